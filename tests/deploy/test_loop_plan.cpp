// The launcher's plan: the pods' scene and the client's run settings are
// bound from those programs' own flag tables and forwarded through them, so
// what a process reads back is what the launcher was given.
#include <gtest/gtest.h>

#include <algorithm>
#include <optional>
#include <string>
#include <vector>

#include "config/command_line.h"
#include "deploy/loop_plan.h"

namespace holofuse::deploy {
namespace {

LoopPlan planOf(std::vector<std::string> flags) {
  flags.insert(flags.begin(), "holofuse_loop");
  std::vector<char*> argv;
  for (std::string& flag : flags) argv.push_back(flag.data());
  LoopPlan plan;
  const auto exit_code = parseLoopFlags(static_cast<int>(argv.size()), argv.data(), plan);
  EXPECT_FALSE(exit_code.has_value()) << "the flags were refused";
  return plan;
}

// What a process reading table makes of command (its program first),
// every flag of other tables left aside.
template <typename S>
S readBack(const std::vector<Setting<S>>& table, const std::vector<std::string>& command) {
  CLI::App app;
  app.allow_extras();
  const SettingFlags<S> flags(app, table);
  std::vector<std::string> reversed(command.rbegin(), command.rend() - 1);
  app.parse(reversed);
  S settings;
  flags.apply(settings);
  return settings;
}

template <typename S>
void expectSame(const std::vector<Setting<S>>& table, const S& read, const S& given) {
  for (const Setting<S>& setting : table)
    EXPECT_EQ(setting.get(read), setting.get(given)) << setting.flag;
}

TEST(LoopPlan, EachClientReadsBackTheRunTheLauncherWasGiven) {
  const LoopPlan plan = planOf({"--mode", "montage4d", "--view", "pod:2", "--frames-ahead", "3",
                                "--overlap-render", "off", "--device", "lavapipe"});
  EXPECT_EQ(plan.client.mode, render::BlendMode::kMontage4D);
  EXPECT_EQ(plan.client.frames_ahead, 3u);
  const auto read = readBack(render::clientRunFlags(), clientCommand(plan, "127.0.0.1:1", 0));
  expectSame(render::clientRunFlags(), read, plan.client);
  EXPECT_EQ(read.view, "pod:2");
  EXPECT_EQ(read.device, "lavapipe");
}

// --record-layers with several clients: a folder each, as their pictures.
TEST(LoopPlan, EachClientRecordsItsLayersIntoAFolderOfItsOwn) {
  const LoopPlan one = planOf({"--record-layers", "/tmp/layers"});
  EXPECT_EQ(readBack(render::clientRunFlags(), clientCommand(one, "127.0.0.1:1", 0)).record_layers,
            "/tmp/layers");
  const LoopPlan two = planOf({"--clients", "2", "--record-layers", "/tmp/layers"});
  for (int c = 0; c < 2; ++c) {
    EXPECT_EQ(
        readBack(render::clientRunFlags(), clientCommand(two, "127.0.0.1:1", c)).record_layers,
        "/tmp/layers/client" + std::to_string(c));
  }
}

// A soak's clients render until the soak stops them: no frame count, so
// their progress lines give no made-up total.
TEST(LoopPlan, ASoaksClientsRenderUntilStopped) {
  auto framesOf = [](const std::vector<std::string>& args) {
    const auto flag = std::find(args.begin(), args.end(), "--frames");
    return flag != args.end() && flag + 1 != args.end() ? *(flag + 1) : std::string("absent");
  };
  EXPECT_EQ(framesOf(clientCommand(planOf({"--frames", "12"}), "127.0.0.1:1", 0)), "12");
  EXPECT_EQ(framesOf(clientCommand(planOf({"--soak-minutes", "3"}), "127.0.0.1:1", 0)), "0");
}

// Soak settings that cannot run are refused before anything starts, with
// exit code 2 and a line that names them.
TEST(LoopPlan, SoakSettingsThatCannotRunAreRefusedByName) {
  const auto refusal = [](std::vector<std::string> flags) {
    flags.insert(flags.begin(), "holofuse_loop");
    std::vector<char*> argv;
    for (std::string& flag : flags) argv.push_back(flag.data());
    LoopPlan plan;
    testing::internal::CaptureStderr();
    const auto exit_code = parseLoopFlags(static_cast<int>(argv.size()), argv.data(), plan);
    const std::string said = testing::internal::GetCapturedStderr();
    EXPECT_EQ(exit_code, std::optional<int>(2)) << said;
    return said;
  };
  EXPECT_NE(refusal({"--churn"}).find("--churn needs --soak-minutes"), std::string::npos);
  EXPECT_NE(refusal({"--profile"}).find("--profile needs --soak-minutes"), std::string::npos);
  EXPECT_NE(refusal({"--soak-minutes", "2", "--warmup-minutes", "2"})
                .find("--warmup-minutes 2 leaves nothing of a 2-minute soak"),
            std::string::npos);
  // Together, where they can, they run: a churn in a rig cuts links too.
  EXPECT_TRUE(planOf({"--soak-minutes", "5", "--churn", "--netns", "--profile"}).churn);
}

TEST(LoopPlan, EachPodAndTheJudgeReadBackTheSceneTheLauncherWasGiven) {
  const LoopPlan plan = planOf({"--scene", "fast-motion", "--seed", "18446744073709551615",
                                "--noise", "0.5", "--fps", "7.5", "--quality"});
  ASSERT_TRUE(plan.scene.seed.has_value());
  EXPECT_EQ(*plan.scene.seed, 18446744073709551615u) << "a 64-bit seed keeps every digit";
  EXPECT_EQ(plan.shape.pods, plan.scene.preset().cameras) << "the scene's camera count";
  for (int pod : {0, plan.shape.pods - 1}) {
    const auto read = readBack(scene::sceneFlags(), podCommand(plan, pod, "127.0.0.1:1"));
    expectSame(scene::sceneFlags(), read, plan.scene);
    EXPECT_EQ(read.options().noise_amplitude, 0.5);
    const auto shape = readBack(rigShapeFlags(), podCommand(plan, pod, "127.0.0.1:1"));
    expectSame(rigShapeFlags(), shape, plan.shape);
    EXPECT_EQ(shape.fps, 7.5);
  }
  // The judge's command is one shell word of the client's --judge.
  const auto client = clientCommand(plan, "127.0.0.1:1", 0);
  const auto judge = std::find(client.begin(), client.end(), "--judge");
  ASSERT_NE(judge, client.end());
  EXPECT_NE(judge[1].find("'--seed' '18446744073709551615'"), std::string::npos) << judge[1];
  EXPECT_NE(judge[1].find("'--scene' 'fast-motion'"), std::string::npos) << judge[1];
  EXPECT_NE(judge[1].find("'--fps' '7.5'"), std::string::npos) << judge[1];
}

// Unset, the seed and the noise reach no pod: each keeps its scene's.
TEST(LoopPlan, ASceneSeedAndNoiseNotGivenAreLeftToTheScene) {
  const LoopPlan plan = planOf({"--scene", "studio"});
  const auto pod = podCommand(plan, 0, "127.0.0.1:1");
  EXPECT_EQ(std::find(pod.begin(), pod.end(), "--seed"), pod.end());
  EXPECT_EQ(std::find(pod.begin(), pod.end(), "--noise"), pod.end());
  const scene::SceneChoice read = readBack(scene::sceneFlags(), pod);
  EXPECT_EQ(read.options().seed, plan.scene.preset().scene.seed);
  EXPECT_EQ(read.options().noise_amplitude, plan.scene.preset().scene.noise_amplitude);
}

}  // namespace
}  // namespace holofuse::deploy

// Each program's settings table: what the launcher passes on is what the
// process reads back, and one flag sets the pods and the server alike.
#include <gtest/gtest.h>

#include <cmath>

#include "config/command_line.h"
#include "eval/loop_settings.h"

namespace holofuse::eval {
namespace {

// A value of setting other than the default's: a choice not the default,
// or a number inside the range away from the default.
std::string otherValue(const Setting<LoopSettings>& setting) {
  const std::string now = setting.get(LoopSettings{});
  if (!setting.choices.empty())
    return setting.choices[0] != now ? setting.choices[0] : setting.choices[1];
  for (const double v : {setting.max, setting.min, std::floor((setting.min + setting.max) / 2)}) {
    LoopSettings probe;
    const std::string text = formatNumber(v);
    if (setting.set(probe, text).empty() && setting.get(probe) != now) return text;
  }
  return "";
}

// Every setting moved from its default reaches its process: the arguments
// each program is given, parsed by that program's own table, give back
// the same struct.
TEST(LoopSettings, WhatTheLauncherPassesOnIsWhatEachProcessReadsBack) {
  for (const Setting<LoopSettings>& moved : loopFlags()) {
    LoopSettings given;
    const std::string value = otherValue(moved);
    ASSERT_FALSE(value.empty()) << moved.flag;
    ASSERT_EQ(moved.set(given, value), "") << moved.flag << " " << value;
    auto read_back = [](const auto& table, const std::vector<std::string>& arguments, auto& into) {
      CLI::App app;
      const SettingFlags flags(app, table);
      std::vector<std::string> reversed(arguments.rbegin(), arguments.rend());
      app.parse(reversed);
      flags.apply(into);
    };
    LoopSettings read;
    read_back(podEncodingFlags(), podArguments(given), read.pods);
    read_back(fusion::fusionFlags(), serverArguments(given), read.fusion);
    read_back(render::renderFlags(), clientArguments(given), read.render);
    for (const Setting<LoopSettings>& setting : loopFlags()) {
      EXPECT_EQ(setting.get(read), setting.get(given))
          << moved.flag << " " << value << ": " << setting.flag;
    }
    const size_t passed =
        podArguments(given).size() + serverArguments(given).size() + clientArguments(given).size();
    const std::string takers = loopFlagTakers(moved.flag);
    EXPECT_EQ(passed, takers == "pods and server" ? 4u : 2u)
        << moved.flag << ": only what differs from the defaults is passed on, to " << takers;
  }
}

TEST(LoopSettings, TheImageCodecIsOneFlagForThePodsAndTheServer) {
  LoopSettings settings;
  ASSERT_EQ(findSetting(loopFlags(), "--image-codec")->set(settings, "raw"), "");
  EXPECT_EQ(settings.fusion.image_codec, protocol::Codec::kRaw);
  EXPECT_EQ(settings.pods.color_codec, protocol::Codec::kRaw);
  EXPECT_EQ(podArguments(settings), (std::vector<std::string>{"--codec", "raw"}))
      << "under the pods' own name";
  EXPECT_EQ(findSetting(loopFlags(), "--codec"), nullptr);
  EXPECT_EQ(loopFlagTakers("--crop-margin"), "pods");
  EXPECT_EQ(loopFlagTakers("--voxel"), "server");
  EXPECT_EQ(loopFlagTakers("--alpha"), "client");
}

TEST(LoopSettings, AValueOutsideItsRangeIsRefusedAtParseNamingTheFlag) {
  CLI::App app;
  const SettingFlags flags(app, loopFlags());
  try {
    app.parse(std::vector<std::string>{"0.9", "--voxel"});
    ADD_FAILURE() << "--voxel 0.9 was taken";
  } catch (const CLI::ValidationError& e) {
    EXPECT_NE(std::string(e.what()).find("--voxel"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("[0.0001, 0.5]"), std::string::npos) << e.what();
  }
  LoopSettings settings;
  EXPECT_NE(findSetting(loopFlags(), "--geodesic-passes")->set(settings, "2.5"), "")
      << "a whole-number setting refuses a fraction";
  EXPECT_EQ(findSetting(loopFlags(), "--hull-error-mm")->set(settings, "1.5"), "")
      << "this one takes fractions";
}

}  // namespace
}  // namespace holofuse::eval

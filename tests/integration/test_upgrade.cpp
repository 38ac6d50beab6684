// A rolling upgrade, for real: pods, server and client of one rig on two
// releases at once. The older release is the same programs held to its
// newest protocol minor (--protocol 1.4: the first with authentication),
// which is what an older binary offers in its Hello; each connection
// negotiates its own version (SPEC.md section 3), so the rig keeps serving
// while its hosts are upgraded one at a time, in either order.
#include <gtest/gtest.h>
#include <signal.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "loop_test.h"
#include "protocol/frame.h"

namespace holofuse {
namespace {

using namespace holofuse::test;

const std::string kOldRelease = "1.4";

size_t countIn(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

// Pods of the old release feed a new server and client; then each pod is
// stopped and started again on the new release while the client renders.
// Every step is seen by the event it needs: the server's log of the join,
// the client's next pictures.
TEST(Upgrade, OldPodsFeedANewServerAndAreUpgradedOneByOneWhileTheClientRenders) {
  const fs::path out = freshDir("upgrade_pods");
  pid_t server = 0;
  const std::string endpoint = startServer(out, 2, &server);
  ASSERT_FALSE(endpoint.empty()) << readFile(out / "server.log");
  std::vector<pid_t> pods = {
      startSmallPod(endpoint, 0, 2, out, {"--protocol", kOldRelease}, "pod0_old.log"),
      startSmallPod(endpoint, 1, 2, out, {"--protocol", kOldRelease}, "pod1_old.log")};
  const fs::path client_out = out / "client";
  const pid_t client = spawn({kBin + "/render_client", "--server", endpoint, "--out",
                              client_out.string(), "--frames", "100000", "--size", "64x48"},
                             out / "client.log");
  auto serverSays = [&](const std::string& what, size_t times) {
    return waitFor([&] { return countIn(readFile(out / "server.log"), what) >= times; });
  };
  auto morePictures = [&](size_t more) {
    const size_t from = picturesIn(client_out);
    return waitFor([&] { return picturesIn(client_out) >= from + more; });
  };
  ASSERT_TRUE(serverSays("joined, protocol 1.4", 2)) << readFile(out / "server.log");
  ASSERT_TRUE(morePictures(5)) << readFile(out / "client.log");
  for (int id = 0; id < 2; ++id) {
    kill(pods[id], SIGTERM);
    EXPECT_EQ(waitExit(pods[id], 20), 0) << "pod " << id << " of the old release";
    pods[id] = startSmallPod(endpoint, id, 2, out, {}, "pod" + std::to_string(id) + "_new.log");
    ASSERT_TRUE(serverSays("joined, protocol 1." + std::to_string(protocol::kVersionMinor),
                           static_cast<size_t>(id) + 2))
        << readFile(out / "server.log");
    ASSERT_TRUE(morePictures(5)) << "after pod " << id << " was upgraded\n"
                                 << readFile(out / "client.log");
  }
  kill(client, SIGTERM);
  EXPECT_EQ(waitExit(client, 30), 0) << readFile(out / "client.log");
  for (pid_t pid : pods) kill(pid, SIGTERM);
  for (pid_t pid : pods) EXPECT_EQ(waitExit(pid, 20), 0);
  kill(server, SIGTERM);
  EXPECT_EQ(waitExit(server, 20), 0);
  // On the new release the pods' clocks are measured (1.8); the report
  // carries the last Stats, sent after both were upgraded.
  const auto report = nlohmann::json::parse(readFile(client_out / "report.json"));
  const auto& hosts = report["clocks"]["hosts"];
  for (const char* host : {"pod_0", "pod_1", "client"}) {
    ASSERT_TRUE(hosts.contains(host)) << report["clocks"].dump();
    EXPECT_TRUE(hosts[host]["measured"].get<bool>()) << host;
  }
  EXPECT_GE(report["frames_rendered"].get<int>(), 15);
  EXPECT_TRUE(report["frames_skipped"].empty()) << report["frames_skipped"].dump();
}

// The reverse: the server is the old release; new pods and a new client
// agree on its version, get no clock probes (they came with 1.8), and the
// client renders every frame it asked for.
TEST(Upgrade, NewPodsAndClientJoinAServerOfTheOldRelease) {
  const fs::path out = freshDir("upgrade_server");
  pid_t server = 0;
  const std::string endpoint = startServer(out, 2, &server, {"--protocol", kOldRelease});
  ASSERT_FALSE(endpoint.empty()) << readFile(out / "server.log");
  const std::vector<pid_t> pods = {startSmallPod(endpoint, 0, 2, out),
                                   startSmallPod(endpoint, 1, 2, out)};
  const fs::path client_out = out / "client";
  constexpr int kFrames = 8;
  const pid_t client =
      spawn({kBin + "/render_client", "--server", endpoint, "--out", client_out.string(),
             "--frames", std::to_string(kFrames), "--size", "64x48"},
            out / "client.log");
  EXPECT_EQ(waitExit(client, 120), 0) << readFile(out / "client.log");
  for (pid_t pid : pods) kill(pid, SIGTERM);
  for (pid_t pid : pods) EXPECT_EQ(waitExit(pid, 20), 0);
  kill(server, SIGTERM);
  EXPECT_EQ(waitExit(server, 20), 0);
  const std::string log = readFile(out / "server.log");
  EXPECT_EQ(countIn(log, "joined, protocol 1.4, authenticated"), 3u) << log;
  EXPECT_EQ(countIn(log, "'s clock against ours"), 0u) << "no probes below 1.8\n" << log;
  const auto report = nlohmann::json::parse(readFile(client_out / "report.json"));
  EXPECT_EQ(report["frames_rendered"].get<int>(), kFrames);
  for (const char* host : {"pod_0", "pod_1", "client"}) {
    ASSERT_TRUE(report["clocks"]["hosts"].contains(host)) << report["clocks"].dump();
    EXPECT_FALSE(report["clocks"]["hosts"][host]["measured"].get<bool>()) << host;
  }
}

}  // namespace
}  // namespace holofuse

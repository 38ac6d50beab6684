// Hosts whose clocks disagree: pods started in time namespaces of their own
// (CLOCK_MONOTONIC shifted by seconds, as on another capture PC) against a
// real server and client on this clock. The server measures each pod's
// offset with clock probes (protocol 1.8) and moves its stamps onto its own
// clock, so the budget stays right: without that, a pod 5 s behind would
// make every frame's end-to-end latency 5 s, and the send stage of a pod
// ahead would end before it starts.
#include <gtest/gtest.h>
#include <signal.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "base/process.h"
#include "loop_test.h"

namespace holofuse {
namespace {

using namespace holofuse::test;

const std::string kUnshare = "/usr/bin/unshare";  // util-linux

// Whether this process may make time namespaces (Linux 5.6 and
// CAP_SYS_ADMIN); the reason when not.
std::string timeNamespacesRefused() {
  if (!fs::exists(kUnshare)) return kUnshare + " is missing (Debian's util-linux)";
  const fs::path log = freshDir("clocks_probe") / "unshare.log";
  const pid_t pid = spawn({kUnshare, "--time", "--fork", "--monotonic", "1", "/bin/true"}, log);
  const int code = pid > 0 ? waitExit(pid, 20) : -1;
  return code == 0 ? "" : "unshare --time exited " + std::to_string(code) + ": " + readFile(log);
}

// A pod whose CLOCK_MONOTONIC reads shift_s seconds off this host's. Frame
// ids come from CLOCK_REALTIME, which a time namespace leaves alone (a rig
// keeps it in step with chrony or PTP).
pid_t startShiftedPod(const std::string& endpoint, int id, int shift_s, const fs::path& out) {
  return spawn({kUnshare, "--time", "--fork", "--kill-child=TERM", "--monotonic",
                std::to_string(shift_s), kBin + "/capture_node", "--server", endpoint, "--pod-id",
                std::to_string(id), "--pods", "3", "--size", "64x48", "--fps", "10"},
               out / ("pod" + std::to_string(id) + ".log"));
}

// How many peers' clock estimates the server's log gives.
size_t clocksTold(const std::string& log) {
  size_t told = 0;
  for (size_t at = log.find("'s clock against ours: "); at != std::string::npos;
       at = log.find("'s clock against ours: ", at + 1))
    ++told;
  return told;
}

TEST(Clocks, PodsOnClocksSecondsApartKeepTheBudgetOnTheServersClock) {
  if (const std::string refused = timeNamespacesRefused(); !refused.empty())
    GTEST_SKIP() << "time namespaces are not permitted here, so no pod can run on another "
                    "clock: "
                 << refused;
  const fs::path out = freshDir("clocks_shifted");
  pid_t server = 0;
  const std::string endpoint = startServer(out, 3, &server);
  ASSERT_FALSE(endpoint.empty()) << readFile(out / "server.log");
  // Pod 0 on this clock, pod 1 five seconds behind, pod 2 three ahead.
  const std::vector<pid_t> pods = {startShiftedPod(endpoint, 0, 0, out),
                                   startShiftedPod(endpoint, 1, -5, out),
                                   startShiftedPod(endpoint, 2, 3, out)};
  // The client joins once the server has placed every pod on its clock, so
  // the frames it renders are fused from stamps the server could place (a
  // loaded machine can keep a pod's first probe answer behind several of
  // its frames).
  const fs::path server_log = out / "server.log";
  ASSERT_TRUE(test::waitFor([&] { return clocksTold(readFile(server_log)) >= 3; }))
      << readFile(server_log);
  constexpr int kFrames = 20;
  const pid_t client =
      spawn({kBin + "/render_client", "--server", endpoint, "--out", (out / "client").string(),
             "--frames", std::to_string(kFrames), "--size", "64x48"},
            out / "client.log");
  const int client_exit = waitExit(client, 240);
  // unshare waits out its child whatever it is sent but SIGKILL; killed,
  // it hands the pod SIGTERM (--kill-child), and the pod says Bye.
  for (pid_t pid : pods) kill(pid, SIGKILL);
  for (pid_t pid : pods) waitExit(pid, 20);
  kill(server, SIGTERM);
  waitExit(server, 20);
  ASSERT_EQ(client_exit, 0) << readFile(out / "client.log");

  const auto report = nlohmann::json::parse(readFile(out / "client" / "report.json"));
  // The budget: end to end and the stages that cross hosts are times on
  // one clock, under a second on loopback.
  const auto& latency = report["latency_ms"];
  EXPECT_GT(latency["end_to_end"]["p50"].get<double>(), 0.0);
  EXPECT_LT(latency["end_to_end"]["p95"].get<double>(), 2000.0) << latency.dump();
  const auto& send = latency["stages"]["send"];
  EXPECT_LT(send["p95"].get<double>(), 1000.0) << send.dump();
  // A send stamp that ended before it started is left out: without the
  // clocks' offsets, the pod 3 s ahead loses all its kFrames. Every other
  // camera present in a rendered mesh (a loaded machine delivers some
  // late: frames[].cameras_present) has its own, but for a frame decoded
  // before its pod's estimate, and a send shorter than the estimate's
  // uncertainty (on loopback both are about 0.1 ms, so a few come out
  // negative): fewer than half a pod's frames in all.
  int present = 0;
  for (const auto& frame : report["frames"]) present += frame["cameras_present"].get<int>();
  EXPECT_LE(send["samples"].get<int>(), present) << send.dump();
  EXPECT_GT(send["samples"].get<int>(), present - kFrames / 2)
      << send.dump() << ", present " << present;
  EXPECT_GE(present, 2 * kFrames) << "most groups fused whole";

  // Each pod's offset as the server measured it: the shift, within the
  // stated uncertainty (both ways of a probe take a time >= 0, so the true
  // offset lies within the estimate +- half the round trip).
  const auto& hosts = report["clocks"]["hosts"];
  const std::pair<const char*, double> truths[] = {
      {"pod_0", 0.0}, {"pod_1", -5000.0}, {"pod_2", 3000.0}, {"client", 0.0}};
  for (const auto& [host, truth_ms] : truths) {
    ASSERT_TRUE(hosts.contains(host)) << report["clocks"].dump();
    const auto& clock = hosts[host];
    ASSERT_TRUE(clock["measured"].get<bool>()) << host;
    const double offset = clock["offset_ms"].get<double>();
    const double uncertainty = clock["uncertainty_ms"].get<double>();
    EXPECT_LE(std::abs(offset - truth_ms), uncertainty + 0.001)
        << host << ": " << offset << " +- " << uncertainty << " ms, truth " << truth_ms;
    EXPECT_LT(uncertainty, 250.0) << host << ": a loopback round trip";
    EXPECT_FALSE(clock["drifted"].get<bool>()) << host;
  }
  EXPECT_TRUE(report["clocks"]["warnings"].empty()) << report["clocks"].dump();
  // The server's log gives each peer's estimate once its burst is in: the
  // three pods' and the client's.
  const std::string log = readFile(server_log);
  EXPECT_EQ(clocksTold(log), 4u) << log;
}

}  // namespace
}  // namespace holofuse

// Faults a rig meets in hours on a shared LAN, with real processes on
// loopback (issue 21's table, SECURITY.md): hostile peers all at once,
// peers killed with SIGKILL and started again, a client stopped with
// SIGSTOP. Each test asserts what the server keeps (its memory and
// descriptors against a baseline taken in the same run), that the honest
// peers are still served, and what the log names. Every wait is for an
// event (a picture written, a line logged, a socket closed), with a limit
// that only a failure reaches.
#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <thread>

#include "base/process.h"
#include "codec/pod_frame_codec.h"
#include "geometry/camera.h"
#include "insider_attacks.h"
#include "loop_test.h"
#include "peer_by_hand.h"
#include "protocol/socket.h"

namespace holofuse {
namespace {

using namespace holofuse::test;

constexpr int kWidth = test::kSmallWidth, kHeight = test::kSmallHeight;

// The memory bounds hold for the program, not for a sanitized build of it
// (kSanitized): there ASan's quarantine keeps freed blocks resident.
void expectPeakGrowthBelow(const ProcessUsage& after, const ProcessUsage& baseline, uint64_t kb,
                           const std::string& what) {
  if (kSanitized) return;
  EXPECT_LT(after.peak_rss_kb, baseline.peak_rss_kb + kb)
      << what << ": baseline peak " << baseline.peak_rss_kb << " kB, after " << after.peak_rss_kb
      << " kB";
}

ProcessUsage usageOf(pid_t pid) {
  const auto usage = processUsage(pid);
  EXPECT_TRUE(usage.has_value()) << "process " << pid << " is gone";
  return usage.value_or(ProcessUsage{});
}

void stopAll(const std::vector<pid_t>& pids) {
  for (pid_t pid : pids) {
    kill(pid, SIGCONT);
    kill(pid, SIGTERM);
  }
  for (pid_t pid : pids) waitExit(pid, 20);
}

// What a pod with this calibration would send, frame by frame.
struct ForgedPod {
  Camera camera = ringCameras(4, 2.5, 1.0, {0, 1, 0}, kWidth, kHeight, 50)[0];
  Image8 color{kWidth, kHeight, 3, 90}, mask{kWidth, kHeight, 1, 255},
      feather{kWidth, kHeight, 1, 255};
  protocol::OutgoingFrame frame(uint32_t pod, uint64_t frame_id) {
    return test::wholePodFrame(pod, frame_id, color, mask, feather);
  }
};

// Every attack of issue 21's table at once, against a server serving two
// honest pods and a client: connections claiming 60 MiB before and after
// admission, a crowd that trickles one byte and never finishes its
// handshake, a pod on another clock, a pod whose planes claim 4096x4096
// where its calibration says 64x48. The server's peak memory grows by
// little, every attacker is refused or closed by name, and the client goes
// on rendering the honest pods' frames.
TEST(Faults, HostilePeersAllAtOnceLeaveTheServerSmallAndTheRigServed) {
  const fs::path out = freshDir("faults_hostile");
  pid_t server = 0;
  const std::string endpoint = startServer(out, 4, &server,
                                           {"--handshake-timeout-ms", "1000", "--max-handshaking",
                                            "100", "--max-handshaking-per-address", "100"});
  ASSERT_FALSE(endpoint.empty()) << readFile(out / "server.log");
  const std::vector<pid_t> pods = {startSmallPod(endpoint, 0, 4, out),
                                   startSmallPod(endpoint, 1, 4, out)};
  const pid_t client = startSmallClient(endpoint, out, "client", 400);
  ASSERT_TRUE(waitFor([&] { return picturesIn(out / "client") >= 2; }))
      << readFile(out / "client.log");
  const ProcessUsage baseline = usageOf(server);
  auto parsed = protocol::parseEndpoint(endpoint);
  ASSERT_TRUE(parsed.isOk());

  // A header claiming a 60 MiB payload.
  const uint8_t claim[protocol::kHeaderSize] = {'H', 'F', 'U', 'S', 1, 4, 1,    0,
                                                0,   0,   0,   0,   0, 0, 0xC0, 0x03};
  // Admitted clients claiming 60 MiB of something that is not theirs.
  std::vector<std::unique_ptr<protocol::Connection>> claimers;
  for (uint32_t id = 10; id < 20; ++id) {
    claimers.push_back(admittedByHand(endpoint, protocol::Role::kClient, id));
    ASSERT_NE(claimers.back(), nullptr) << readFile(out / "server.log");
    ASSERT_EQ(::write(claimers.back()->fd(), claim, sizeof(claim)),
              static_cast<ssize_t>(sizeof(claim)));
  }
  // Pod 2 on another clock: frame ids a billion ahead of the rig's.
  ForgedPod forged;
  auto other_clock = admittedByHand(endpoint, protocol::Role::kPod, 2);
  ASSERT_NE(other_clock, nullptr);
  Camera camera2 = forged.camera;
  camera2.id = 2;
  other_clock->sendMessage(toCalibration(camera2));
  for (uint64_t i = 0; i < 5; ++i)
    other_clock->send(
        std::make_shared<protocol::OutgoingFrame>(forged.frame(2, 1000000000000ull + i)));
  flush(*other_clock);
  // Pod 3's bomb: a colour plane claiming 4096x4096 (48 MiB once
  // decompressed) under a 64x48 calibration.
  auto bomb = admittedByHand(endpoint, protocol::Role::kPod, 3);
  ASSERT_NE(bomb, nullptr);
  Camera camera3 = forged.camera;
  camera3.id = 3;
  bomb->sendMessage(toCalibration(camera3));
  // Its LZ4 data is a few bytes: what matters is the size it states.
  const std::vector<uint8_t> few(64, 0x11);
  protocol::Plane huge;
  huge.kind = protocol::PlaneKind::kColor;
  huge.codec = protocol::Codec::kLz4;
  huge.format = protocol::PixelFormat::kRgb8;
  huge.width = huge.height = 4096;
  huge.raw_size = 4096u * 4096u * 3u;
  huge.data = few;
  protocol::PodFrame lie;
  lie.frame_id = 1;
  lie.camera_id = 3;
  lie.planes = {huge};
  bomb->sendMessage(lie);
  flush(*bomb);

  // Then strangers, each given a handshake slot here (past
  // --max-handshaking-per-address they would be refused at once, as
  // Limits.PastTheHandshakeCapForOneAddress... tests): 40 headers claiming
  // 60 MiB, 40 that send one byte of a header and wait.
  std::vector<std::unique_ptr<protocol::Connection>> strangers;
  for (int i = 0; i < 80; ++i) {
    auto socket = protocol::connectTcp(*parsed, 5000);
    ASSERT_TRUE(socket.isOk()) << socket.status().toString();
    strangers.push_back(std::make_unique<protocol::Connection>(std::move(*socket), "stranger"));
    const size_t bytes = i < 40 ? sizeof(claim) : 1;
    ASSERT_EQ(::write(strangers.back()->fd(), claim, bytes), static_cast<ssize_t>(bytes));
  }
  // Each is refused or closed, by name.
  for (size_t i = 0; i < strangers.size(); ++i) {
    Status closed;
    protocol::Frame last = nextFrame(*strangers[i], &closed);
    while (!last.bytes.empty()) last = nextFrame(*strangers[i], &closed);
    EXPECT_FALSE(closed.isOk()) << "stranger " << i << " still open after 10 s";
  }
  for (auto* attacker : {&bomb, &claimers.front()}) {
    Status closed;
    while (!nextFrame(**attacker, &closed).bytes.empty()) {
    }
    EXPECT_FALSE(closed.isOk()) << "closed by the server";
  }
  const fs::path log = out / "server.log";
  EXPECT_TRUE(waitFor([&] { return logSays(log, "does it run on another clock?"); }))
      << readFile(log);
  // The honest pods and the client are still served: more pictures come.
  const size_t before = picturesIn(out / "client");
  EXPECT_TRUE(waitFor([&] { return picturesIn(out / "client") >= before + 5; }))
      << readFile(out / "client.log");
  // 130 hostile peers held nothing of size: the peak grew by less than
  // 32 MiB (one 60 MiB claim, or the bomb's 48 MiB, would exceed it).
  expectPeakGrowthBelow(usageOf(server), baseline, 32 * 1024, "the server after 130 hostile peers");
  stopAll({client});
  stopAll(pods);
  kill(server, SIGTERM);
  EXPECT_EQ(waitExit(server, 10), 0);
  const std::string text = readFile(log);
  EXPECT_NE(text.find("above cap 256"), std::string::npos) << text;
  EXPECT_NE(text.find("no handshake within 1000 ms"), std::string::npos) << text;
  EXPECT_NE(text.find("62914560 bytes above cap 65536"), std::string::npos) << text;
  EXPECT_NE(text.find("calibration says 64x48"), std::string::npos) << text;
  EXPECT_EQ(text.find("closing pod 0"), std::string::npos) << "an honest pod was closed\n" << text;
  EXPECT_EQ(text.find("closing pod 1"), std::string::npos) << "an honest pod was closed\n" << text;
  fs::remove_all(out);
}

// A pod writes its Calibration and its first PodFrame as one burst: on
// loopback the server reads both in one turn. The PodFrame (noise at
// 320x240, far above the 64 KiB every message but a PodFrame may have) is
// judged by the cap its calibration sets once the server has handled it,
// not by the one in force when its header was read: the pod is served.
TEST(Faults, APodsCalibrationAndLargeFirstFrameInOneBurstAreBothTaken) {
  const fs::path out = freshDir("faults_one_burst");
  pid_t server = 0;
  const std::string endpoint = startServer(out, 1, &server);
  ASSERT_FALSE(endpoint.empty()) << readFile(out / "server.log");
  constexpr int kBigWidth = 320, kBigHeight = 240;
  Camera camera = ringCameras(1, 2.5, 1.0, {0, 1, 0}, kBigWidth, kBigHeight, 50)[0];
  camera.id = 0;
  Image8 color{kBigWidth, kBigHeight, 3, 0}, mask{kBigWidth, kBigHeight, 1, 255},
      feather{kBigWidth, kBigHeight, 1, 255};
  uint32_t state = 12345;  // noise: LZ4 cannot shrink it below the cap
  for (auto& byte : color.pixels)
    byte = static_cast<uint8_t>((state = state * 1664525u + 1013904223u) >> 24);
  PodPlanes planes;
  planes.frame_id = 1;
  planes.color = &color;
  planes.mask = &mask;
  planes.feather = &feather;
  PodEncoding whole;
  whole.crop_margin = kFullFrame;
  std::vector<protocol::StageStamp> stamps;
  auto frame = std::make_shared<protocol::OutgoingFrame>(encodePodFrame(planes, stamps, 0, whole));
  ASSERT_GT(frame->size(), size_t{64u << 10} + protocol::kHeaderSize);

  auto pod = admittedByHand(endpoint, protocol::Role::kPod, 0);
  ASSERT_NE(pod, nullptr) << readFile(out / "server.log");
  pod->sendMessage(toCalibration(camera));
  pod->send(frame);
  // The server answers a probe only after it has handled what came before.
  pod->sendMessage(protocol::ClockProbe{protocol::ProbeStep::kRequest, 1, 0, 0});
  flush(*pod);
  Status closed;
  bool answered = false;
  while (!answered) {
    const protocol::Frame reply = nextFrame(*pod, &closed);
    if (reply.bytes.empty()) break;  // closed, or nothing within 10 s
    protocol::ClockProbe probe;
    answered = reply.header.type == static_cast<uint16_t>(protocol::MessageType::kClockProbe) &&
               protocol::decodeFrame(reply, probe).isOk() && probe.origin_ns == 1;
  }
  EXPECT_TRUE(answered) << closed.toString() << "\n" << readFile(out / "server.log");
  {
    const std::string text = readFile(out / "server.log");
    EXPECT_EQ(text.find("closing pod 0"), std::string::npos) << text;
  }
  // A header held back behind a Heartbeat is judged once the Heartbeat is
  // handled, not when the peer writes again: a PodFrame claiming 60 MiB,
  // and then silence, is refused by name at once (not at the idle timeout).
  protocol::Bytes burst = protocol::encodeFrame(protocol::Heartbeat{}, 99);
  const uint8_t claim[protocol::kHeaderSize] = {'H', 'F', 'U', 'S', 1, 9, 5,    0,
                                                0,   0,   0,   0,   0, 0, 0xC0, 0x03};
  burst.insert(burst.end(), std::begin(claim), std::end(claim));
  ASSERT_EQ(::write(pod->fd(), burst.data(), burst.size()), static_cast<ssize_t>(burst.size()));
  protocol::ErrorMessage error;
  ASSERT_TRUE(protocol::decodeFrame(test::nextError(*pod), error).isOk())
      << readFile(out / "server.log");
  EXPECT_NE(error.message.find("62914560 bytes above cap"), std::string::npos) << error.message;
  kill(server, SIGTERM);
  EXPECT_EQ(waitExit(server, 10), 0);
  fs::remove_all(out);
}

// The server on a port of the test's choosing, so a restart finds the
// same address; waits for its "listening" line. A peer silent for
// idle_timeout_ms is closed: short, so that dead peers go quickly.
pid_t serverOnPort(uint16_t port, const fs::path& out, int pods, const std::string& log,
                   const std::vector<std::string>& extra = {}, int idle_timeout_ms = 2000) {
  std::vector<std::string> argv = {
      kBin + "/fusion_server", "--listen",          "127.0.0.1:" + std::to_string(port), "--pods",
      std::to_string(pods),    "--idle-timeout-ms", std::to_string(idle_timeout_ms)};
  argv.insert(argv.end(), extra.begin(), extra.end());
  const pid_t pid = spawn(argv, out / log);
  EXPECT_TRUE(waitFor([&] { return logSays(out / log, "listening"); }, 30)) << readFile(out / log);
  return pid;
}

// Memory a restart gave back: the resident size now is within 10% (and
// 4 MiB) of the high-water mark before. Not of the resident size before:
// a sample lands anywhere between a trough and a frame's worth of buffers
// in flight (measured 31-37 MB for the same warmed-up server), while what
// a peer left behind raises the trough above the old peak. Returns what
// was too much, or nothing.
std::string residentGrowth(const ProcessUsage& now, const ProcessUsage& baseline) {
  if (kSanitized) return {};  // memory figures are the sanitizer's (kSanitized)
  if (now.rss_kb <= baseline.peak_rss_kb + std::max<uint64_t>(baseline.peak_rss_kb / 10, 4096))
    return {};
  return "resident memory " + std::to_string(baseline.rss_kb) + " kB before (peak " +
         std::to_string(baseline.peak_rss_kb) + " kB), " + std::to_string(now.rss_kb) + " kB after";
}

// The descriptors: back to at most the baseline's. A client writing its
// pictures holds a file open for a moment, in either sample (seen in CI:
// 8 against 7); that one closes, a leaked one stays open.
void expectNear(pid_t pid, const ProcessUsage& baseline, const char* who) {
  EXPECT_TRUE(waitFor([&] { return usageOf(pid).descriptors <= baseline.descriptors; }))
      << who << ": descriptors " << usageOf(pid).descriptors << ", before " << baseline.descriptors;
  const std::string growth = residentGrowth(usageOf(pid), baseline);
  EXPECT_TRUE(growth.empty()) << who << ": " << growth;
}

// SIGKILL, then a start again, of a pod, of the client and of the server:
// each comes back into the rig (the pods and the client find the new
// server with back-off), the client renders again, and the survivors'
// descriptors and memory return to where they were before.
TEST(Faults, PeersKilledAndStartedAgainRejoinAndLeaveNothingBehind) {
  const fs::path out = freshDir("faults_restart");
  const uint16_t port = freePort();
  ASSERT_NE(port, 0);
  const std::string endpoint = "127.0.0.1:" + std::to_string(port);
  pid_t server = serverOnPort(port, out, 2, "server.log");
  std::vector<pid_t> pods = {startSmallPod(endpoint, 0, 2, out),
                             startSmallPod(endpoint, 1, 2, out)};
  pid_t client = startSmallClient(endpoint, out, "client0", 2000);
  ASSERT_TRUE(waitFor([&] { return picturesIn(out / "client0") >= 3; }))
      << readFile(out / "client0.log");
  // A pod, then the client: killed, started again, back in, rendering.
  int restarts = 0;
  auto restartPodAndClient = [&] {
    const int before = usageOf(server).descriptors;
    kill(pods[1], SIGKILL);
    EXPECT_EQ(waitExit(pods[1], 10), 128 + SIGKILL);
    EXPECT_TRUE(waitFor([&] { return usageOf(server).descriptors < before; }))
        << "the server let the dead pod's socket go";
    pods[1] = startSmallPod(endpoint, 1, 2, out);
    EXPECT_TRUE(waitFor([&] { return usageOf(server).descriptors == before; }))
        << readFile(out / "server.log");
    kill(client, SIGKILL);
    EXPECT_EQ(waitExit(client, 10), 128 + SIGKILL);
    const std::string name = "client" + std::to_string(++restarts);
    client = startSmallClient(endpoint, out, name, 2000);
    EXPECT_TRUE(waitFor([&] { return picturesIn(out / name) >= 3; }))
        << readFile(out / (name + ".log"));
    EXPECT_TRUE(waitFor([&] { return usageOf(server).descriptors == before; }))
        << "descriptors: " << usageOf(server).descriptors << ", before " << before;
    return name;
  };
  // Two restarts warm the server's allocator up (each thread's arena).
  // Then two rounds of four: what a restart leaves behind grows the
  // server in both, while the allocator may still grow once, in one of
  // them, on a loaded machine (glibc opens a new arena when a thread finds
  // the others' locks taken).
  restartPodAndClient();
  restartPodAndClient();
  std::string last;
  std::vector<ProcessUsage> rounds = {usageOf(server)};
  for (int round = 0; round < 2; ++round) {
    for (int i = 0; i < 4; ++i) last = restartPodAndClient();
    rounds.push_back(usageOf(server));
    EXPECT_EQ(rounds.back().descriptors, rounds.front().descriptors) << "server: descriptors";
  }
  const std::string first = residentGrowth(rounds[1], rounds[0]);
  const std::string second = residentGrowth(rounds[2], rounds[1]);
  EXPECT_TRUE(first.empty() || second.empty())
      << "the server grew in both rounds of restarts: " << first << "; then " << second;

  // The server: killed and started on the same port; the pods and the
  // client find it again, and hold what they held before.
  const ProcessUsage pod_baseline = usageOf(pods[0]);
  const ProcessUsage client_baseline = usageOf(client);
  kill(server, SIGKILL);
  EXPECT_EQ(waitExit(server, 10), 128 + SIGKILL);
  ASSERT_TRUE(waitFor([&] { return logSays(out / (last + ".log"), "lost"); }))
      << readFile(out / (last + ".log"));
  server = serverOnPort(port, out, 2, "server_again.log");
  ASSERT_TRUE(waitFor([&] {
    const std::string log = readFile(out / "server_again.log");
    return log.find("pod 0") != std::string::npos && log.find("pod 1") != std::string::npos &&
           log.find("client 0") != std::string::npos;
  })) << readFile(out / "server_again.log");
  const size_t seen = picturesIn(out / last);
  EXPECT_TRUE(waitFor([&] { return picturesIn(out / last) >= seen + 3; }))
      << readFile(out / (last + ".log"));
  expectNear(pods[0], pod_baseline, "pod 0 after the server restarted");
  expectNear(client, client_baseline, "the client after the server restarted");
  stopAll({client});
  stopAll(pods);
  kill(server, SIGTERM);
  EXPECT_EQ(waitExit(server, 10), 0);
  fs::remove_all(out);
}

// A client stopped with SIGSTOP reads nothing: the server queues a few of
// its frames, drops the rest, closes it at the idle timeout, and the other
// client renders every frame meanwhile. Continued, the stopped client
// finds the server again and finishes.
TEST(Faults, AStoppedClientNeitherStallsTheOtherNorSwellsTheServer) {
  const fs::path out = freshDir("faults_stop");
  const uint16_t port = freePort();
  ASSERT_NE(port, 0);
  const std::string endpoint = "127.0.0.1:" + std::to_string(port);
  const pid_t server = serverOnPort(port, out, 2, "server.log");
  const std::vector<pid_t> pods = {startSmallPod(endpoint, 0, 2, out),
                                   startSmallPod(endpoint, 1, 2, out)};
  // The other client is running before the stopped one starts, and the
  // stopped one has many more frames to render than it has when it is
  // stopped: at 15 fps a short run could finish, say bye and leave the
  // server nothing to time out while the other one was still starting.
  const pid_t other = startSmallClient(endpoint, out, "other", 2000);
  ASSERT_TRUE(waitFor([&] { return picturesIn(out / "other") >= 2; }))
      << readFile(out / "server.log");
  constexpr int kStoppedFrames = 60;
  const pid_t stopped = startSmallClient(endpoint, out, "stopped", kStoppedFrames);
  ASSERT_TRUE(waitFor([&] { return picturesIn(out / "stopped") >= 2; }))
      << readFile(out / "server.log");
  const ProcessUsage baseline = usageOf(server);
  kill(stopped, SIGSTOP);
  // The signal lands asynchronously: the pictures are counted once the
  // client has stopped (WNOWAIT: its stop or end is left to be seen again).
  siginfo_t info{};
  ASSERT_EQ(waitid(P_PID, static_cast<id_t>(stopped), &info, WSTOPPED | WEXITED | WNOWAIT), 0);
  ASSERT_EQ(info.si_code, CLD_STOPPED) << "the client finished before it could be stopped\n"
                                       << readFile(out / "stopped.log");
  const size_t at_stop = picturesIn(out / "stopped");
  const size_t other_at_stop = picturesIn(out / "other");
  // The server closes the silent client; the other one renders on.
  EXPECT_TRUE(waitFor([&] { return logSays(out / "server.log", "heard nothing for 2000 ms"); }))
      << readFile(out / "server.log");
  EXPECT_TRUE(waitFor([&] { return picturesIn(out / "other") >= other_at_stop + 10; }))
      << readFile(out / "other.log");
  EXPECT_EQ(picturesIn(out / "stopped"), at_stop) << "a stopped process wrote nothing";
  expectPeakGrowthBelow(usageOf(server), baseline, 32 * 1024,
                        "the server queued a few frames for the stopped client, not all of them");
  kill(stopped, SIGCONT);
  EXPECT_EQ(waitExit(stopped, 120), 0) << readFile(out / "stopped.log");
  const auto report = nlohmann::json::parse(readFile(out / "stopped" / "report.json"));
  EXPECT_EQ(report["frames_rendered"].get<int>(), kStoppedFrames);
  // What it rendered after the stop is fresh: frame ids past those it
  // rendered before, not the queue it missed.
  const auto& frames = report["frames"];
  for (size_t i = 1; i < frames.size(); ++i)
    EXPECT_GT(frames[i]["frame_id"].get<uint64_t>(), frames[i - 1]["frame_id"].get<uint64_t>());
  stopAll({other});
  stopAll(pods);
  kill(server, SIGTERM);
  EXPECT_EQ(waitExit(server, 10), 0);
  fs::remove_all(out);
}

// Layers as video (protocol 1.6): each frame predicts from the one before,
// so a client that joins a running stream cannot decode what the others
// are in the middle of. With key frames only on demand (600 frames, an
// interval the run never reaches), a second layered client that joins late decodes every frame it
// is sent from its first, because its arrival asked for a key frame; the
// first client, in step all along, skips nothing after the join.
TEST(Faults, ALayeredClientJoiningAVideoStreamLateDecodesFromItsFirstFrame) {
  const fs::path out = freshDir("faults_layer_join");
  const uint16_t port = freePort();
  ASSERT_NE(port, 0);
  const std::string endpoint = "127.0.0.1:" + std::to_string(port);
  // No peer dies here, and under Vulkan validation a layered client can
  // take seconds a frame: past the fault tests' idle timeout (2 s) the
  // server would close the first client, which rejoins out of step.
  const pid_t server =
      serverOnPort(port, out, 2, "server.log",
                   {"--layer-video", "h264", "--layer-video-key-interval", "600"}, 600000);
  const std::vector<pid_t> pods = {startSmallPod(endpoint, 0, 2, out),
                                   startSmallPod(endpoint, 1, 2, out)};
  const std::vector<std::string> layered = {"--mode", "layered"};
  const pid_t first = startSmallClient(endpoint, out, "first", 2000, layered);
  ASSERT_TRUE(waitFor([&] { return picturesIn(out / "first") >= 4; }))
      << readFile(out / "first.log") << readFile(out / "server.log");
  // Frames fused before the server heard the first client carry no layers
  // (it skips them, by name); none it is sent once in step is refused.
  auto skips = [&](const std::string& name) {
    const std::string log = readFile(out / (name + ".log"));
    size_t count = 0;
    for (size_t at = log.find("skipped"); at != std::string::npos; at = log.find("skipped", at + 1))
      ++count;
    return count;
  };
  const size_t first_skips = skips("first");
  const pid_t late = startSmallClient(endpoint, out, "late", 6, layered);
  ASSERT_EQ(waitExit(late, 120), 0) << readFile(out / "late.log");
  const auto report = nlohmann::json::parse(readFile(out / "late" / "report.json"));
  EXPECT_EQ(report["frames_rendered"].get<int>(), 6);
  EXPECT_TRUE(report["frames_skipped"].empty()) << report["frames_skipped"].dump();
  EXPECT_EQ(readFile(out / "late.log").find("skipped"), std::string::npos)
      << readFile(out / "late.log");
  const size_t first_at_join = picturesIn(out / "first");
  EXPECT_TRUE(waitFor([&] { return picturesIn(out / "first") >= first_at_join + 2; }))
      << readFile(out / "first.log");
  EXPECT_EQ(skips("first"), first_skips) << readFile(out / "first.log");
  EXPECT_EQ(readFile(out / "first.log").find("key frame"), std::string::npos)
      << readFile(out / "first.log");
  EXPECT_TRUE(logSays(out / "server.log", "texture layers as video"))
      << readFile(out / "server.log");
  stopAll({first});
  stopAll(pods);
  kill(server, SIGTERM);
  EXPECT_EQ(waitExit(server, 10), 0);
  fs::remove_all(out);
}

}  // namespace
}  // namespace holofuse

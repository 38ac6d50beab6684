// Trust no peer, part two (SECURITY.md): peers that hold a key and still
// misbehave, with real processes on loopback. A pod whose clock is off
// loses its own frames, never the others'; the honest client's frames
// are counted during and after each misbehaviour.
#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "base/process.h"
#include "geometry/camera.h"
#include "insider_attacks.h"
#include "loop_test.h"
#include "peer_by_hand.h"
#include "protocol/messages.h"

namespace holofuse {
namespace {

using namespace holofuse::test;

// A server for `pods` pods with the first `honest` of them running, and a
// client rendering until stopped: the rig a test's misbehaving peer joins.
class ServingRig {
 public:
  // Starts it; ready once the client has rendered 3 pictures.
  ServingRig(const std::string& name, int pods, int honest,
             const std::vector<std::string>& server_flags = {},
             const std::vector<std::string>& server_wrapper = {})
      : out_(freshDir(name)), configured_(pods) {
    endpoint_ = startServer(out_, pods, &server_, server_flags, server_wrapper);
    if (endpoint_.empty()) return;
    for (int id = 0; id < honest; ++id) pods_.push_back(startSmallPod(endpoint_, id, pods, out_));
    client_ = startSmallClient(endpoint_, out_, "client", 100000);
    ready_ = waitFor([&] { return pictures() >= 3; });
  }
  ::testing::AssertionResult ready() const {
    if (ready_) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << readFile(serverLog()) << readFile(out_ / "client.log");
  }
  const fs::path& out() const { return out_; }
  const std::string& endpoint() const { return endpoint_; }
  pid_t server() const { return server_; }
  fs::path serverLog() const { return out_ / "server.log"; }
  size_t pictures() const { return picturesIn(out_ / "client"); }
  // Kills honest pod `id` (SIGKILL: a crash) and starts it again.
  void restartPod(int id) {
    crashed_.insert(id);
    kill(pods_.at(id), SIGKILL);
    waitExit(pods_.at(id), 20);
    pods_.at(id) = startSmallPod(endpoint_, id, configured_, out_, {},
                                 "pod" + std::to_string(id) + "_again.log");
  }
  // The client renders n more pictures (an event, with a limit only a
  // failure reaches).
  ::testing::AssertionResult rendersMore(size_t n) const {
    const size_t before = pictures();
    if (waitFor([&] { return pictures() >= before + n; })) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << "no " << n << " more pictures\n"
                                         << readFile(out_ / "client.log");
  }
  // Stops the client, the pods and the server, which exit cleanly; returns
  // the server's log, in which no honest pod or client was closed. (A pod
  // killed by restartPod may be: its socket is reset when it died with
  // bytes unread, and the server says so.)
  std::string stop() {
    kill(client_, SIGTERM);
    EXPECT_EQ(waitExit(client_, 30), 0) << readFile(out_ / "client.log");
    for (const pid_t pod : pods_) kill(pod, SIGTERM);
    for (const pid_t pod : pods_) waitExit(pod, 20);
    kill(server_, SIGTERM);
    EXPECT_EQ(waitExit(server_, 20), 0);
    const std::string log = readFile(serverLog());
    std::istringstream lines(log);
    for (std::string line; std::getline(lines, line);) {
      for (size_t id = 0; id < pods_.size(); ++id) {
        if (line.find("closing pod " + std::to_string(id) + " ") == std::string::npos) continue;
        const bool crash = crashed_.count(static_cast<int>(id)) &&
                           line.find("Connection reset by peer") != std::string::npos;
        EXPECT_TRUE(crash) << line << "\n" << log;
      }
    }
    EXPECT_EQ(log.find("closing client 0 "), std::string::npos) << log;
    return log;
  }
  ~ServingRig() {
    if (!::testing::Test::HasFailure()) fs::remove_all(out_);
  }

 private:
  fs::path out_;
  std::string endpoint_;
  int configured_ = 0;
  std::set<int> crashed_;  // pods restartPod killed
  pid_t server_ = 0, client_ = 0;
  std::vector<pid_t> pods_;
  bool ready_ = false;
};

// Whether a line of log says pod 3 is off the rig's clock by about
// |skew| ids in that direction (a frame may straddle a tick: within one).
bool offClockLineSays(const std::string& log, int64_t skew, const std::string& direction) {
  const std::string start = "pod 3 is off the rig's clock: frame id ";
  for (size_t at = log.find(start); at != std::string::npos; at = log.find(start, at + 1)) {
    const std::string line = log.substr(at, log.find('\n', at) - at);
    const size_t is = line.find(" is ", start.size());
    if (is == std::string::npos) continue;
    const std::string rest = line.substr(is + 4);
    const int64_t ids = std::strtoll(rest.c_str(), nullptr, 10);
    if (std::llabs(ids - std::llabs(skew)) <= 1 &&
        rest.find(" ids " + direction + " the rig's clock") != std::string::npos)
      return true;
  }
  return false;
}

// Three honest pods and a fourth whose frame ids run 1 s, 1 h or 90,000
// ids ahead of the rig's, then the same behind (pods at 10 fps: 10, 36,000
// and 90,000 ids), one after another. Each is named in the log with its
// offset, the one an hour ahead is closed once it has been off the clock
// for the bound, and the client renders the honest pods' groups whole all
// the while and after.
TEST(RigClock, APodOffTheClockLosesOnlyItsOwnFrames) {
  ServingRig rig("rig_clock", 4, 3, {"--off-clock-close-ms", "1500"});
  ASSERT_TRUE(rig.ready());
  const fs::path server_log = rig.serverLog();
  constexpr size_t kPicturesPerPhase = 6;
  const struct {
    int64_t ids;
    const char* direction;
  } skews[] = {{10, "ahead of"}, {36000, "ahead of"}, {90000, "ahead of"},
               {-10, "behind"},  {-36000, "behind"},  {-90000, "behind"}};
  for (const auto& skew : skews) {
    const size_t mark = readFile(server_log).size();
    const std::string name = "skewed" + std::to_string(skew.ids) + ".log";
    const pid_t skewed = startSmallPod(rig.endpoint(), 3, 4, rig.out(),
                                       {"--frame-id-offset", std::to_string(skew.ids)}, name);
    // Named with its offset (a frame may straddle a tick: within one id).
    EXPECT_TRUE(waitFor([&] {
      return offClockLineSays(readFile(server_log).substr(mark), skew.ids, skew.direction);
    })) << "no line naming pod 3 "
        << skew.ids << " ids off\n"
        << readFile(server_log);
    // The honest pods' groups go on being fused while it sends.
    EXPECT_TRUE(rig.rendersMore(kPicturesPerPhase)) << "while pod 3 was " << skew.ids << " ids off";
    if (skew.ids == 36000) {
      // Off the clock for longer than the bound: closed, by name.
      EXPECT_TRUE(waitFor([&] {
        return test::logSays(server_log, "malformed: its frame ids have been off the rig's clock");
      })) << readFile(server_log);
    }
    kill(skewed, SIGTERM);
    EXPECT_EQ(waitExit(skewed, 20), 0) << readFile(rig.out() / name);
  }
  // After it left, the honest pods' groups are fused whole.
  EXPECT_TRUE(rig.rendersMore(kPicturesPerPhase)) << "after pod 3 left";
  rig.stop();

  // Every frame rendered once the three had joined holds their three
  // cameras (a frame of pod 3 alone, or of nothing, would be the skewed
  // pod moving the rig's clock); a loaded machine may deliver a pod's
  // frame late now and then.
  const auto report = nlohmann::json::parse(readFile(rig.out() / "client" / "report.json"));
  const auto& frames = report["frames"];
  ASSERT_GE(frames.size(), 3 + 7 * kPicturesPerPhase);
  size_t whole = 0, counted = 0;
  for (size_t i = 3; i < frames.size(); ++i, ++counted)
    whole += frames[i]["cameras_present"].get<int>() >= 3;
  EXPECT_GE(whole, counted * 9 / 10) << whole << " of " << counted << " frames held 3 cameras";
}

// Keyed insiders flood the server with what a key allows: FrameRequests,
// messages of a type it does not know, and clock-probe answers nobody
// asked for. Each is slowed to its budget, then closed and told why by
// name, while the honest client goes on rendering the honest pods' frames.
TEST(Budget, KeyedFloodersAreSlowedThenClosedAndTheHonestClientIsServed) {
  ServingRig rig("budget_floods", 2, 2);
  ASSERT_TRUE(rig.ready());
  const std::string endpoint = rig.endpoint();
  const struct {
    uint32_t id;
    std::vector<uint8_t> message;
    const char* refusal;
  } floods[] = {
      {5, test::frameRequestMessage(),
       "FrameRequest messages faster than 250 a second (64 at once)"},
      {6, test::unknownTypeMessage(),
       "messages of type 99 (unknown) faster than 25 a second (20 at once)"},
      {7, test::clockProbeReplyMessage(),
       "ClockProbe messages faster than 25 a second (20 at once)"},
  };
  std::vector<std::unique_ptr<protocol::Connection>> flooders;
  for (const auto& flood : floods) {
    flooders.push_back(test::admittedByHand(endpoint, protocol::Role::kClient, flood.id));
    ASSERT_NE(flooders.back(), nullptr) << readFile(rig.serverLog());
  }
  const size_t before = rig.pictures();
  // Each floods on a thread of its own and reads what the server says on
  // another, so no refusal waits behind another flooder's.
  const size_t n = std::size(floods);
  std::vector<uint64_t> sent(n);
  std::vector<protocol::ErrorMessage> refusals(n);
  std::vector<bool> refused(n);
  {
    std::vector<std::jthread> threads;
    for (size_t i = 0; i < n; ++i) {
      threads.emplace_back(
          [&, i] { sent[i] = test::floodUntilClosed(flooders[i]->fd(), floods[i].message); });
      threads.emplace_back([&, i] {
        refused[i] = protocol::decodeFrame(test::nextError(*flooders[i]), refusals[i]).isOk();
      });
    }
  }
  // Each was told why it was closed.
  for (size_t i = 0; i < n; ++i) {
    EXPECT_TRUE(refused[i]) << "client " << floods[i].id << " was never refused\n"
                            << readFile(rig.serverLog());
    EXPECT_NE(refusals[i].message.find(floods[i].refusal), std::string::npos)
        << refusals[i].message;
    EXPECT_NE(refusals[i].message.find("--over-budget-close-ms"), std::string::npos)
        << refusals[i].message;
  }
  // The flood was real (thousands of messages) and the honest client
  // rendered all through it.
  for (size_t i = 0; i < n; ++i) EXPECT_GT(sent[i], 1000u) << "client " << floods[i].id;
  EXPECT_GE(rig.pictures() - before, 5u) << "pictures while the floods lasted";
  EXPECT_TRUE(rig.rendersMore(5)) << "after the floods";
  const std::string log = rig.stop();
  for (const auto& flood : floods) {
    EXPECT_NE(log.find("closing client " + std::to_string(flood.id) + " (127.0.0.1"),
              std::string::npos)
        << log;
  }
}

// A keyed pod whose calibration is within --max-image-side (4096x4096)
// but 5461 times the rig's 64x48 pods: its frames would decompress to 80
// MB each. It is refused at its Calibration, before any frame of that size
// is read or decompressed (one follows at once); the server's peak memory
// stays where it was and the honest client goes on rendering.
TEST(Budget, APodFarAboveTheRigsImagesIsRefusedBeforeItsFramesAreDecoded) {
  ServingRig rig("budget_bomb", 3, 2);
  ASSERT_TRUE(rig.ready());
  const auto baseline = processUsage(rig.server());
  ASSERT_TRUE(baseline.has_value());

  constexpr uint32_t kSide = 4096;
  Camera camera = ringCameras(3, 2.5, 1.0, {0, 1, 0}, kSide, kSide, 50)[2];
  camera.id = 2;
  const auto bomb_frame = test::emptyPodFrame(2, kSide, 1);
  ASSERT_LT(bomb_frame->size(), 1u << 20) << "LZ4 of empty planes: small on the wire";
  auto bomb = test::admittedByHand(rig.endpoint(), protocol::Role::kPod, 2);
  ASSERT_NE(bomb, nullptr) << readFile(rig.serverLog());
  bomb->sendMessage(toCalibration(camera));
  bomb->send(bomb_frame);
  test::flush(*bomb);
  protocol::ErrorMessage refusal;
  ASSERT_TRUE(protocol::decodeFrame(test::nextError(*bomb), refusal).isOk())
      << readFile(rig.serverLog());
  EXPECT_NE(refusal.message.find("its images, 4096x4096 (16777216 pixels), cost 5461.3 times the "
                                 "rig's median pod (3072 pixels, of 3 pods)"),
            std::string::npos)
      << refusal.message;
  Status closed;
  while (!test::nextFrame(*bomb, &closed).bytes.empty()) {
  }
  EXPECT_FALSE(closed.isOk()) << "closed by the server";
  EXPECT_TRUE(rig.rendersMore(5)) << "after the bomb";
  // Nothing of the bomb's size was ever held: one decoded frame is 80 MB.
  const auto usage = processUsage(rig.server());
  ASSERT_TRUE(usage.has_value());
  if (!test::kSanitized) {
    EXPECT_LT(usage->peak_rss_kb, baseline->peak_rss_kb + 16 * 1024)
        << "baseline peak " << baseline->peak_rss_kb << " kB";
  }
  const std::string log = rig.stop();
  EXPECT_NE(log.find("closing pod 2 (127.0.0.1"), std::string::npos) << log;
}

size_t joins(const std::string& log, int pod) {
  const std::string joined = "pod " + std::to_string(pod) + " (127.0.0.1:";
  size_t n = 0;
  for (size_t at = log.find(joined); at != std::string::npos; at = log.find(joined, at + 1))
    n += log.compare(log.find(')', at), 9, ") joined,") == 0;
  return n;
}

// Pod 1, killed (a crash) and started again, joins the rig again and the
// client renders on.
void expectRestartedPodJoinsAndRenders(ServingRig& rig) {
  rig.restartPod(1);
  EXPECT_TRUE(waitFor([&] { return joins(readFile(rig.serverLog()), 1) >= 2; }))
      << "the restarted pod never joined\n"
      << readFile(rig.serverLog());
  EXPECT_TRUE(rig.rendersMore(5)) << "after pod 1 restarted";
}

// A crowd from 40 addresses keeps every handshake slot taken, each
// connection sending one byte and waiting out a long handshake deadline,
// new ones coming all the time. A pod that crashes and starts again gets
// in: the stranger longest in its handshake makes room for it, and a claim
// to be one of the rig's pods is kept while it proves it.
TEST(Admission, ARestartingPodJoinsDuringASustainedTrickle) {
  ServingRig rig("admission_trickle", 2, 2,
                 {"--max-handshaking", "16", "--handshake-timeout-ms", "60000"});
  ASSERT_TRUE(rig.ready());
  const uint16_t port = static_cast<uint16_t>(std::stoi(rig.endpoint().substr(10)));
  test::Trickle crowd(port, 40, 2000, std::chrono::milliseconds(10));
  // Every slot is taken and the crowd goes on coming.
  ASSERT_TRUE(waitFor([&] {
    const std::string log = readFile(rig.serverLog());
    return log.find("to make room") != std::string::npos ||
           log.find("already in their handshake") != std::string::npos;
  })) << readFile(rig.serverLog());
  expectRestartedPodJoinsAndRenders(rig);
  const std::string log = rig.stop();
  EXPECT_NE(log.find("connections in their handshake (--max-handshaking): closing"),
            std::string::npos)
      << log;
}

// Strangers connect as fast as they can and each waits out its handshake
// deadline: the server's descriptors (a limit of 48) are all theirs and
// hundreds more wait in the listen queue ahead of anyone else. A pod that
// crashes and starts again gets in: strangers' descriptors make room for
// the connections waiting, its among them.
TEST(Admission, ARestartingPodJoinsWhileStrangersHoldEveryDescriptor) {
  ServingRig rig("admission_descriptors", 2, 2,
                 {"--max-handshaking", "1000", "--max-handshaking-per-address", "1000"},
                 {"/usr/bin/prlimit", "--nofile=48"});
  ASSERT_TRUE(rig.ready());
  const uint16_t port = static_cast<uint16_t>(std::stoi(rig.endpoint().substr(10)));
  test::Trickle crowd(port, 1, 4000, std::chrono::milliseconds(1));
  // Out of descriptors, and 1500 more queued ahead of the pod.
  ASSERT_TRUE(waitFor([&] {
    return test::logSays(rig.serverLog(), "cannot accept (Too many open files)") &&
           crowd.opened() >= 1500;
  })) << readFile(rig.serverLog());
  expectRestartedPodJoinsAndRenders(rig);
  rig.stop();
}

}  // namespace
}  // namespace holofuse

// bench_insiders: SECURITY.md's promises against keyed insiders, measured
// (issue 43's targets). A keyed rig on loopback (a server, 4 pods and a
// client, all real processes) is measured under each misbehaviour in
// turn, each in three windows: quiet before it, during it, and after it
// (the client's fps during and after is against the window before, since
// this machine's speed drifts):
//   - pod 3 replaced by one whose frame ids run 1 s, 1 h and 90,000 ids
//     ahead, then behind: the client's fps during and after against quiet,
//     and how long until the log names it;
//   - a keyed client flooding FrameRequests, messages of an unknown type,
//     clock-probe answers: fps during and after, the server's peak memory
//     against its quiet peak, seconds until the flooder is closed;
//   - pod 3 replaced by a 4096x4096 insider sending 80 MB frames: the same;
//   - a trickle from 40 addresses holding every handshake slot, and (a
//     second rig, the server limited to 48 descriptors) the same crowd
//     taking every descriptor: seconds until pod 1, killed and started
//     again, has joined.
// The client's fps is the pictures it writes in a window over its length.
//   bench_insiders [--size WxH] [--fps R] [--window-s S] [--out DIR] [--markdown FILE]
#include <signal.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "base/process.h"
#include "config/command_line.h"
#include "config/rig_shape.h"
#include "geometry/camera.h"
#include "integration/insider_attacks.h"
#include "integration/peer_by_hand.h"
#include "integration/process_harness.h"
#include "protocol/messages.h"

namespace fs = std::filesystem;
using namespace holofuse;
using Clock = std::chrono::steady_clock;

namespace {

struct Settings {
  std::string bin = HOLOFUSE_BIN_DIR;
  std::string size = "320x240";
  double fps = 15;
  double window_s = 6;
  fs::path out;
};

struct Row {
  Row(std::string what_, std::string event_) : what(std::move(what_)), event(std::move(event_)) {}
  std::string what;
  std::string event;                     // what `seconds` runs to
  double quiet_fps = 0;                  // the window before it
  double fps_during = 0, fps_after = 0;  // against quiet
  std::optional<double> seconds;
  double peak_rss = 0;  // the server's peak so far against its quiet peak
};

double secondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

class Rig {
 public:
  Rig(const Settings& settings, const std::string& name,
      const std::vector<std::string>& server_wrapper = {})
      : s_(settings), out_(settings.out / name) {
    fs::remove_all(out_);
    fs::create_directories(out_);
    endpoint_ = test::startServer(s_.bin, out_, 4, &server_, {}, server_wrapper);
    for (int id = 0; id < 4; ++id) pods_.push_back(startPod(id, {}));
    client_ = test::spawn({s_.bin + "/render_client", "--server", endpoint_, "--out",
                           (out_ / "client").string(), "--frames", "1000000", "--size", s_.size},
                          out_ / "client.log");
  }
  ~Rig() {
    for (const pid_t pid : pods_) kill(pid, SIGTERM);
    kill(client_, SIGTERM);
    for (const pid_t pid : pods_) test::waitExit(pid, 20);
    test::waitExit(client_, 30);
    kill(server_, SIGTERM);
    test::waitExit(server_, 20);
  }
  bool warm() {
    return test::waitFor([&] { return pictures() >= 20; }, 120);
  }
  pid_t startPod(int id, const std::vector<std::string>& extra) {
    std::vector<std::string> argv = {s_.bin + "/capture_node",
                                     "--server",
                                     endpoint_,
                                     "--pod-id",
                                     std::to_string(id),
                                     "--pods",
                                     "4",
                                     "--size",
                                     s_.size,
                                     "--fps",
                                     std::to_string(s_.fps)};
    argv.insert(argv.end(), extra.begin(), extra.end());
    return test::spawn(
        argv, out_ / ("pod" + std::to_string(id) + "_" + std::to_string(++started_) + ".log"));
  }
  // Stops pod `id` (SIGKILL: a crash) and starts another in its place,
  // returning once it has joined, so that what follows is not its start.
  void replacePod(int id, const std::vector<std::string>& extra, bool crash = false) {
    kill(pods_[id], crash ? SIGKILL : SIGTERM);
    test::waitExit(pods_[id], 20);
    const size_t mark = log().size();
    pods_[id] = startPod(id, extra);
    const std::string joined = "pod " + std::to_string(id) + " (127.0.0.1:";
    test::waitFor([&] {
      const std::string text = log();
      const size_t at = text.find(joined, mark);
      return at != std::string::npos && text.find(") joined", at) != std::string::npos;
    });
  }
  void stopPod(int id) {
    kill(pods_[id], SIGTERM);
    test::waitExit(pods_[id], 20);
  }
  size_t pictures() const { return test::picturesIn(out_ / "client"); }
  // The client's frames a second over the next window.
  double windowFps() {
    const size_t before = pictures();
    const auto t0 = Clock::now();
    std::this_thread::sleep_for(std::chrono::duration<double>(s_.window_s));
    return static_cast<double>(pictures() - before) / secondsSince(t0);
  }
  std::string log() const { return test::readFile(out_ / "server.log"); }
  uint64_t peakRssKb() const {
    const auto usage = processUsage(server_);
    return usage ? usage->peak_rss_kb : 0;
  }
  const std::string& endpoint() const { return endpoint_; }

 private:
  const Settings& s_;
  fs::path out_;
  std::string endpoint_;
  pid_t server_ = 0, client_ = 0;
  std::vector<pid_t> pods_;
  int started_ = 0;
};

// Seconds from t0 until the server's log, after byte `mark`, holds `what`;
// none within limit_s.
std::optional<double> secondsUntilLogged(const Rig& rig, size_t mark, const std::string& what,
                                         Clock::time_point t0, double limit_s = 30) {
  while (secondsSince(t0) < limit_s) {
    const std::string log = rig.log();
    if (log.size() > mark && log.find(what, mark) != std::string::npos) return secondsSince(t0);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return std::nullopt;
}

// secondsUntilLogged on a thread of its own, while the caller measures.
class LogWatch {
 public:
  LogWatch(const Rig& rig, const std::string& what, Clock::time_point t0)
      : thread_([&rig, what, t0, mark = rig.log().size(), this] {
          seconds_ = secondsUntilLogged(rig, mark, what, t0);
        }) {}
  std::optional<double> seconds() {
    thread_.join();
    return seconds_;
  }

 private:
  std::optional<double> seconds_;
  std::jthread thread_;
};

// A crowd from 40 addresses (a new stranger every gap, at most hold of
// them open) until the server's log says `crowded`; then pod 1 is killed
// and started again: the seconds until it has joined, the client's fps
// during the crowd and after it against the window before, the server's
// peak against `peak`.
Row crowdWhilePodRestarts(Rig& rig, const std::string& what, std::chrono::milliseconds gap,
                          size_t hold, const std::string& crowded, uint64_t peak) {
  Row row(what, "pod 1 joined again");
  const double quiet = row.quiet_fps = rig.windowFps();
  {
    const uint16_t port = static_cast<uint16_t>(std::stoi(rig.endpoint().substr(10)));
    const size_t before = rig.log().size();
    test::Trickle crowd(port, 40, hold, gap);
    secondsUntilLogged(rig, before, crowded, Clock::now());
    const size_t mark = rig.log().size();
    const auto t0 = Clock::now();
    rig.replacePod(1, {}, true);
    row.seconds = secondsUntilLogged(rig, mark, ") joined", t0);
    row.fps_during = rig.windowFps() / quiet;
  }
  row.fps_after = rig.windowFps() / quiet;
  row.peak_rss = static_cast<double>(rig.peakRssKb()) / static_cast<double>(peak);
  std::printf("%s: joined after %.1f s\n", what.c_str(), row.seconds.value_or(-1));
  return row;
}

std::string cell(double ratio) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.0f%%", 100 * ratio);
  return text;
}

// The Markdown table of every misbehaviour, with the quiet rig's numbers
// it is read against.
std::string insiderTable(const Settings& s, double quiet_fps, uint64_t quiet_peak,
                         const std::vector<Row>& rows) {
  char head[512];
  std::snprintf(head, sizeof(head),
                "Keyed rig on loopback: 4 pods at %s, %.0f fps, one client; at first %.1f fps, "
                "server peak %.1f MB; windows of %.0f s. The client's fps during and after "
                "each misbehaviour is against the window just before it; the server's peak "
                "memory so far against its peak at first.\n\n",
                s.size.c_str(), s.fps, quiet_fps, quiet_peak / 1024.0, s.window_s);
  std::string table = head;
  table +=
      "| misbehaviour | client fps before | during | after | seconds to | event | server peak |\n"
      "|---|---:|---:|---:|---:|---|---:|\n";
  for (const Row& row : rows) {
    char seconds[32] = "never";
    if (row.seconds) std::snprintf(seconds, sizeof(seconds), "%.2f", *row.seconds);
    char peak[32];
    std::snprintf(peak, sizeof(peak), "%.2fx", row.peak_rss);
    char before[32];
    std::snprintf(before, sizeof(before), "%.1f", row.quiet_fps);
    table += "| " + row.what + " | " + before + " | " + cell(row.fps_during) + " | " +
             cell(row.fps_after) + " | " + seconds + " | " + row.event + " | " + peak + " |\n";
  }
  return table;
}

}  // namespace

int main(int argc, char** argv) {
  Settings s;
  std::string markdown;
  CLI::App app{"bench_insiders: the rig against keyed insiders and crowds (SECURITY.md)"};
  app.add_option("--size", s.size, "the pods' images")->capture_default_str();
  // The pods' --fps, from their table.
  const SettingFlags<RigShape> shape_flags(app, pickSettings(rigShapeFlags(), {"--fps"}));
  app.add_option("--window-s", s.window_s, "seconds each fps is measured over")
      ->capture_default_str();
  std::string out = "out/bench_insiders";
  app.add_option("--out", out, "folder for the rigs' logs")->capture_default_str();
  app.add_option("--markdown", markdown, "also write the table to this file");
  CLI11_PARSE(app, argc, argv);
  RigShape shape;
  shape.fps = s.fps;
  shape_flags.apply(shape);
  s.fps = shape.fps;
  s.out = out;
  fs::create_directories(s.out);
  std::vector<Row> rows;
  double quiet_fps = 0;
  uint64_t quiet_peak = 0;
  {
    Rig rig(s, "rig");
    if (!rig.warm()) {
      std::fprintf(stderr, "the rig never rendered: see %s\n", s.out.c_str());
      return 1;
    }
    quiet_fps = rig.windowFps();
    quiet_peak = rig.peakRssKb();
    std::printf("quiet: %.1f fps, server peak %.1f MB\n", quiet_fps, quiet_peak / 1024.0);
    const int ids_per_second = static_cast<int>(s.fps + 0.5);
    const struct {
      const char* what;
      long long ids;
    } skews[] = {{"pod 3 1 s ahead", ids_per_second},
                 {"pod 3 1 h ahead", 3600LL * ids_per_second},
                 {"pod 3 90,000 ids ahead", 90000},
                 {"pod 3 1 s behind", -ids_per_second},
                 {"pod 3 1 h behind", -3600LL * ids_per_second},
                 {"pod 3 90,000 ids behind", -90000}};
    for (const auto& skew : skews) {
      Row row(skew.what, "named in the log");
      const double quiet = row.quiet_fps = rig.windowFps();
      const auto t0 = Clock::now();
      LogWatch named(rig, "pod 3 is off the rig's clock", t0);
      rig.replacePod(3, {"--frame-id-offset", std::to_string(skew.ids)});
      row.fps_during = rig.windowFps() / quiet;
      row.seconds = named.seconds();
      rig.replacePod(3, {});
      row.fps_after = rig.windowFps() / quiet;
      row.peak_rss = static_cast<double>(rig.peakRssKb()) / quiet_peak;
      rows.push_back(row);
      std::printf("%s: %.0f%% during, %.0f%% after\n", row.what.c_str(), 100 * row.fps_during,
                  100 * row.fps_after);
    }
    const struct {
      const char* what;
      uint32_t id;
      std::vector<uint8_t> message;
    } floods[] = {{"FrameRequest flood", 5, test::frameRequestMessage()},
                  {"unknown-type flood", 6, test::unknownTypeMessage()},
                  {"clock-probe answer flood", 7, test::clockProbeReplyMessage()}};
    for (const auto& flood : floods) {
      Row row(flood.what, "the flooder closed");
      const double quiet = row.quiet_fps = rig.windowFps();
      auto flooder = test::admittedByHand(rig.endpoint(), protocol::Role::kClient, flood.id);
      if (flooder == nullptr) {
        std::fprintf(stderr, "%s: not admitted\n", flood.what);
        return 1;
      }
      const auto t0 = Clock::now();
      std::jthread writer([&] {
        test::floodUntilClosed(flooder->fd(), flood.message);
        row.seconds = secondsSince(t0);
      });
      row.fps_during = rig.windowFps() / quiet;
      writer.join();
      row.fps_after = rig.windowFps() / quiet;
      row.peak_rss = static_cast<double>(rig.peakRssKb()) / quiet_peak;
      rows.push_back(row);
      std::printf("%s: %.0f%% during, closed after %.1f s\n", flood.what, 100 * row.fps_during,
                  row.seconds.value_or(-1));
    }
    {
      Row row("pod 3 a 4096x4096 insider", "the insider closed");
      const double quiet = row.quiet_fps = rig.windowFps();
      rig.stopPod(3);
      constexpr uint32_t kSide = 4096;
      Camera camera = ringCameras(4, 2.5, 1.0, {0, 1, 0}, kSide, kSide, 50)[3];
      camera.id = 3;
      const auto bomb_frame = test::emptyPodFrame(3, kSide, 1);
      auto bomb = test::admittedByHand(rig.endpoint(), protocol::Role::kPod, 3);
      if (bomb == nullptr) {
        std::fprintf(stderr, "the insider pod was not admitted\n");
        return 1;
      }
      const auto t0 = Clock::now();
      // Its calibration, then a frame a period until it is closed.
      std::jthread sender([&] {
        bomb->sendMessage(toCalibration(camera));
        for (Status closed; closed.isOk() && secondsSince(t0) < 60;) {
          bomb->send(bomb_frame);
          test::flush(*bomb);
          test::nextFrame(*bomb, &closed, static_cast<int>(1000 / s.fps));
        }
        row.seconds = secondsSince(t0);
      });
      row.fps_during = rig.windowFps() / quiet;
      sender.join();
      rig.replacePod(3, {});
      row.fps_after = rig.windowFps() / quiet;
      row.peak_rss = static_cast<double>(rig.peakRssKb()) / quiet_peak;
      rows.push_back(row);
      std::printf("%s: %.0f%% during, closed after %.1f s\n", row.what.c_str(),
                  100 * row.fps_during, row.seconds.value_or(-1));
    }
    rows.push_back(crowdWhilePodRestarts(rig, "a trickle from 40 addresses; pod 1 restarts",
                                         std::chrono::milliseconds(10), 2000,
                                         "connections in their handshake", quiet_peak));
  }
  {
    Rig rig(s, "rig_48_descriptors", {"/usr/bin/prlimit", "--nofile=48"});
    if (!rig.warm()) {
      std::fprintf(stderr, "the rig never rendered: see %s\n", s.out.c_str());
      return 1;
    }
    const uint64_t peak = rig.peakRssKb();
    rows.push_back(
        crowdWhilePodRestarts(rig, "40 addresses take every descriptor (48); pod 1 restarts",
                              std::chrono::milliseconds(1), 4000, "cannot accept", peak));
  }

  const std::string table = insiderTable(s, quiet_fps, quiet_peak, rows);
  std::printf("\n%s", table.c_str());
  if (!markdown.empty()) std::ofstream(markdown) << table;
  return 0;
}

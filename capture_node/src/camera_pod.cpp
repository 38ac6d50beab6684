#include "capture_node/camera_pod.h"

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <mutex>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <optional>
#include <thread>

#include "base/shutdown.h"
#include "capture_node/pod_link.h"
#include "dataset/camera_input.h"
#include "dataset/capture_formats.h"
#include "image/opencv_image.h"
#include "protocol/clock.h"
#include "protocol/server_link.h"
#include "segmentation/segmentation.h"

namespace holofuse::capture {

using protocol::monotonicNs;
using protocol::Stage;

namespace {

namespace fs = std::filesystem;

bool isDeviceIndex(const std::string& source) {
  return !source.empty() && source.size() < 4 &&
         std::all_of(source.begin(), source.end(), [](unsigned char c) { return std::isdigit(c); });
}

// The source's frames on a thread of their own, so that a source that
// stalls (a network stream, a camera unplugged) never stalls the link to
// the server; the pod always takes the newest frame. A stream or device
// that stops is reopened with a growing wait (a quarter second to 5 s); a
// video file is read at its own frame rate, once or in a loop.
class FrameGrabber {
 public:
  struct Grab {
    Image8 rgb;
    uint64_t sequence = 0;
    uint64_t grabbed_ns = 0;  // monotonic, when the read returned
  };

  FrameGrabber(std::string source, bool loop, std::string log_name)
      : source_(std::move(source)),
        loop_(loop),
        name_(std::move(log_name)),
        is_file_(fs::is_regular_file(source_)) {}
  ~FrameGrabber() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    changed_.notify_all();
    if (thread_.joinable()) thread_.join();
  }
  void start() {
    thread_ = std::thread([this] { run(); });
  }

  // The newest frame after sequence `after`, waiting up to timeout_ms.
  std::optional<Grab> next(uint64_t after, int timeout_ms) {
    std::unique_lock<std::mutex> lock(mutex_);
    changed_.wait_for(lock, std::chrono::milliseconds(timeout_ms),
                      [&] { return latest_.sequence > after || finished_ || fatal_; });
    if (latest_.sequence <= after) return std::nullopt;
    return latest_;
  }
  bool finished() {
    std::lock_guard<std::mutex> lock(mutex_);
    return finished_;
  }
  std::optional<std::string> fatal() {
    std::lock_guard<std::mutex> lock(mutex_);
    return fatal_;
  }
  double sourceFps() {
    std::lock_guard<std::mutex> lock(mutex_);
    return fps_;
  }
  uint64_t reconnects() const { return reconnects_.load(); }

 private:
  bool open() {
    if (isDeviceIndex(source_)) return capture_.open(std::stoi(source_), cv::CAP_V4L2);
    if (source_.rfind("/dev/", 0) == 0) return capture_.open(source_, cv::CAP_V4L2);
    if (is_file_) return capture_.open(source_, cv::CAP_FFMPEG);
    // A network stream: give up on a dead peer within seconds, not minutes.
    return capture_.open(
        source_, cv::CAP_FFMPEG,
        {cv::CAP_PROP_OPEN_TIMEOUT_MSEC, 3000, cv::CAP_PROP_READ_TIMEOUT_MSEC, 3000});
  }

  // Sleeps until `until` (monotonic ns) or a stop; false on a stop.
  bool sleepUntil(uint64_t until) {
    std::unique_lock<std::mutex> lock(mutex_);
    const uint64_t now = monotonicNs();
    if (until > now)
      changed_.wait_for(lock, std::chrono::nanoseconds(until - now), [&] { return stop_; });
    return !stop_;
  }
  bool stopping() {
    std::lock_guard<std::mutex> lock(mutex_);
    return stop_;
  }
  void end(std::optional<std::string> fatal) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      finished_ = true;
      fatal_ = std::move(fatal);
    }
    changed_.notify_all();
  }

  void run() {
    double backoff_s = 0.25;
    bool dropped = false;
    uint64_t file_start = 0, file_frames = 0;
    while (!stopping()) {
      if (!capture_.isOpened()) {
        if (!open()) {
          if (is_file_)
            return end(source_ + ": cannot open the video file (not a video FFmpeg reads?)");
          std::fprintf(stderr, "[%s] cannot open the source %s; trying again in %.2g s\n",
                       name_.c_str(), source_.c_str(), backoff_s);
          if (!sleepUntil(monotonicNs() + static_cast<uint64_t>(backoff_s * 1e9))) return;
          backoff_s = std::min(5.0, backoff_s * 2);
          continue;
        }
        if (dropped) {
          ++reconnects_;
          std::fprintf(stderr, "[%s] the source %s is back (reconnect %llu)\n", name_.c_str(),
                       source_.c_str(), static_cast<unsigned long long>(reconnects_.load()));
        }
        dropped = false;
        backoff_s = 0.25;
        const double fps = capture_.get(cv::CAP_PROP_FPS);
        {
          std::lock_guard<std::mutex> lock(mutex_);
          fps_ = fps >= 1 && fps <= 240 ? fps : 0.0;
        }
        file_start = monotonicNs();
        file_frames = 0;
      }
      cv::Mat frame;
      if (!capture_.read(frame) || frame.empty()) {
        capture_.release();
        if (is_file_) {
          if (loop_) continue;
          return end(std::nullopt);
        }
        std::fprintf(stderr, "[%s] the source %s stopped sending frames; reconnecting\n",
                     name_.c_str(), source_.c_str());
        dropped = true;
        continue;
      }
      if (is_file_) {
        // A file is played at its own pace, as a camera would deliver it.
        const double fps = sourceFps() > 0 ? sourceFps() : 15.0;
        if (!sleepUntil(file_start +
                        static_cast<uint64_t>(static_cast<double>(file_frames) * 1e9 / fps)))
          return;
        ++file_frames;
      }
      cv::Mat rgb;
      switch (frame.channels()) {
        case 1:
          cv::cvtColor(frame, rgb, cv::COLOR_GRAY2RGB);
          break;
        case 4:
          cv::cvtColor(frame, rgb, cv::COLOR_BGRA2RGB);
          break;
        default:
          cv::cvtColor(frame, rgb, cv::COLOR_BGR2RGB);
      }
      if (rgb.depth() != CV_8U) rgb.convertTo(rgb, CV_8U, rgb.depth() == CV_16U ? 1.0 / 257 : 1.0);
      Grab grab;
      grab.rgb = fromMat(rgb);
      grab.grabbed_ns = monotonicNs();
      {
        std::lock_guard<std::mutex> lock(mutex_);
        grab.sequence = latest_.sequence + 1;
        latest_ = std::move(grab);
      }
      changed_.notify_all();
    }
  }

  const std::string source_;
  const bool loop_;
  const std::string name_;
  const bool is_file_;
  cv::VideoCapture capture_;  // the grabber thread's alone
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable changed_;
  Grab latest_;
  bool stop_ = false, finished_ = false;
  std::optional<std::string> fatal_;
  double fps_ = 0;
  std::atomic<uint64_t> reconnects_{0};
};

// The camera the pod runs, from the rig's calibration: by name, else the
// one numbered pod_id.
StatusOr<dataset::CaptureCamera> findCamera(const CameraPodOptions& options) {
  const auto format = dataset::captureFormatFromName(options.calibration_format);
  if (!format) {
    return Status(StatusCode::kMalformed, "--calibration-format " + options.calibration_format +
                                              ": expected one of " + dataset::captureFormatNames());
  }
  auto rig = dataset::readCapture(options.calibration, *format);
  if (!rig.isOk()) return rig.status();
  std::string names;
  for (const auto& c : rig->cameras) {
    names += (names.empty() ? "" : ", ") + c.name;
    if (options.camera.empty() ? c.camera.id == options.pod_id : c.name == options.camera) return c;
  }
  return Status(StatusCode::kMalformed,
                options.calibration + ": " +
                    (options.camera.empty() ? "no camera numbered " + std::to_string(options.pod_id)
                                            : "no camera named \"" + options.camera + "\"") +
                    "; it has " + names);
}

// A line on standard input (Enter pressed, or a line piped in).
bool lineOnStdin() {
  pollfd p{STDIN_FILENO, POLLIN, 0};
  if (::poll(&p, 1, 0) <= 0 || (p.revents & POLLIN) == 0) return false;
  char buffer[256];
  const ssize_t n = ::read(STDIN_FILENO, buffer, sizeof(buffer));
  return n > 0 && std::find(buffer, buffer + n, '\n') != buffer + n;
}

}  // namespace

int runCameraPod(const CameraPodOptions& options) {
  const std::string name = "camera-pod-" + std::to_string(options.pod_id);
  auto fail = [&](const std::string& what) {
    std::fprintf(stderr, "[%s] %s\n", name.c_str(), what.c_str());
    return 2;
  };
  auto found = findCamera(options);
  if (!found.isOk()) return fail(found.status().message());
  const dataset::CaptureCamera& camera = *found;
  const std::optional<dataset::Undistortion> undistort = dataset::Undistortion::of(camera.camera);
  Camera pinhole = camera.camera;
  pinhole.distortion.clear();
  pinhole.id = options.pod_id;
  std::optional<BackgroundModel> background;
  const std::string plate = !options.plate.empty() ? options.plate : camera.background.value_or("");
  if (!plate.empty()) {
    auto model = dataset::readPlate(plate, camera, undistort);
    if (!model.isOk()) return fail(model.status().message());
    background = std::move(*model);
  } else if (options.plate_frames <= 0) {
    return fail("camera \"" + camera.name +
                "\" has no plate: give --plate (a picture or a video of the empty room), or "
                "--plate-frames N to learn it from the source while the room is empty");
  }
  const size_t plate_frames = static_cast<size_t>(std::max(0, options.plate_frames));
  if (plate_frames > 0 && plate_frames < dataset::kFewestPlateFrames) {
    return fail("--plate-frames " + std::to_string(plate_frames) + ": a plate needs at least " +
                std::to_string(dataset::kFewestPlateFrames) + " frames");
  }
  if (options.plate_on_key)
    ::fcntl(STDIN_FILENO, F_SETFL, ::fcntl(STDIN_FILENO, F_GETFL) | O_NONBLOCK);
  // Learning: at start with --plate-frames and no plate file, or on a key.
  bool learning = !background && !options.plate_on_key;
  std::vector<Image8> plate_buffer;

  FrameGrabber grabber(options.source, options.loop, name);
  grabber.start();
  PodLink pod_link(options.server, options.pod_id, name, options.key, options.max_minor,
                   toCalibration(pinhole));
  protocol::ServerLink& link = pod_link.link();
  auto pump = [&](int timeout_ms) { return pod_link.pump(timeout_ms); };
  std::fprintf(stderr, "[%s] camera \"%s\" (%ux%u%s) from %s; plate %s\n", name.c_str(),
               camera.name.c_str(), pinhole.width, pinhole.height, undistort ? ", undistorted" : "",
               options.source.c_str(),
               background ? plate.c_str()
                          : (std::to_string(plate_frames) + " frames of the source" +
                             (options.plate_on_key ? ", on Enter" : ""))
                                .c_str());
  if (options.plate_on_key && !background)
    std::fprintf(stderr, "[%s] empty the room and press Enter to take the plate\n", name.c_str());

  uint64_t last_sequence = 0, last_frame_id = 0, sent = 0, skipped = 0, refused = 0;
  uint64_t last_report = monotonicNs(), last_refusal_log = 0;
  Image8 previous_mask;
  double fps = options.fps;
  while (!stopRequested()) {
    if (!pump(0)) return fail("giving up: " + link.fatalError()->toString());
    if (options.plate_on_key && !learning && lineOnStdin()) {
      learning = true;
      plate_buffer.clear();
      std::fprintf(stderr, "[%s] taking the plate from the next %zu frames\n", name.c_str(),
                   plate_frames);
    }
    auto grab = grabber.next(last_sequence, 20);
    if (!grab) {
      if (const auto fatal = grabber.fatal()) return fail(*fatal);
      if (grabber.finished()) break;
      continue;
    }
    last_sequence = grab->sequence;
    const uint64_t t0 = grab->grabbed_ns;
    if (grab->rgb.width != pinhole.width || grab->rgb.height != pinhole.height) {
      char text[256];
      std::snprintf(text, sizeof(text),
                    "the source %s gives a %ux%u frame; camera \"%s\"'s calibration is %ux%u: "
                    "refused",
                    options.source.c_str(), grab->rgb.width, grab->rgb.height, camera.name.c_str(),
                    pinhole.width, pinhole.height);
      // Before anything was sent it is the set-up that is wrong; later, a
      // stream that changed its size mid-way costs those frames.
      if (sent == 0) return fail(text);
      ++refused;
      if (t0 - last_refusal_log > 2000000000ull) {
        last_refusal_log = t0;
        std::fprintf(stderr, "[%s] %s (%llu so far)\n", name.c_str(), text,
                     static_cast<unsigned long long>(refused));
      }
      continue;
    }
    Image8 color = undistort ? undistort->apply(grab->rgb) : std::move(grab->rgb);
    if (learning) {
      plate_buffer.push_back(std::move(color));
      if (plate_buffer.size() < plate_frames) continue;
      auto model = BackgroundModel::fromFrames(plate_buffer, dataset::realCameraSegmentation());
      if (!model.isOk()) return fail("the plate: " + model.status().message());
      background = std::move(*model);
      learning = false;
      plate_buffer.clear();
      previous_mask = Image8();
      std::fprintf(stderr, "[%s] plate learnt from %zu frames\n", name.c_str(), plate_frames);
      continue;
    }
    if (!background || !link.ready()) continue;
    if (fps <= 0) fps = grabber.sourceFps() > 0 ? grabber.sourceFps() : 15.0;
    // Frame ids on the rig's wall-clock grid, as every pod numbers them;
    // a source faster than the rig gives up the frames between.
    const uint64_t period_ns = static_cast<uint64_t>(1e9 / fps);
    const uint64_t frame_id = protocol::realtimeNs() / period_ns;
    if (frame_id <= last_frame_id) {
      ++skipped;
      continue;
    }
    last_frame_id = frame_id;
    const uint64_t t1 = monotonicNs();
    Image8 mask =
        background->segment(color, nullptr, previous_mask.empty() ? nullptr : &previous_mask);
    const uint64_t t2 = monotonicNs();
    const Image8 feather = featherMap(mask);
    const uint64_t t3 = monotonicNs();
    std::vector<protocol::StageStamp> stamps = {
        {static_cast<uint16_t>(Stage::kPodRender), static_cast<uint16_t>(options.pod_id), t0, t1},
        {static_cast<uint16_t>(Stage::kSegment), static_cast<uint16_t>(options.pod_id), t1, t2},
        {static_cast<uint16_t>(Stage::kFeather), static_cast<uint16_t>(options.pod_id), t2, t3}};
    link.send(std::make_shared<const protocol::OutgoingFrame>(holofuse::encodePodFrame(
        {frame_id, t0, &color, &mask, &feather}, stamps, options.pod_id, options.encoding)));
    previous_mask = std::move(mask);
    ++sent;
    if (options.frames > 0 && sent >= options.frames) break;
    if (t3 - last_report > 5000000000ull) {
      last_report = t3;
      std::fprintf(stderr, "[%s] %llu frames sent, %llu skipped, %llu refused, %llu reconnects\n",
                   name.c_str(), static_cast<unsigned long long>(sent),
                   static_cast<unsigned long long>(skipped),
                   static_cast<unsigned long long>(refused),
                   static_cast<unsigned long long>(grabber.reconnects()));
    }
  }
  while (!stopRequested() && link.ready() && link.queuedFrames() > 0) pump(20);
  link.close(stopRequested() ? "pod stopped by signal" : "pod finished its frames",
             stopRequested() ? 500 : 10000);
  std::fprintf(stderr,
               "[%s] sent %llu frames (%llu skipped to the rig's rate, %llu refused), %.1f MB, "
               "%llu reconnects to the source\n",
               name.c_str(), static_cast<unsigned long long>(sent),
               static_cast<unsigned long long>(skipped), static_cast<unsigned long long>(refused),
               link.bytesOut() / 1e6, static_cast<unsigned long long>(grabber.reconnects()));
  return 0;
}

}  // namespace holofuse::capture

// A pod on a real camera, started for real: capture_node --source reads a
// video file (paced at its frame rate), an HTTP stream served on loopback
// by ffmpeg or an RTSP stream served by GStreamer's RTSP server,
// undistorts, segments against the camera's plate and streams to a
// fusion server that records what it receives. A source of
// another size than the calibration is refused by name; a stream that
// drops is reconnected.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <sstream>

#include "base/process.h"
#include "codec/image_codec.h"
#include "codec/pod_frame_codec.h"
#include "dataset/dataset.h"
#include "geometry/camera.h"
#include "loop_test.h"
#include "metrics/image_metrics.h"
#include "protocol/socket.h"
#include "scene/scene_library.h"
#include "scene/synthetic_scene.h"

namespace holofuse {
namespace {

using namespace holofuse::test;

cv::Mat bgrOf(const Image8& rgb) {
  cv::Mat m(static_cast<int>(rgb.height), static_cast<int>(rgb.width), CV_8UC3,
            const_cast<uint8_t*>(rgb.pixels.data()));
  cv::Mat bgr;
  cv::cvtColor(m, bgr, cv::COLOR_RGB2BGR);
  return bgr;
}

// One studio camera filmed: its video (FFV1, lossless, 10 fps), its plate
// and the rig's calibration (capture.json, cameras only), and the true
// masks of the video's frames.
struct FilmedCamera {
  fs::path calibration, video, plate;
  std::vector<Image8> truth;
};

FilmedCamera film(const fs::path& dir, int frames, uint32_t width = 160, uint32_t height = 120,
                  uint32_t video_width = 0, uint32_t video_height = 0, int empty_frames = 0) {
  scene::SceneOptions options = scene::findScene("studio")->scene;
  options.late_prop = false;  // one camera: nobody to outvote a prop
  const scene::SyntheticScene studio(options);
  const Camera camera = scene::SyntheticScene::cameraRig(4, width, height)[1];
  FilmedCamera filmed;
  fs::create_directories(dir);
  filmed.calibration = dir / "rig";
  fs::create_directories(filmed.calibration);
  nlohmann::json r = nlohmann::json::array();
  for (int row = 0; row < 3; ++row)
    r.push_back({camera.rotation[0][row], camera.rotation[1][row], camera.rotation[2][row]});
  nlohmann::json capture = {{"format", "holofuse-capture"}, {"version", 1}};
  capture["cameras"].push_back(
      {{"name", "door"},
       {"width", camera.width},
       {"height", camera.height},
       {"K", {{camera.fx, camera.skew, camera.cx}, {0, camera.fy, camera.cy}, {0, 0, 1}}},
       {"R", r},
       {"t", {camera.translation.x, camera.translation.y, camera.translation.z}}});
  std::ofstream(filmed.calibration / "capture.json") << capture.dump(2);
  filmed.plate = dir / "plate.png";
  EXPECT_TRUE(cv::imwrite(filmed.plate.string(), bgrOf(studio.backgroundPlate(camera))));
  filmed.video = dir / "door.mkv";
  const cv::Size size(static_cast<int>(video_width ? video_width : width),
                      static_cast<int>(video_height ? video_height : height));
  cv::VideoWriter writer(filmed.video.string(), cv::VideoWriter::fourcc('F', 'F', 'V', '1'), 10,
                         size);
  EXPECT_TRUE(writer.isOpened());
  // The empty room first (a sensor's noise on the plate), when asked for.
  cv::RNG rng(7);
  for (int f = 0; f < empty_frames; ++f) {
    cv::Mat noise(size, CV_16SC3), frame;
    rng.fill(noise, cv::RNG::UNIFORM, cv::Scalar::all(-2), cv::Scalar::all(3));
    bgrOf(studio.backgroundPlate(camera)).convertTo(frame, CV_16SC3);
    frame += noise;
    frame.convertTo(frame, CV_8UC3);
    writer << frame;
  }
  for (int f = 0; f < frames; ++f) {
    const auto view = studio.render(camera, static_cast<uint64_t>(20 + f));
    filmed.truth.push_back(view.mask);
    cv::Mat bgr = bgrOf(view.color);
    if (bgr.size() != size) cv::resize(bgr, bgr, size);
    writer << bgr;
  }
  return filmed;
}

// Every mask the server recorded from pod 0, decoded.
std::vector<Image8> recordedMasks(const fs::path& recording) {
  std::vector<Image8> masks;
  auto dataset = dataset::Dataset::open(recording.string());
  EXPECT_TRUE(dataset.isOk()) << dataset.status().toString();
  if (!dataset.isOk() || dataset->cameras().count(0) == 0) return masks;
  const auto& camera = dataset->cameras().at(0);
  auto calibration = dataset->readCalibration(0);
  EXPECT_TRUE(calibration.isOk());
  for (const auto& record : camera.frames) {
    auto frame = dataset->readFrame(record);
    EXPECT_TRUE(frame.isOk());
    auto images = dataset::decodePodImages(*frame, fromCalibration(*calibration));
    EXPECT_TRUE(images.isOk()) << images.status().toString();
    if (images.isOk()) masks.push_back(images->mask);
  }
  return masks;
}

// The pod on a filmed camera's video against a server that records what it
// receives; the masks recorded. extra: the pod's flags after --calibration.
std::vector<Image8> streamThroughPod(const fs::path& out, const FilmedCamera& filmed,
                                     const std::vector<std::string>& extra) {
  pid_t server = 0;
  const std::string endpoint =
      startServer(out, 1, &server, {"--record", (out / "recording").string()});
  EXPECT_FALSE(endpoint.empty()) << readFile(out / "server.log");
  std::vector<std::string> args = {kBin + "/capture_node",
                                   "--server",
                                   endpoint,
                                   "--pod-id",
                                   "0",
                                   "--source",
                                   filmed.video.string(),
                                   "--calibration",
                                   filmed.calibration.string()};
  args.insert(args.end(), extra.begin(), extra.end());
  const pid_t pod = spawn(args, out / "pod.log");
  EXPECT_EQ(waitExit(pod, 60), 0) << readFile(out / "pod.log");
  kill(server, SIGTERM);
  EXPECT_EQ(waitExit(server, 30), 0) << readFile(out / "server.log");
  return recordedMasks(out / "recording");
}

// Every recorded mask is segmented as the truth of one of the video's
// frames (which one, the wall-clock grid decides).
void expectEachMaskIsAFramesTruth(const std::vector<Image8>& masks, const FilmedCamera& filmed) {
  for (size_t m = 0; m < masks.size(); ++m) {
    double best = 0;
    for (const Image8& truth : filmed.truth)
      best = std::max(best, metrics::maskIoU(masks[m], truth));
    EXPECT_GE(best, 0.95) << "recorded frame " << m;
  }
}

// A video file through the real pod, its plate a picture: the server
// receives the calibration and most frames, each segmented as the truth.
TEST(CameraPod, AVideoFileIsSegmentedAndStreamed) {
  const fs::path out = freshDir("camera_pod_file");
  const FilmedCamera filmed = film(out, 12);
  const auto masks = streamThroughPod(out, filmed, {"--plate", filmed.plate.string()});
  const std::string log = readFile(out / "pod.log");
  EXPECT_NE(log.find("camera \"door\" (160x120)"), std::string::npos) << log;
  ASSERT_GE(masks.size(), 6u) << "most of the 12 frames reach the server\n" << log;
  expectEachMaskIsAFramesTruth(masks, filmed);
  fs::remove_all(out);
}

// No plate file: the pod learns the plate from the source's first frames,
// the room still empty, then segments the subject as well as with one.
TEST(CameraPod, ThePlateIsLearntFromTheSourcesFirstFrames) {
  const fs::path out = freshDir("camera_pod_learn");
  const FilmedCamera filmed = film(out, 10, 160, 120, 0, 0, 6);
  const auto masks = streamThroughPod(out, filmed, {"--plate-frames", "6"});
  EXPECT_TRUE(logSays(out / "pod.log", "plate learnt from 6 frames")) << readFile(out / "pod.log");
  ASSERT_GE(masks.size(), 5u) << readFile(out / "pod.log");
  expectEachMaskIsAFramesTruth(masks, filmed);
  fs::remove_all(out);
}

// --plate-on-key: nothing is streamed until Enter (a line on the pod's
// standard input) takes the plate from the next frames; here the room
// stays empty, so once the plate is learnt the masks hold nothing.
TEST(CameraPod, ThePlateIsTakenWhenEnterIsPressed) {
  const fs::path out = freshDir("camera_pod_key");
  const FilmedCamera filmed = film(out, 0, 160, 120, 0, 0, 8);
  pid_t server = 0;
  const std::string endpoint =
      startServer(out, 1, &server, {"--record", (out / "recording").string()});
  ASSERT_FALSE(endpoint.empty()) << readFile(out / "server.log");
  // The pod's standard input is a pipe the test writes its Enter into.
  ChildPipes pipes;
  auto pod = spawnProcess({kBin + "/capture_node", "--server", endpoint, "--pod-id", "0", "--loop",
                           "--source", filmed.video.string(), "--calibration",
                           filmed.calibration.string(), "--plate-frames", "4", "--plate-on-key"},
                          {(out / "pod.log").string()}, &pipes);
  ASSERT_TRUE(pod.isOk()) << pod.status().toString();
  ASSERT_TRUE(waitFor([&] { return logSays(out / "pod.log", "press Enter to take the plate"); }))
      << readFile(out / "pod.log");
  EXPECT_EQ(::write(pipes.to_child, "\n", 1), 1);
  EXPECT_TRUE(waitFor([&] { return logSays(out / "pod.log", "plate learnt from 4 frames"); }))
      << readFile(out / "pod.log");
  EXPECT_TRUE(waitFor([&] { return recordedMasks(out / "recording").size() >= 3; }))
      << readFile(out / "pod.log");
  kill(*pod, SIGTERM);
  EXPECT_EQ(waitExit(*pod, 30), 0) << readFile(out / "pod.log");
  ::close(pipes.to_child);
  ::close(pipes.from_child);
  kill(server, SIGTERM);
  waitExit(server, 30);
  for (const Image8& mask : recordedMasks(out / "recording")) {
    size_t subject = 0;
    for (uint8_t v : mask.pixels) subject += v != 0;
    EXPECT_LT(subject, mask.pixels.size() / 100) << "an empty room, against its own plate";
  }
  fs::remove_all(out);
}

// A source whose frames are not the calibration's size: refused, naming
// the source, the camera and both sizes; nothing is sent.
TEST(CameraPod, AFrameOfAnotherSizeIsRefusedByName) {
  const fs::path out = freshDir("camera_pod_size");
  const FilmedCamera filmed = film(out, 3, 160, 120, 128, 96);
  const pid_t pod = spawn({kBin + "/capture_node", "--server", "127.0.0.1:9", "--pod-id", "0",
                           "--source", filmed.video.string(), "--calibration",
                           filmed.calibration.string(), "--plate", filmed.plate.string()},
                          out / "pod.log");
  EXPECT_EQ(waitExit(pod, 60), 2);
  const std::string log = readFile(out / "pod.log");
  EXPECT_NE(log.find("gives a 128x96 frame; camera \"door\"'s calibration is 160x120"),
            std::string::npos)
      << log;
  EXPECT_NE(log.find(filmed.video.string()), std::string::npos) << log;

  // A camera the calibration lacks, and a camera with no plate at all.
  const pid_t unknown = spawn(
      {kBin + "/capture_node", "--server", "127.0.0.1:9", "--pod-id", "0", "--source",
       filmed.video.string(), "--calibration", filmed.calibration.string(), "--camera", "window"},
      out / "unknown.log");
  EXPECT_EQ(waitExit(unknown, 30), 2);
  EXPECT_TRUE(logSays(out / "unknown.log", "no camera named \"window\"; it has door"))
      << readFile(out / "unknown.log");
  const pid_t bare =
      spawn({kBin + "/capture_node", "--server", "127.0.0.1:9", "--pod-id", "0", "--source",
             filmed.video.string(), "--calibration", filmed.calibration.string()},
            out / "bare.log");
  EXPECT_EQ(waitExit(bare, 30), 2);
  EXPECT_TRUE(logSays(out / "bare.log", "camera \"door\" has no plate"))
      << readFile(out / "bare.log");
  fs::remove_all(out);
}

// A program on $PATH, by its full path (empty when there is none).
std::string onPath(const std::string& program) {
  const char* path = std::getenv("PATH");
  std::stringstream dirs(path != nullptr ? path : "/usr/bin");
  for (std::string dir; std::getline(dirs, dir, ':');) {
    const fs::path candidate = fs::path(dir) / program;
    if (::access(candidate.c_str(), X_OK) == 0) return candidate.string();
  }
  return "";
}

// A stream at url that serve(log) starts on loopback: the pod streams
// it, loses it when the server of the stream is killed, says so, and is
// back once it is started again; frames then flow again.
void expectTheStreamReconnects(const fs::path& out, const FilmedCamera& filmed,
                               const std::string& url,
                               const std::function<pid_t(const std::string&)>& serve) {
  pid_t stream = serve("stream1.log");
  pid_t server = 0;
  const std::string endpoint =
      startServer(out, 1, &server, {"--record", (out / "recording").string()});
  ASSERT_FALSE(endpoint.empty()) << readFile(out / "server.log");
  const pid_t pod = spawn({kBin + "/capture_node", "--server", endpoint, "--pod-id", "0",
                           "--source", url, "--calibration", filmed.calibration.string(), "--plate",
                           filmed.plate.string(), "--fps", "10"},
                          out / "pod.log");
  // Frames reach the server (and its recording).
  const auto framesRecorded = [&] { return recordedMasks(out / "recording").size(); };
  ASSERT_TRUE(waitFor([&] { return framesRecorded() >= 3; }, 60))
      << readFile(out / "pod.log") << readFile(out / "stream1.log");
  kill(stream, SIGKILL);
  waitExit(stream, 10);
  EXPECT_TRUE(waitFor([&] { return logSays(out / "pod.log", "stopped sending frames"); }, 60))
      << readFile(out / "pod.log");
  stream = serve("stream2.log");
  EXPECT_TRUE(waitFor([&] { return logSays(out / "pod.log", "is back (reconnect 1)"); }, 60))
      << readFile(out / "pod.log");
  const size_t before = framesRecorded();
  EXPECT_TRUE(waitFor([&] { return framesRecorded() > before + 3; }, 60));
  kill(pod, SIGTERM);
  EXPECT_EQ(waitExit(pod, 30), 0) << readFile(out / "pod.log");
  kill(stream, SIGKILL);
  waitExit(stream, 10);
  kill(server, SIGTERM);
  waitExit(server, 30);
  EXPECT_TRUE(logSays(out / "pod.log", "1 reconnects to the source")) << readFile(out / "pod.log");
}

// An HTTP stream served by ffmpeg (MPEG-2 in MPEG-TS, as an encoder box
// sends it), looping the filmed video in real time.
TEST(CameraPod, AnHttpStreamThatDropsIsReconnected) {
  const std::string ffmpeg = onPath("ffmpeg");
  ASSERT_FALSE(ffmpeg.empty()) << "ffmpeg is not installed (./holofuse deps installs it)";
  const fs::path out = freshDir("camera_pod_http");
  const FilmedCamera filmed = film(out, 20);
  const std::string url = "http://127.0.0.1:" + std::to_string(freePort()) + "/door";
  expectTheStreamReconnects(out, filmed, url, [&](const std::string& log) {
    return spawn({ffmpeg, "-hide_banner", "-loglevel", "error", "-re", "-stream_loop", "-1", "-i",
                  filmed.video.string(), "-c:v", "mpeg2video", "-q:v", "2", "-f", "mpegts",
                  "-listen", "1", url},
                 out / log);
  });
  fs::remove_all(out);
}

// An RTSP stream (Motion-JPEG over RTP, as IP cameras send it) from
// GStreamer's RTSP server (tests/integration/rtsp_server.py): a live test
// picture of the camera's size.
TEST(CameraPod, AnRtspStreamThatDropsIsReconnected) {
  const fs::path out = freshDir("camera_pod_rtsp");
  const FilmedCamera filmed = film(out, 1);
  const std::string port = std::to_string(freePort());
  const std::string url = "rtsp://127.0.0.1:" + port + "/door";
  expectTheStreamReconnects(out, filmed, url, [&](const std::string& log) {
    return spawn({"/usr/bin/python3", HOLOFUSE_TESTS_DIR "/integration/rtsp_server.py", port,
                  "door", "160", "120", "10"},
                 out / log);
  });
  fs::remove_all(out);
}

}  // namespace
}  // namespace holofuse

// Datasets through the network path, with real processes on loopback: a
// live loop records what its pods send, `holofuse_dataset verify` checks
// it, replays through server and client fuse the same meshes bit for bit,
// a recorder killed with SIGKILL keeps every whole record, and bad input
// is named.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <set>
#include <sstream>
#include <thread>

#include "dataset/dataset.h"
#include "dataset/record_file.h"
#include "loop_test.h"
#include "protocol/messages.h"
#include "scene/synthetic_scene.h"

namespace holofuse {
namespace {

using namespace holofuse::test;

// frame id -> the Draco bytes of the fused mesh, from a fused.hfr.
std::map<uint64_t, protocol::Bytes> fusedMeshes(const fs::path& file) {
  std::map<uint64_t, protocol::Bytes> meshes;
  auto reader = dataset::RecordReader::open(file.string());
  EXPECT_TRUE(reader.isOk()) << reader.status().toString();
  if (!reader.isOk()) return meshes;
  for (const auto& r : reader->records()) {
    if (r.kind != static_cast<uint16_t>(dataset::RecordKind::kMeshFrame)) continue;
    auto bytes = reader->read(r);
    EXPECT_TRUE(bytes.isOk());
    auto frame = dataset::parseWholeFrame(*bytes, file.string());
    EXPECT_TRUE(frame.isOk()) << frame.status().toString();
    protocol::MeshFrame mesh;
    EXPECT_TRUE(protocol::decodeFrame(*frame, mesh).isOk());
    EXPECT_EQ(mesh.frame_id, r.frame_id);
    meshes[r.frame_id] = protocol::Bytes(mesh.mesh.begin(), mesh.mesh.end());
  }
  return meshes;
}

// camera -> every PodFrame's planes (kind and compressed bytes) in order.
std::map<uint32_t, std::vector<protocol::Bytes>> recordedPlanes(const fs::path& dir) {
  std::map<uint32_t, std::vector<protocol::Bytes>> planes;
  auto dataset = dataset::Dataset::open(dir.string());
  EXPECT_TRUE(dataset.isOk()) << dataset.status().toString();
  if (!dataset.isOk()) return planes;
  for (const auto& [id, camera] : dataset->cameras()) {
    for (const auto& r : camera.frames) {
      auto frame = dataset->readFrame(r);
      EXPECT_TRUE(frame.isOk()) << frame.status().toString();
      protocol::PodFrame pod;
      EXPECT_TRUE(protocol::decodeFrame(*frame, pod).isOk());
      protocol::Bytes all;
      for (const auto& plane : pod.planes) {
        all.push_back(static_cast<uint8_t>(plane.kind));
        all.insert(all.end(), plane.data.begin(), plane.data.end());
      }
      planes[id].push_back(std::move(all));
    }
  }
  return planes;
}

class DatasetLoop : public ::testing::Test {
 protected:
  // One short live recording shared by the tests of this suite.
  static void SetUpTestSuite() {
    root_ = freshDir("dataset_loop");
    recording_ = root_ / "recording";
    const pid_t loop = spawn(
        {kBin + "/holofuse_loop", "--pods", "2", "--frames", "5", "--fps", "4", "--size", "160x120",
         "--out", (root_ / "live").string(), "--record", recording_.string(), "--record-fused"},
        root_ / "live.log");
    live_exit_ = waitExit(loop, 240);
  }
  static void TearDownTestSuite() { fs::remove_all(root_); }

  // Replays the recording as fast as the server accepts, recording what
  // the replay pods sent and the fused output into out/record.
  static int replay(const fs::path& out) {
    const pid_t loop =
        spawn({kBin + "/holofuse_loop", "--replay", recording_.string(), "--speed", "max", "--out",
               out.string(), "--record", (out / "record").string(), "--record-fused"},
              out.string() + ".log");
    return waitExit(loop, 240);
  }

  static inline fs::path root_, recording_;
  static inline int live_exit_ = -1;
};

TEST_F(DatasetLoop, TheLiveLoopRecordsWholeCheckedProtocolFrames) {
  ASSERT_EQ(live_exit_, 0) << readFile(root_ / "live.log");
  const pid_t verify =
      spawn({kBin + "/holofuse_dataset", "verify", recording_.string()}, root_ / "verify.log");
  ASSERT_EQ(waitExit(verify, 60), 0) << readFile(root_ / "verify.log");
  const std::string text = readFile(root_ / "verify.log");
  EXPECT_NE(text.find("index: in place"), std::string::npos) << text;
  EXPECT_NE(text.find("every record's CRC32C matches"), std::string::npos) << text;
  EXPECT_NE(text.find("verdict: OK"), std::string::npos) << text;

  auto dataset = dataset::Dataset::open(recording_.string());
  ASSERT_TRUE(dataset.isOk()) << dataset.status().toString();
  ASSERT_EQ(dataset->cameras().size(), 2u);
  for (const auto& [id, camera] : dataset->cameras()) {
    ASSERT_TRUE(camera.calibration.has_value()) << "camera " << id;
    EXPECT_GE(camera.frames.size(), 3u) << "camera " << id;
    // Byte for byte as received: every record is a whole frame whose own
    // CRC32C still checks, from the pod it is filed under.
    for (const auto& r : camera.frames) {
      auto frame = dataset->readFrame(r);
      ASSERT_TRUE(frame.isOk()) << frame.status().toString();
      protocol::PodFrame pod;
      ASSERT_TRUE(protocol::decodeFrame(*frame, pod).isOk());
      EXPECT_EQ(pod.camera_id, id);
      EXPECT_EQ(pod.frame_id, r.frame_id);
    }
  }
}

// eval --dataset on a recording of the live loop (the real-capture test
// below needs ../shared/datasets): the recorded images go through the same
// hull, codecs and renderer, scored inside the recorded masks.
TEST_F(DatasetLoop, EvalScoresARecordingLeaveOneCameraOut) {
  ASSERT_EQ(live_exit_, 0) << readFile(root_ / "live.log");
  const fs::path out = root_ / "eval";
  const pid_t eval = spawn({kBin + "/holofuse_eval", "--dataset", recording_.string(), "--frames",
                            "2", "--modes", "normal,holoportation", "--out", out.string()},
                           root_ / "eval.log");
  ASSERT_EQ(waitExit(eval, 240), 0) << readFile(root_ / "eval.log");
  const auto quality = readJson(out / "quality.json");
  ASSERT_TRUE(quality["scenes"].contains("dataset:recording")) << quality["scenes"].dump();
  const auto& scene = quality["scenes"]["dataset:recording"];
  EXPECT_EQ(scene["cameras"].get<int>(), 2);
  for (const char* mode : {"normal", "holoportation"}) {
    // Two frames, each of the two cameras held out in turn.
    EXPECT_EQ(scene["modes"][mode]["images"].get<int>(), 4) << mode;
    EXPECT_GT(scene["modes"][mode]["psnr_db"].get<double>(), 8.0) << mode;
  }
  EXPECT_GT(scene["codec_ms"].get<double>(), 0.0)
      << "the recorded images are decoded and the hull sent through Draco";
  for (const char* stage : {"server_decode", "mesh_encode", "image_encode", "decode"}) {
    EXPECT_GT(scene["codec_stages_ms"][stage]["p50"].get<double>(), 0.0) << stage;
  }
  EXPECT_EQ(scene["codec_stages_ms"]["pod_encode"]["p50"].get<double>(), 0.0)
      << "a recording's pods encoded long ago";
  EXPECT_TRUE(scene["hull"]["chamfer_mm"].is_null()) << "a recording has no true surface";

  // Bytes per link as the live loop sent them. The eval's frames are the
  // recording's first two ids that every camera holds: the pods' frames
  // are the recorded ones, and the server's packing of the same hull is
  // what the live server recorded (MeshFrame, TextureBundle, Stats), up to
  // the stamps and notes inside.
  auto dataset = dataset::Dataset::open(recording_.string());
  ASSERT_TRUE(dataset.isOk()) << dataset.status().toString();
  std::map<uint64_t, std::map<uint32_t, size_t>>
      pod_bytes;  // frame id -> camera -> bytes on the wire
  for (const auto& [id, camera] : dataset->cameras()) {
    for (const auto& r : camera.frames) {
      auto frame = dataset->readFrame(r);
      ASSERT_TRUE(frame.isOk()) << frame.status().toString();
      pod_bytes[r.frame_id].try_emplace(id, frame->bytes.size());
    }
  }
  std::vector<uint64_t> ids;
  double pod_link = 0;
  for (const auto& [frame_id, by_camera] : pod_bytes) {
    if (by_camera.size() != 2 || ids.size() == 2) continue;
    ids.push_back(frame_id);
    for (const auto& [camera, bytes] : by_camera) pod_link += static_cast<double>(bytes) / 2;
  }
  ASSERT_EQ(ids.size(), 2u);
  EXPECT_DOUBLE_EQ(scene["pod_link_bytes_per_frame"].get<double>(), pod_link);
  // The server's packing of those frames: a lossless replay of the same
  // recording fuses every group (a live server under load drops groups,
  // so the live recording may lack one of the two).
  ASSERT_EQ(replay(root_ / "eval_replay"), 0) << readFile(root_ / "eval_replay.log");
  auto fused =
      dataset::RecordReader::open((root_ / "eval_replay" / "record" / "fused.hfr").string());
  ASSERT_TRUE(fused.isOk()) << fused.status().toString();
  std::map<uint64_t, double> client_link;  // frame id -> bytes the server sent for it
  for (const auto& r : fused->records()) client_link[r.frame_id] += r.payload_length;
  double fused_sum = 0;
  for (uint64_t id : ids) {
    ASSERT_TRUE(client_link.contains(id)) << "the lossless replay did not fuse frame " << id;
    fused_sum += client_link[id];
  }
  const double client_mean = fused_sum / 2;
  EXPECT_NEAR(scene["bytes_per_frame"].get<double>(), client_mean, 0.01 * client_mean);
}

// The sweep's codec settings in a replay reach the server's images to
// clients only: the replay pods send the recorded bytes, and refuse codec
// flags (so a launcher that passed them on would fail here).
TEST_F(DatasetLoop, AReplayTakesCodecSettingsAtTheServerOnly) {
  ASSERT_EQ(live_exit_, 0) << readFile(root_ / "live.log");
  const fs::path out = root_ / "replay_codec";
  const pid_t loop =
      spawn({kBin + "/holofuse_loop", "--replay", recording_.string(), "--speed", "max",
             "--image-codec", "lz4", "--lz4-acceleration", "8", "--out", out.string()},
            root_ / "replay_codec.log");
  ASSERT_EQ(waitExit(loop, 240), 0) << readFile(root_ / "replay_codec.log");
  const std::string server_log = readFile(out / "logs" / "server.log");
  EXPECT_NE(server_log.find("images to clients lz4 at LZ4 acceleration 8"), std::string::npos)
      << server_log;
  EXPECT_GT(readJson(out / "report.json")["frames_rendered"].get<int>(), 0);
}

TEST_F(DatasetLoop, ReplayFusesTheSameMeshesBitForBitAndSendsTheRecordedImages) {
  ASSERT_EQ(live_exit_, 0) << readFile(root_ / "live.log");
  const fs::path first = root_ / "replay1", second = root_ / "replay2";
  ASSERT_EQ(replay(first), 0) << readFile(first.string() + ".log");
  ASSERT_EQ(replay(second), 0) << readFile(second.string() + ".log");

  auto dataset = dataset::Dataset::open(recording_.string());
  ASSERT_TRUE(dataset.isOk());
  const auto a = fusedMeshes(first / "record" / "fused.hfr");
  const auto b = fusedMeshes(second / "record" / "fused.hfr");
  // Every recorded frame id is fused (nothing dropped at max speed), and
  // the two replays agree bit for bit.
  EXPECT_EQ(a.size(), dataset->frameIds());
  ASSERT_EQ(a.size(), b.size());
  for (const auto& [id, bytes] : a) {
    ASSERT_EQ(b.count(id), 1u) << "frame " << id;
    EXPECT_GT(bytes.size(), 100u) << "frame " << id;
    EXPECT_TRUE(bytes == b.at(id)) << "frame " << id << " differs between the replays";
  }
  // What the replay pods sent is what the live pods sent: the same planes,
  // byte for byte, in the same order.
  EXPECT_EQ(recordedPlanes(first / "record"), recordedPlanes(recording_));

  // A looping replay keeps going past the recording's end with new ids.
  const fs::path looped = root_ / "looped";
  const pid_t loop =
      spawn({kBin + "/holofuse_loop", "--replay", recording_.string(), "--speed", "4", "--loop",
             "--frames", std::to_string(2 * a.size() + 2), "--out", looped.string()},
            looped.string() + ".log");
  ASSERT_EQ(waitExit(loop, 240), 0) << readFile(looped.string() + ".log");
  const auto looped_report = readJson(looped / "report.json");
  EXPECT_EQ(looped_report["frames_rendered"].get<size_t>(), 2 * a.size() + 2);
  EXPECT_GT(looped_report["frames"].back()["frame_id"].get<uint64_t>(), dataset->lastFrameId());

  // The same client and report as the live loop, with the replay's stage.
  const auto report = readJson(first / "report.json");
  ASSERT_GT(report["frames_rendered"].get<int>(), 0);
  ASSERT_TRUE(report["latency_ms"]["stages"].contains("replay_read"));
  EXPECT_TRUE(report["quality"].empty()) << "a replay has no truth to judge frames by";
  EXPECT_TRUE(report["frames"][0]["psnr_db"].is_null());
  EXPECT_GT(report["latency_ms"]["stages"]["replay_read"]["samples"].get<int>(), 0);
  // Replay pods are counted at the server like live ones: each counted,
  // up to every frame the recording holds of its camera (a live frame
  // that came too late to be fused was not recorded, so a camera may hold
  // fewer than the others). The count is the last Stats the client read:
  // at max speed under validation it left with later ones unread (pod 0
  // at 3 of 6), so it may be short of the whole.
  EXPECT_EQ(report["jitter_source"], "server, over every pod frame received");
  const auto& at_server = report["pod_frames_at_server"];
  ASSERT_EQ(at_server.size(), dataset->cameras().size()) << "every camera replays as a pod";
  for (const auto& [id, camera] : dataset->cameras()) {
    const std::string pod = "pod_" + std::to_string(id);
    ASSERT_TRUE(at_server.contains(pod)) << at_server.dump();
    EXPECT_GT(at_server[pod].get<size_t>(), 0u) << pod;
    EXPECT_LE(at_server[pod].get<size_t>(), camera.frames.size()) << pod;
  }
}

// SIGKILL the recording server while pods stream: every record written
// whole reads back, verify says what (if anything) at the end is
// incomplete, and the dataset still replays.
TEST(DatasetRecorder, AKilledRecorderKeepsEveryWholeRecordAndStillReplays) {
  const fs::path out = freshDir("dataset_killed");
  const fs::path recording = out / "recording";
  pid_t server = 0;
  const std::string endpoint = startServer(out, 2, &server, {"--record", recording.string()});
  ASSERT_FALSE(endpoint.empty()) << readFile(out / "server.log");
  std::vector<pid_t> pods;
  for (int i = 0; i < 2; ++i) {
    pods.push_back(spawn({kBin + "/capture_node", "--server", endpoint, "--pod-id",
                          std::to_string(i), "--pods", "2", "--size", "160x120", "--fps", "8"},
                         out / ("pod" + std::to_string(i) + ".log")));
  }
  const fs::path file = recording / "pods.hfr";
  for (int i = 0; i < 600 && (!fs::exists(file) || fs::file_size(file) < 300000); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_TRUE(fs::exists(file) && fs::file_size(file) >= 300000) << readFile(out / "server.log");
  kill(server, SIGKILL);
  EXPECT_EQ(waitExit(server, 10), 128 + SIGKILL);
  for (pid_t pod : pods) {
    kill(pod, SIGTERM);
    waitExit(pod, 10);
  }

  const pid_t verify =
      spawn({kBin + "/holofuse_dataset", "verify", recording.string()}, out / "verify.log");
  const int verdict = waitExit(verify, 60);
  const std::string text = readFile(out / "verify.log");
  ASSERT_TRUE(verdict == 0 || verdict == 3) << text;
  EXPECT_NE(
      text.find("no index at the end (the recording was not closed cleanly); rebuilt by scanning"),
      std::string::npos)
      << text;
  EXPECT_NE(text.find("every record's CRC32C matches"), std::string::npos) << text;
  auto reader = dataset::RecordReader::open(file.string());
  ASSERT_TRUE(reader.isOk());
  EXPECT_GE(reader->records().size(), 4u);
  EXPECT_TRUE(reader->verifyAll().isOk());
  if (verdict == 3) {
    // The bytes named are exactly those after the last whole record.
    const std::string bytes = "bytes " + std::to_string(reader->scan().good_end) + ".." +
                              std::to_string(fs::file_size(file));
    EXPECT_NE(text.find("incomplete tail: " + bytes), std::string::npos) << text;
  } else {
    EXPECT_EQ(reader->scan().good_end, fs::file_size(file));
  }

  const pid_t loop = spawn({kBin + "/holofuse_loop", "--replay", recording.string(), "--speed",
                            "max", "--out", (out / "replay").string()},
                           out / "replay.log");
  ASSERT_EQ(waitExit(loop, 240), 0) << readFile(out / "replay.log");
  EXPECT_GT(readJson(out / "replay" / "report.json")["frames_rendered"].get<int>(), 0);
  fs::remove_all(out);
}

// The recording runs out of space (a file size limit fails writes the way
// a full disk does): the server says so, keeps what it wrote, and goes on
// serving its client.
TEST(DatasetRecorder, ARecordingThatRunsOutOfSpaceIsReportedAndServingGoesOn) {
  const fs::path out = freshDir("dataset_full");
  const fs::path recording = out / "recording";
  // 600 KB: a few frames of two pods, then every write fails.
  const pid_t server = spawn({"/bin/bash", "-c",
                              "ulimit -f 600 && exec " + kBin +
                                  "/fusion_server --listen 127.0.0.1:0 --pods 2 "
                                  "--port-file " +
                                  (out / "port").string() + " --record " + recording.string()},
                             out / "server.log");
  std::string port;
  for (int i = 0; i < 100 && port.empty(); ++i) {
    std::ifstream in(out / "port");
    std::getline(in, port);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_FALSE(port.empty()) << readFile(out / "server.log");
  const std::string endpoint = "127.0.0.1:" + port;
  std::vector<pid_t> pods;
  for (int i = 0; i < 2; ++i) {
    pods.push_back(spawn({kBin + "/capture_node", "--server", endpoint, "--pod-id",
                          std::to_string(i), "--pods", "2", "--size", "160x120", "--fps", "8"},
                         out / ("pod" + std::to_string(i) + ".log")));
  }
  // A client that asks for more frames than fit in the recording.
  const pid_t client = spawn({kBin + "/render_client", "--server", endpoint, "--out",
                              (out / "client").string(), "--frames", "24", "--size", "160x120"},
                             out / "client.log");
  EXPECT_EQ(waitExit(client, 240), 0) << readFile(out / "client.log");
  for (pid_t pod : pods) {
    kill(pod, SIGTERM);
    waitExit(pod, 10);
  }
  kill(server, SIGTERM);
  EXPECT_EQ(waitExit(server, 20), 0) << readFile(out / "server.log");
  const std::string log = readFile(out / "server.log");
  EXPECT_NE(log.find("recording failed, the server goes on: " + (recording / "pods.hfr").string() +
                     ": writing pod_frame"),
            std::string::npos)
      << log;
  EXPECT_NE(log.find("file size limit reached"), std::string::npos) << log;
  // Its progress says it stopped and what it holds, not a growing count.
  const size_t failed = log.find("recording failed, the server goes on");
  const size_t stopped = log.find("[server] recording stopped ");
  ASSERT_NE(stopped, std::string::npos) << log;
  EXPECT_NE(log.find("file size limit reached", stopped), std::string::npos) << log;
  EXPECT_EQ(log.find("[server] recording: ", failed), std::string::npos)
      << "a recording that stopped reported as recording\n"
      << log;
  EXPECT_EQ(readJson(out / "client" / "report.json")["frames_rendered"].get<int>(), 24);
  // What was written before the failure is whole and checks.
  auto reader = dataset::RecordReader::open((recording / "pods.hfr").string());
  ASSERT_TRUE(reader.isOk()) << reader.status().toString();
  EXPECT_GE(reader->records().size(), 3u);
  // The pod frames it says it holds are the ones in the file (the two
  // calibrations are the other records).
  const std::string holds = log.substr(log.find("it holds ", stopped) + 9);
  EXPECT_EQ(std::stoull(holds) + 2, reader->records().size()) << holds;
  EXPECT_LE(fs::file_size(recording / "pods.hfr"), 600u * 1024u);
  EXPECT_FALSE(reader->scan().tail_problem.has_value()) << *reader->scan().tail_problem;
  EXPECT_TRUE(reader->verifyAll().isOk());
  fs::remove_all(out);
}

TEST(DatasetRecorder, BadDatasetsAndCamerasAreNamed) {
  const fs::path out = freshDir("dataset_bad");
  // A folder that holds no recording.
  pid_t p =
      spawn({kBin + "/holofuse_loop", "--replay", out.string(), "--out", (out / "o").string()},
            out / "a.log");
  EXPECT_EQ(waitExit(p, 30), 2);
  EXPECT_NE(readFile(out / "a.log").find("not a holofuse dataset (no pods.hfr in it)"),
            std::string::npos)
      << readFile(out / "a.log");

  // A recording with one camera, asked for another.
  const fs::path dir = out / "one";
  fs::create_directories(dir);
  {
    auto writer = dataset::RecordWriter::create((dir / "pods.hfr").string(), 0);
    ASSERT_TRUE(writer.isOk());
    protocol::Calibration calibration;
    calibration.camera_id = 0;
    calibration.width = 64;
    calibration.height = 48;
    calibration.fx = calibration.fy = 50;
    calibration.rotation = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    const protocol::Bytes bytes = protocol::encodeOutgoing(calibration, 1).flatten();
    ASSERT_TRUE(writer->append(dataset::RecordKind::kCalibration, 0, 0, 0, bytes).isOk());
    ASSERT_TRUE(writer->close().isOk());
  }
  p = spawn({kBin + "/capture_node", "--server", "127.0.0.1:1", "--pod-id", "7", "--replay",
             dir.string()},
            out / "b.log");
  EXPECT_EQ(waitExit(p, 30), 2);
  EXPECT_NE(readFile(out / "b.log").find("has no calibration for camera 7 (cameras with one: 0)"),
            std::string::npos)
      << readFile(out / "b.log");
  p = spawn({kBin + "/capture_node", "--server", "127.0.0.1:1", "--pod-id", "0", "--replay",
             dir.string(), "--speed", "fast"},
            out / "c.log");
  EXPECT_EQ(waitExit(p, 30), 2);
  EXPECT_NE(readFile(out / "c.log").find("--speed 'fast': expected a factor"), std::string::npos)
      << readFile(out / "c.log");

  // A damaged byte: verify names the record and its offset, exit 1.
  std::string bytes = readFile(dir / "pods.hfr");
  const size_t damaged = dataset::kRecordFileHeaderSize + dataset::kRecordHeaderSize + 5;
  bytes[damaged] = static_cast<char>(bytes[damaged] ^ 0x10);
  std::ofstream(dir / "pods.hfr", std::ios::binary | std::ios::trunc) << bytes;
  p = spawn({kBin + "/holofuse_dataset", "verify", dir.string()}, out / "d.log");
  EXPECT_EQ(waitExit(p, 30), 1);
  EXPECT_NE(readFile(out / "d.log")
                .find("CORRUPT: " + (dir / "pods.hfr").string() +
                      ": the calibration record at byte 32: payload CRC32C mismatch"),
            std::string::npos)
      << readFile(out / "d.log");
  fs::remove_all(out);
}

// A capture as rigs store it, one video per camera (masks as videos
// beside them) named in a holofuse capture.json: imported by the real
// tool with its frames paired by the videos' timestamps, it is a moving
// sequence, not a still, and replays through the network path frame by
// frame, each fused from that instant's images.
TEST(ImportedVideos, AMultiFrameCaptureImportsAndReplaysFrameByFrame) {
  const fs::path out = freshDir("videos");
  const fs::path src = out / "capture";
  fs::create_directories(src / "videos");
  const scene::SyntheticScene scene;
  const auto cameras = scene::SyntheticScene::cameraRig(4, 160, 120);
  const int frames = 4;
  nlohmann::json capture = {{"format", "holofuse-capture"}, {"version", 1}};
  for (size_t i = 0; i < cameras.size(); ++i) {
    const Camera& c = cameras[i];
    const std::string name = "cam" + std::to_string(i);
    const cv::Size size(static_cast<int>(c.width), static_cast<int>(c.height));
    // FFV1 in Matroska: lossless, as a rig's intermediate files often are.
    const int ffv1 = cv::VideoWriter::fourcc('F', 'F', 'V', '1');
    cv::VideoWriter colour((src / "videos" / (name + ".mkv")).string(), ffv1, 10, size);
    cv::VideoWriter masks((src / "videos" / (name + "_mask.mkv")).string(), ffv1, 10, size);
    ASSERT_TRUE(colour.isOpened() && masks.isOpened());
    for (int f = 0; f < frames; ++f) {
      const auto view = scene.render(c, static_cast<uint64_t>(30 + 3 * f));
      cv::Mat rgb(size, CV_8UC3, const_cast<uint8_t*>(view.color.pixels.data())), bgr;
      cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
      colour << bgr;
      cv::Mat grey(size, CV_8UC1, const_cast<uint8_t*>(view.mask.pixels.data())), mask;
      cv::cvtColor(grey, mask, cv::COLOR_GRAY2BGR);
      masks << mask;
    }
    nlohmann::json r = nlohmann::json::array();
    for (int row = 0; row < 3; ++row)
      r.push_back({c.rotation[0][row], c.rotation[1][row], c.rotation[2][row]});
    capture["cameras"].push_back({{"name", name},
                                  {"width", c.width},
                                  {"height", c.height},
                                  {"K", {{c.fx, c.skew, c.cx}, {0, c.fy, c.cy}, {0, 0, 1}}},
                                  {"R", r},
                                  {"t", {c.translation.x, c.translation.y, c.translation.z}},
                                  {"video", "videos/" + name + ".mkv"},
                                  {"mask_video", "videos/" + name + "_mask.mkv"}});
  }
  std::ofstream(src / "capture.json") << capture.dump(2);

  const fs::path dataset_dir = out / "dataset";
  pid_t p = spawn({kBin + "/holofuse_dataset", "import", src.string(), "--format", "holofuse",
                   "--out", dataset_dir.string()},
                  out / "import.log");
  ASSERT_EQ(waitExit(p, 120), 0) << readFile(out / "import.log");
  const std::string log = readFile(out / "import.log");
  EXPECT_NE(log.find("imported 4 camera(s) x 4 frame(s)"), std::string::npos) << log;
  EXPECT_NE(log.find("frames matched by the videos' timestamps"), std::string::npos) << log;
  EXPECT_NE(log.find("masks 16 from the source"), std::string::npos) << log;
  auto dataset = dataset::Dataset::open(dataset_dir.string());
  ASSERT_TRUE(dataset.isOk()) << dataset.status().toString();
  ASSERT_TRUE(dataset->metadata().has_value());
  EXPECT_FALSE(dataset->metadata()->still);
  EXPECT_EQ(dataset->frameIds(), 4u);

  const fs::path replay = out / "replay";
  p = spawn({kBin + "/holofuse_loop", "--replay", dataset_dir.string(), "--speed", "max", "--out",
             replay.string(), "--record", (replay / "record").string(), "--record-fused"},
            out / "replay.log");
  ASSERT_EQ(waitExit(p, 240), 0) << readFile(out / "replay.log");
  const auto meshes = fusedMeshes(replay / "record" / "fused.hfr");
  ASSERT_EQ(meshes.size(), 4u) << "every frame of the videos fused";
  std::set<protocol::Bytes> distinct;
  for (const auto& [id, bytes] : meshes) distinct.insert(bytes);
  EXPECT_EQ(distinct.size(), 4u) << "the subject moves: each frame its own hull";
  EXPECT_GT(readJson(replay / "report.json")["frames_rendered"].get<int>(), 0);
  fs::remove_all(out);
}

// A real capture the team develops against, in $HOLOFUSE_DATASETS or
// ../shared/datasets (not in the repository: the tests skip without it).
fs::path realCapture(const std::string& name) {
  const char* env = std::getenv("HOLOFUSE_DATASETS");
  return fs::path(env != nullptr ? env : HOLOFUSE_SHARED_DATASETS) / name;
}

#define HOLOFUSE_SKIP_WITHOUT(src, marker)       \
  if (!fs::exists((src) / (marker)))             \
  GTEST_SKIP() << "no real capture at " << (src) \
               << " (../shared/datasets is not part of the repository)"

TEST(RealCapture, TheMiddleburyTempleImportsReplaysAndEvaluates) {
  const fs::path src = realCapture("middlebury-temple-colmap");
  HOLOFUSE_SKIP_WITHOUT(src, "sparse/cameras.txt");
  const fs::path out = freshDir("temple");
  const fs::path dataset_dir = out / "temple";
  pid_t p = spawn({kBin + "/holofuse_dataset", "import", src.string(), "--format", "colmap",
                   "--out", dataset_dir.string()},
                  out / "import.log");
  ASSERT_EQ(waitExit(p, 120), 0) << readFile(out / "import.log");
  EXPECT_NE(readFile(out / "import.log").find("imported 16 camera(s) x 1 frame(s)"),
            std::string::npos)
      << readFile(out / "import.log");
  auto dataset = dataset::Dataset::open(dataset_dir.string());
  ASSERT_TRUE(dataset.isOk());
  ASSERT_TRUE(dataset->metadata().has_value());
  // The capture volume holds the benchmark's tight bounding box (its
  // ORIGINAL_README), and is not much larger.
  const glm::dvec3 tight_min(-0.073568, 0.021728, -0.012445),
      tight_max(0.028855, 0.181892, 0.062736);
  const auto& m = *dataset->metadata();
  for (int k = 0; k < 3; ++k) {
    EXPECT_LE(m.volume_min[k], tight_min[k]) << "axis " << k;
    EXPECT_GE(m.volume_max[k], tight_max[k]) << "axis " << k;
    EXPECT_LT(m.volume_max[k] - m.volume_min[k], 1.5 * (tight_max[k] - tight_min[k]))
        << "axis " << k;
  }

  // The hull from the segmented masks projects back onto each mask.
  p = spawn({kBin + "/holofuse_dataset", "info", dataset_dir.string()}, out / "info.log");
  ASSERT_EQ(waitExit(p, 120), 0) << readFile(out / "info.log");
  std::istringstream info(readFile(out / "info.log"));
  int rows = 0;
  for (std::string line; std::getline(info, line);) {
    std::istringstream fields(line);
    std::string id, size, frames, mb, unit;
    double iou = 0;
    if (!(fields >> id >> size >> frames >> mb >> unit >> iou) || unit != "MB") continue;
    ++rows;
    EXPECT_GE(iou, 0.9) << line;
  }
  EXPECT_EQ(rows, 16) << readFile(out / "info.log");
  EXPECT_TRUE(fs::exists(dataset_dir / "contact_sheet.png"));

  // A still replays as a loop the client orbits.
  p = spawn({kBin + "/holofuse_loop", "--replay", dataset_dir.string(), "--frames", "3", "--out",
             (out / "replay").string()},
            out / "replay.log");
  ASSERT_EQ(waitExit(p, 240), 0) << readFile(out / "replay.log");
  EXPECT_EQ(readJson(out / "replay" / "report.json")["frames_rendered"].get<int>(), 3);

  // Leave-one-camera-out on the real images.
  p = spawn({kBin + "/holofuse_eval", "--dataset", dataset_dir.string(), "--held-out", "2",
             "--modes", "normal,montage4d", "--out", (out / "eval").string()},
            out / "eval.log");
  ASSERT_EQ(waitExit(p, 240), 0) << readFile(out / "eval.log");
  const auto quality = readJson(out / "eval" / "quality.json");
  const auto& scene = quality["scenes"]["dataset:temple"];
  for (const char* mode : {"normal", "montage4d"}) {
    EXPECT_GT(scene["modes"][mode]["psnr_db"].get<double>(), 12.0)
        << mode;  // measured 14.4-15.3 dB
    EXPECT_GT(scene["modes"][mode]["images"].get<int>(), 0) << mode;
  }
  EXPECT_TRUE(scene["hull"]["chamfer_mm"].is_null());
  fs::remove_all(out);
}

// The ETH statue comes as one 3x4 projection matrix per image: each is
// decomposed into K, R and t, and the hull carved from the segmented
// masks agrees with every camera's own mask; all 18 cameras evaluate in
// every mode and replay.
TEST(RealCapture, TheEthStatueImportsFromItsProjectionMatrices) {
  const fs::path src = realCapture("eth-david-statue-projections");
  HOLOFUSE_SKIP_WITHOUT(src, "david_00.pa");
  const fs::path out = freshDir("statue");
  const fs::path dataset_dir = out / "statue";
  pid_t p = spawn({kBin + "/holofuse_dataset", "import", src.string(), "--format", "projections",
                   "--out", dataset_dir.string()},
                  out / "import.log");
  ASSERT_EQ(waitExit(p, 120), 0) << readFile(out / "import.log");
  const std::string log = readFile(out / "import.log");
  EXPECT_NE(log.find("imported 18 camera(s) x 1 frame(s)"), std::string::npos) << log;
  EXPECT_EQ(log.find("CHECK"), std::string::npos) << log;
  // Each camera's row of the health table: id, name, coverage, IoU with
  // the hull of the others (measured 0.936-0.970).
  std::istringstream lines(log);
  int rows = 0;
  for (std::string line; std::getline(lines, line);) {
    std::istringstream fields(line);
    std::string id, name, covers;
    double iou = 0;
    if (!(fields >> id >> name >> covers >> iou) || name.rfind("david_", 0) != 0) continue;
    ++rows;
    EXPECT_GE(iou, 0.9) << line;
  }
  EXPECT_EQ(rows, 18) << log;

  // Leave-one-camera-out in every mode (measured 13.0-14.1 dB).
  p = spawn(
      {kBin + "/holofuse_eval", "--dataset", dataset_dir.string(), "--held-out", "2", "--modes",
       "normal,holoportation,montage4d,fragment", "--out", (out / "eval").string()},
      out / "eval.log");
  ASSERT_EQ(waitExit(p, 240), 0) << readFile(out / "eval.log");
  const auto quality = readJson(out / "eval" / "quality.json");
  for (const char* mode : {"normal", "holoportation", "montage4d", "fragment"}) {
    const auto& m = quality["scenes"]["dataset:statue"]["modes"][mode];
    EXPECT_GT(m["psnr_db"].get<double>(), 11.0) << mode;
    EXPECT_EQ(m["images"].get<int>(), 2) << mode;
  }
  p = spawn({kBin + "/holofuse_loop", "--replay", dataset_dir.string(), "--frames", "2", "--out",
             (out / "replay").string()},
            out / "replay.log");
  ASSERT_EQ(waitExit(p, 240), 0) << readFile(out / "replay.log");
  EXPECT_EQ(readJson(out / "replay" / "report.json")["frames_rendered"].get<int>(), 2);
  fs::remove_all(out);
}

}  // namespace
}  // namespace holofuse

// The whole loop with real processes on loopback: pods, server and client
// started as executables, checked against the synthetic truth.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <thread>

#include "capture_node/synthetic_scene.h"

namespace {

namespace fs = std::filesystem;
const std::string kBin = HOLOFUSE_BIN_DIR;

pid_t spawn(const std::vector<std::string>& args, const fs::path& log) {
  const pid_t pid = fork();
  if (pid != 0) return pid;
  std::FILE* f = std::fopen(log.c_str(), "w");
  if (f != nullptr) {
    dup2(fileno(f), STDOUT_FILENO);
    dup2(fileno(f), STDERR_FILENO);
  }
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  execv(argv[0], argv.data());
  _exit(127);
}

int waitExit(pid_t pid, int timeout_s) {
  int status = 0;
  for (int i = 0; i < timeout_s * 20; ++i) {
    if (waitpid(pid, &status, WNOHANG) == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  kill(pid, SIGKILL);
  waitpid(pid, &status, 0);
  return -1;
}

fs::path freshDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("holofuse_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

nlohmann::json readJson(const fs::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

TEST(Loop, FourPodsServerAndClientRenderTheSubjectWhereTheTruthIs) {
  const fs::path out = freshDir("loop");
  const double fps = 4.0;
  const pid_t loop = spawn({kBin + "/holofuse_loop", "--pods", "4", "--frames", "6", "--fps", "4", "--size", "200x150",
                            "--view", "pod:0", "--out", out.string()},
                           out / "loop.log");
  ASSERT_EQ(waitExit(loop, 240), 0) << "see " << (out / "loop.log");
  const auto report = readJson(out / "report.json");
  ASSERT_EQ(report["frames_rendered"], 6);
  EXPECT_GT(report["fps"].get<double>(), 0.0);
  const auto& e2e = report["latency_ms"]["end_to_end"];
  EXPECT_GT(e2e["p50"].get<double>(), 0.0);
  EXPECT_LE(e2e["p50"].get<double>(), e2e["p95"].get<double>());
  EXPECT_LE(e2e["p95"].get<double>(), e2e["p99"].get<double>());
  for (const char* stage : {"pod_render", "segment", "feather", "pod_encode", "send", "sync_wait", "hull",
                            "mesh_encode", "image_encode", "fanout", "decode", "upload", "render", "write"}) {
    ASSERT_TRUE(report["latency_ms"]["stages"].contains(stage)) << stage;
    EXPECT_GT(report["latency_ms"]["stages"][stage]["samples"].get<int>(), 0) << stage;
    EXPECT_LE(report["latency_ms"]["stages"][stage]["p50"].get<double>(), e2e["p99"].get<double>()) << stage;
  }
  EXPECT_GT(report["bytes_per_frame"]["pod_link"].get<double>(), 1000.0);
  EXPECT_GT(report["bytes_per_frame"]["client_link"].get<double>(), 1000.0);

  // From pod 0's pose the rendered coverage must sit on the true silhouette.
  holofuse::capture::SceneOptions scene_options;
  scene_options.frames_per_second = fps;
  const holofuse::capture::SyntheticScene scene(scene_options);
  const auto camera = holofuse::capture::SyntheticScene::cameraRig(4, 200, 150)[0];
  // Frames the server had to fuse without a pod (a pod still starting, say)
  // carry fewer cameras; the truth check applies to complete ones, and most
  // frames must be complete.
  int checked = 0;
  for (const auto& frame : report["frames"]) {
    if (frame["cameras_present"] != 4) continue;
    const cv::Mat png = cv::imread((out / frame["file"].get<std::string>()).string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(png.empty()) << frame["file"];
    ASSERT_EQ(png.channels(), 4);
    const auto truth = scene.render(camera, frame["frame_id"].get<uint64_t>());
    size_t inter = 0, uni = 0;
    for (int y = 0; y < png.rows; ++y) {
      for (int x = 0; x < png.cols; ++x) {
        const bool rendered = png.at<cv::Vec4b>(y, x)[3] != 0;
        const bool real = *truth.mask.at(x, y) != 0;
        inter += rendered && real;
        uni += rendered || real;
      }
    }
    // The visual hull is a superset of the subject, so the overlap is high
    // but not perfect.
    EXPECT_GT(static_cast<double>(inter) / static_cast<double>(uni), 0.8) << frame["file"];
    ++checked;
  }
  EXPECT_GE(checked, 4);
}

TEST(Loop, KillingOnePodMidRunLeavesTheOthersRunning) {
  const fs::path out = freshDir("kill");
  const fs::path port_file = out / "port";
  const pid_t server = spawn({kBin + "/fusion_server", "--listen", "127.0.0.1:0", "--pods", "4", "--port-file",
                              port_file.string()},
                             out / "server.log");
  std::string port;
  for (int i = 0; i < 100 && port.empty(); ++i) {
    std::ifstream in(port_file);
    std::getline(in, port);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_FALSE(port.empty());
  const std::string endpoint = "127.0.0.1:" + port;
  std::vector<pid_t> pods;
  for (int i = 0; i < 4; ++i) {
    pods.push_back(spawn({kBin + "/capture_node", "--server", endpoint, "--pod-id", std::to_string(i), "--pods", "4",
                          "--size", "160x120", "--fps", "4"},
                         out / ("pod" + std::to_string(i) + ".log")));
  }
  const pid_t client = spawn({kBin + "/render_client", "--server", endpoint, "--out", out.string(), "--frames", "14",
                              "--size", "160x120"},
                             out / "client.log");
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  kill(pods[3], SIGKILL);
  waitpid(pods[3], nullptr, 0);
  const int client_exit = waitExit(client, 180);
  for (int i = 0; i < 3; ++i) {
    kill(pods[i], SIGTERM);
    EXPECT_EQ(waitExit(pods[i], 10), 0) << "pod " << i << " must stop cleanly on SIGTERM";
  }
  kill(server, SIGTERM);
  EXPECT_EQ(waitExit(server, 10), 0);
  ASSERT_EQ(client_exit, 0) << "see " << (out / "client.log");
  const auto report = readJson(out / "report.json");
  ASSERT_EQ(report["frames_rendered"], 14);
  const auto& frames = report["frames"];
  EXPECT_EQ(frames.back()["cameras_present"], 3) << "the last frames come from the three live pods";
  EXPECT_EQ(frames.back()["cameras_expected"], 4);
  std::ifstream log(out / "server.log");
  const std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("pod 3"), std::string::npos) << "the server names the pod it lost";
}

TEST(Loop, WrongFlagsPrintUsageAndFail) {
  const fs::path out = freshDir("flags");
  EXPECT_NE(waitExit(spawn({kBin + "/capture_node", "--server", "127.0.0.1:1", "--pod-id", "9", "--pods", "4"},
                           out / "a.log"), 10), 0);
  EXPECT_NE(waitExit(spawn({kBin + "/fusion_server", "--no-such-flag"}, out / "b.log"), 10), 0);
  EXPECT_NE(waitExit(spawn({kBin + "/render_client", "--server", "nonsense"}, out / "c.log"), 10), 0);
  std::ifstream log(out / "a.log");
  const std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("--pod-id"), std::string::npos);
}

}  // namespace

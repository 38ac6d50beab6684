// The render client against a scripted server on loopback that sends bad
// frames: each is logged and skipped, the previous picture is kept, and the
// client goes on to render the good frame that follows.
#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "capture_node/synthetic_scene.h"
#include "common/image_codec.h"
#include "common/marching_cubes.h"
#include "common/mesh_codec.h"
#include "protocol/clock.h"
#include "protocol/connection.h"
#include "protocol/messages.h"
#include "process_harness.h"

namespace {

namespace fs = std::filesystem;
using namespace holofuse;

// Waits for the next frame from the client, answering nothing.
protocol::Frame receive(protocol::Connection& c) {
  for (int i = 0; i < 200; ++i) {
    if (c.hasFrame()) return c.takeFrame();
    pollfd p{c.fd(), POLLIN, 0};
    ::poll(&p, 1, 50);
    (void)c.onReadable();
  }
  return {};
}

using holofuse::test::readFile;

// Sends everything queued, then waits until the client's log mentions what
// (the client renders only the newest mesh of a batch, so bad frames are
// sent one at a time).
bool sendAndWaitFor(protocol::Connection& c, const fs::path& log, const std::string& what) {
  c.drain(2000);
  for (int i = 0; i < 200; ++i) {
    if (readFile(log).find(what) != std::string::npos) return true;
    (void)c.onReadable();
    while (c.hasFrame()) c.takeFrame();
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return false;
}

protocol::SharedFrame frameOf(protocol::OutgoingFrame f) {
  return std::make_shared<const protocol::OutgoingFrame>(std::move(f));
}

TEST(ClientInput, BadFramesAreSkippedAndTheNextGoodOneIsRendered) {
  const fs::path out = fs::temp_directory_path() / ("holofuse_client_input_" + std::to_string(getpid()));
  fs::remove_all(out);
  fs::create_directories(out);
  auto listener = protocol::listenTcp({"127.0.0.1", 0});
  ASSERT_TRUE(listener.isOk());
  const std::string endpoint = "127.0.0.1:" + std::to_string(listener->localPort());
  const pid_t client = fork();
  if (client == 0) {
    std::FILE* log = std::fopen((out / "client.log").c_str(), "w");
    dup2(fileno(log), STDOUT_FILENO);
    dup2(fileno(log), STDERR_FILENO);
    const std::string bin = std::string(HOLOFUSE_BIN_DIR) + "/render_client";
    execl(bin.c_str(), bin.c_str(), "--server", endpoint.c_str(), "--out", out.c_str(), "--frames", "1", "--size",
          "64x48", "--view", "pod:0", static_cast<char*>(nullptr));
    _exit(127);
  }
  pollfd p{listener->fd(), POLLIN, 0};
  ASSERT_EQ(::poll(&p, 1, 10000), 1);
  protocol::Connection c(listener->acceptOne(nullptr), "client");
  protocol::Hello hello;
  ASSERT_TRUE(protocol::decodeFrame(receive(c), hello).isOk());
  c.sendMessage(protocol::HelloAck{});
  const Camera camera = capture::SyntheticScene::cameraRig(1, 64, 48)[0];
  c.sendMessage(toCalibration(camera));
  const capture::SyntheticScene scene;
  const auto truth = scene.render(camera, 5);
  std::vector<uint8_t> color_bytes, mask_bytes;
  auto bundleFor = [&](uint64_t id, const Image8& color) {
    protocol::TextureBundle bundle;
    bundle.frame_id = id;
    protocol::BundleImage image;
    image.planes = {encodePlane(color, protocol::PlaneKind::kColor, protocol::Codec::kLz4, color_bytes),
                    encodePlane(truth.mask, protocol::PlaneKind::kMask, protocol::Codec::kLz4, mask_bytes)};
    bundle.images = {image};
    return frameOf(protocol::encodeOutgoing(bundle, protocol::nextSequence()));
  };
  auto meshFor = [&](uint64_t id, const std::vector<uint8_t>& draco) {
    protocol::MeshFrame mesh;
    mesh.frame_id = id;
    mesh.capture_time_ns = protocol::monotonicNs();
    mesh.mesh = draco;
    return frameOf(protocol::encodeOutgoing(mesh, protocol::nextSequence()));
  };
  // Frame 1: Draco bytes that are not a mesh.
  const std::vector<uint8_t> garbage(64, 0x5A);
  const fs::path log = out / "client.log";
  c.send(bundleFor(1, truth.color));
  c.send(meshFor(1, garbage));
  EXPECT_TRUE(sendAndWaitFor(c, log, "frame 1 skipped"));
  // Frame 2: images of the wrong size for the calibration.
  c.send(bundleFor(2, Image8(32, 24, 3, 100)));
  c.send(meshFor(2, garbage));
  EXPECT_TRUE(sendAndWaitFor(c, log, "frame 2 skipped"));
  // Frame 3: a mesh with vertices but no triangles.
  Mesh points;
  points.positions = {{0, 1, 0}, {0.1f, 1, 0}, {0, 1.1f, 0}};
  auto no_triangles = encodeDraco(points);
  if (no_triangles.isOk()) {
    c.send(bundleFor(3, truth.color));
    c.send(meshFor(3, *no_triangles));
    EXPECT_TRUE(sendAndWaitFor(c, log, "frame 3 skipped"));
  }
  // Frame 4: good.
  const Mesh good = scene.truthMesh(5, 0.03);
  auto draco = encodeDraco(good);
  ASSERT_TRUE(draco.isOk());
  c.send(bundleFor(4, truth.color));
  c.send(meshFor(4, *draco));
  c.drain(2000);
  int status = 0;
  for (int i = 0; i < 600 && waitpid(client, &status, WNOHANG) != client; ++i) {
    (void)c.onReadable();
    while (c.hasFrame()) c.takeFrame();
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "client did not finish; see " << out / "client.log";
  std::ifstream in(out / "report.json");
  const auto report = nlohmann::json::parse(in);
  EXPECT_EQ(report["frames_rendered"], 1);
  EXPECT_EQ(report["frames"][0]["frame_id"], 4);
  const std::string skipped = report["frames_skipped"].dump();
  EXPECT_NE(skipped.find("frame 1: draco mesh"), std::string::npos) << skipped;
  EXPECT_NE(skipped.find("frame 2: camera 0 images are not 64x48"), std::string::npos) << skipped;
  if (no_triangles.isOk()) {
    EXPECT_NE(skipped.find("frame 3: mesh with no triangles"), std::string::npos) << skipped;
  }
  // No picture was written for the bad frames.
  EXPECT_TRUE(fs::exists(out / "frames" / "frame_000000.png"));
  EXPECT_FALSE(fs::exists(out / "frames" / "frame_000001.png"));
}

}  // namespace

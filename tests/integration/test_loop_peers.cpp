// The loop's peers coming, going and misbehaving, with real processes on
// loopback: a pod killed mid-run, clients of every protocol minor, a pod
// whose mask disagrees with the hull, a pod that starts before its
// server, hostile and silent connections.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/uio.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>

#include "codec/image_codec.h"
#include "codec/mesh_codec.h"
#include "geometry/camera.h"
#include "loop_test.h"
#include "protocol/auth.h"
#include "protocol/frame.h"
#include "protocol/messages.h"
#include "protocol/server_link.h"
#include "protocol/socket.h"
#include "scene/synthetic_scene.h"

namespace {

using namespace holofuse::test;

TEST(Loop, KillingOnePodMidRunLeavesTheOthersRunning) {
  const fs::path out = freshDir("kill");
  pid_t server = 0;
  const std::string endpoint = startServer(out, 4, &server);
  ASSERT_FALSE(endpoint.empty()) << "the server did not report its port";
  std::vector<pid_t> pods;
  for (int i = 0; i < 4; ++i) {
    pods.push_back(spawn({kBin + "/capture_node", "--server", endpoint, "--pod-id",
                          std::to_string(i), "--pods", "4", "--size", "160x120", "--fps", "4"},
                         out / ("pod" + std::to_string(i) + ".log")));
  }
  const pid_t client = spawn({kBin + "/render_client", "--server", endpoint, "--out", out.string(),
                              "--frames", "14", "--size", "160x120"},
                             out / "client.log");
  // Pod 3 dies once the rig is rendering and its frames are in, whatever
  // the machine's speed (a loaded one may start it last).
  ASSERT_TRUE(holofuse::test::waitFor([&] {
    return holofuse::test::picturesIn(out) >= 2 &&
           holofuse::test::logSays(out / "server.log", "pod 3's first frame is in");
  })) << readFile(out / "client.log")
      << readFile(out / "server.log");
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
  // The server counts every frame each pod sent, not only those behind
  // rendered meshes: the dead pod's count stops, the others' go on.
  EXPECT_EQ(report["jitter_source"], "server, over every pod frame received");
  const auto& received = report["pod_frames_at_server"];
  ASSERT_EQ(received.size(), 4u) << report.dump();
  // The live pods went on for frames after pod 3 stopped. (Not "at least
  // the 14 rendered": on a loaded machine a group may be fused without a
  // late pod, and one run counted pod 0 at 13.)
  for (const char* live : {"pod_0", "pod_1", "pod_2"})
    EXPECT_GE(received[live].get<int>(), received["pod_3"].get<int>() + 3) << live;
  for (const auto& [pod, ms] : report["jitter_ms"].items()) EXPECT_GE(ms.get<double>(), 0.0) << pod;
  std::ifstream log(out / "server.log");
  const std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("pod 3"), std::string::npos) << "the server names the pod it lost";
}

// Protocol 1.1 appends each pod's arrivals to Stats, 1.2 each pod's
// feather map to the TextureBundle's images. The server sends each client
// the minor it agreed on: a 1.0 client the 1.0 Stats under a 1.0 header,
// 1.0 and 1.1 clients the bundle without feather maps, a 1.2 client both.
// Minors before 1.4 have no authentication: only a server started with
// --no-auth (loopback only) serves them. The server sends meshes as half
// floats through LZ4 (1.7): clients of 1.7 get those, every older one the
// same meshes in Draco.
TEST(Loop, EachClientGetsStatsAndImagesInTheMinorItAgreedOn) {
  const fs::path out = freshDir("minor");
  pid_t server = 0;
  const std::string endpoint =
      startServer(out, 1, &server, {"--no-auth", "--mesh-codec", "fp16-lz4"});
  auto parsed = holofuse::protocol::parseEndpoint(endpoint);
  ASSERT_TRUE(parsed.isOk()) << "the server did not report its port";
  const pid_t pod = spawn({kBin + "/capture_node", "--server", endpoint, "--pod-id", "0", "--pods",
                           "1", "--size", "96x72", "--fps", "10", "--no-auth"},
                          out / "pod.log");
  struct Client {
    uint8_t max_minor;
    std::unique_ptr<holofuse::protocol::ServerLink> link;
    std::vector<std::pair<uint8_t, holofuse::protocol::Stats>> stats;  // header minor, message
    // header minor, and the plane kinds of the bundle's one image
    std::vector<std::pair<uint8_t, std::vector<holofuse::protocol::PlaneKind>>> bundles;
    // frame id -> the mesh's codec and its vertices once decoded
    std::map<uint64_t, std::pair<holofuse::protocol::MeshCodec, size_t>> meshes;
  };
  static_assert(holofuse::protocol::kVersionMinor == 13, "a client of each minor");
  std::vector<Client> clients(14);
  for (uint8_t minor = 0; minor < 14; ++minor) clients[minor].max_minor = minor;
  for (Client& c : clients) {
    holofuse::protocol::Hello hello;
    hello.role = holofuse::protocol::Role::kClient;
    hello.id = c.max_minor;
    hello.max_minor = c.max_minor;
    c.link = std::make_unique<holofuse::protocol::ServerLink>(*parsed, hello,
                                                              holofuse::protocol::LinkOptions{});
  }
  auto enough = [&] {
    return std::all_of(clients.begin(), clients.end(), [](const Client& c) {
      return c.stats.size() >= 5 && c.bundles.size() >= 5 && c.meshes.size() >= 5;
    });
  };
  std::vector<holofuse::protocol::Frame> received;
  for (int round = 0; round < 900 && !enough(); ++round) {
    for (Client& c : clients) {
      received.clear();
      c.link->poll(10, received);
      for (const auto& frame : received) {
        holofuse::protocol::Stats stats;
        holofuse::protocol::TextureBundle bundle;
        holofuse::protocol::MeshFrame mesh;
        if (frame.header.type ==
                static_cast<uint16_t>(holofuse::protocol::MessageType::kMeshFrame) &&
            holofuse::protocol::decodeFrame(frame, mesh).isOk()) {
          auto decoded = holofuse::decodeMesh(mesh.codec, mesh.mesh.data(), mesh.mesh.size());
          c.meshes[mesh.frame_id] = {mesh.codec, decoded.isOk() ? decoded->vertexCount() : 0};
        } else if (frame.header.type ==
                       static_cast<uint16_t>(holofuse::protocol::MessageType::kStats) &&
                   holofuse::protocol::decodeFrame(frame, stats).isOk()) {
          c.stats.emplace_back(frame.header.minor, stats);
        } else if (frame.header.type ==
                       static_cast<uint16_t>(holofuse::protocol::MessageType::kTextureBundle) &&
                   holofuse::protocol::decodeFrame(frame, bundle).isOk() &&
                   bundle.images.size() == 1) {
          std::vector<holofuse::protocol::PlaneKind> kinds;
          for (const auto& plane : bundle.images[0].planes) kinds.push_back(plane.kind);
          c.bundles.emplace_back(frame.header.minor, kinds);
        }
      }
    }
  }
  kill(pod, SIGTERM);
  waitExit(pod, 10);
  kill(server, SIGTERM);
  EXPECT_EQ(waitExit(server, 10), 0);
  ASSERT_TRUE(enough()) << readFile(out / "server.log");
  for (const auto& [minor, stats] : clients[0].stats) {
    EXPECT_EQ(minor, 0);
    EXPECT_FALSE(stats.pod_arrivals.has_value()) << "frame " << stats.frame_id;
  }
  for (size_t k = 1; k < clients.size(); ++k) {
    uint64_t last_count = 0;
    for (const auto& [minor, stats] : clients[k].stats) {
      // Stats changed in 1.1, 1.3 and 1.8: 1.1 and 1.2 peers get the 1.2
      // frame, 1.3 to 1.7 peers the 1.7 one, 1.8 peers the server's
      // (SPEC.md section 3), with the pod's clock.
      const uint8_t max = clients[k].max_minor;
      EXPECT_EQ(minor, max >= 8   ? holofuse::protocol::kVersionMinor
                       : max >= 3 ? 7
                                  : 2)
          << "client of 1." << int(max);
      EXPECT_EQ(stats.cameras_present_count.has_value(), clients[k].max_minor >= 3);
      if (stats.cameras_present_count) {
        EXPECT_EQ(*stats.cameras_present_count, 1u);
      }
      ASSERT_TRUE(stats.pod_arrivals.has_value()) << "frame " << stats.frame_id;
      ASSERT_EQ(stats.pod_arrivals->size(), 1u);
      const auto& arrivals = stats.pod_arrivals->front();
      EXPECT_EQ(arrivals.pod, 0);
      EXPECT_GE(arrivals.frames, last_count) << "a running count";
      EXPECT_LT(arrivals.jitter_us, 1000000u) << "under a second on loopback";
      // One host: the pod's clock is the server's, within the estimate's
      // uncertainty once measured (only 1.8 frames carry it).
      if (max < 8) {
        EXPECT_EQ(arrivals.clock_uncertainty_ns, 0u);
      }
      if (arrivals.clock_uncertainty_ns != 0) {
        EXPECT_LE(static_cast<uint64_t>(std::llabs(arrivals.clock_offset_ns)),
                  arrivals.clock_uncertainty_ns);
      }
      last_count = arrivals.frames;
    }
    EXPECT_GE(last_count, 5u);
  }
  // The 1.8 client's last Stats carry the pod's clock as measured.
  ASSERT_FALSE(clients[8].stats.empty());
  ASSERT_TRUE(clients[8].stats.back().second.pod_arrivals.has_value());
  ASSERT_FALSE(clients[8].stats.back().second.pod_arrivals->empty());
  EXPECT_NE(clients[8].stats.back().second.pod_arrivals->front().clock_uncertainty_ns, 0u);
  using holofuse::protocol::PlaneKind;
  const std::vector<PlaneKind> images = {PlaneKind::kColor, PlaneKind::kMask};
  const std::vector<PlaneKind> with_feather = {PlaneKind::kColor, PlaneKind::kMask,
                                               PlaneKind::kFeather};
  for (const Client& c : clients) {
    for (const auto& [minor, kinds] : c.bundles) {
      // 1.3 changed only how many images a bundle may hold: with one, 1.2
      // and 1.3 peers get the same frame, under the server's minor.
      EXPECT_EQ(minor, c.max_minor >= 2 ? holofuse::protocol::kVersionMinor : 1)
          << "client of 1." << int(c.max_minor);
      EXPECT_EQ(kinds, c.max_minor >= 2 ? with_feather : images)
          << "client of 1." << int(c.max_minor);
    }
  }
  // The same meshes in each client's codec: a frame two clients both got
  // has the same vertices (codecs keep the order and count).
  size_t shared = 0;
  for (const Client& c : clients) {
    for (const auto& [frame_id, mesh] : c.meshes) {
      EXPECT_EQ(mesh.first, c.max_minor >= 7 ? holofuse::protocol::MeshCodec::kFp16Lz4
                                             : holofuse::protocol::MeshCodec::kDraco)
          << "client of 1." << int(c.max_minor);
      EXPECT_GT(mesh.second, 0u) << "client of 1." << int(c.max_minor) << " frame " << frame_id;
      const auto newest = clients.back().meshes.find(frame_id);
      if (&c == &clients.back() || newest == clients.back().meshes.end()) continue;
      EXPECT_EQ(mesh.second, newest->second.second) << "frame " << frame_id;
      ++shared;
    }
  }
  EXPECT_GT(shared, 0u) << "no frame reached both a Draco and a fp16-lz4 client";
  const std::string log = readFile(out / "server.log");
  EXPECT_NE(log.find("meshes fp16-lz4"), std::string::npos) << log;
  for (const char* version :
       {"protocol 1.0", "protocol 1.1", "protocol 1.2", "protocol 1.3", "protocol 1.4",
        "protocol 1.5", "protocol 1.6", "protocol 1.7", "protocol 1.8", "protocol 1.9",
        "protocol 1.10", "protocol 1.11", "protocol 1.12", "protocol 1.13"}) {
    EXPECT_NE(log.find(version), std::string::npos) << version << "\n" << log;
  }
}

// Protocol 1.11 codes the layers' camera planes in Zstandard and Draco's
// vertex keys in half steps. Two layered clients of one server, of 1.10
// and 1.11: each gets its spelling of the same frames (LZ4 and Zstandard
// camera planes, the same colour planes; keys as halves and in half steps,
// fewer bytes), and both decode the same camera indices and the same keyed
// vertices.
TEST(Loop, ClientsBefore111GetLz4CameraPlanesAndKeyHalvesOfTheSameFrames) {
  namespace protocol = holofuse::protocol;
  const fs::path out = freshDir("camera_planes");
  pid_t server = 0;
  const std::string endpoint = startServer(out, 2, &server, {"--no-auth"});
  auto parsed = protocol::parseEndpoint(endpoint);
  ASSERT_TRUE(parsed.isOk()) << "the server did not report its port";
  std::vector<pid_t> pods;
  for (int i = 0; i < 2; ++i)
    pods.push_back(
        spawn({kBin + "/capture_node", "--server", endpoint, "--pod-id", std::to_string(i),
               "--pods", "2", "--size", "96x72", "--fps", "10", "--no-auth"},
              out / ("pod" + std::to_string(i) + ".log")));
  struct Client {
    uint8_t max_minor;
    std::unique_ptr<protocol::ServerLink> link;
    // frame id -> each layer's camera plane: its codec and decoded texels
    std::map<uint64_t, std::vector<std::pair<protocol::Codec, std::vector<uint8_t>>>> cameras;
    std::map<uint64_t, std::vector<size_t>> colour_bytes;  // frame id -> each layer's
    // frame id -> the mesh's bytes and its vertices by key
    std::map<uint64_t, std::pair<size_t, std::map<uint64_t, glm::vec3>>> meshes;
    std::map<uint64_t, bool> charts_face_surface_around;  // frame id -> as its bundle says
    std::string refused;
  };
  // A client of the current minor beside them: while they are connected,
  // every client's charts face their triangles' own normals, the one way a
  // client before 1.12 lays them out, and its bundles say so; and every
  // client's mesh comes as coordinates, as before 1.13.
  std::vector<Client> clients(3);
  clients[0].max_minor = 10;
  clients[1].max_minor = 11;
  clients[2].max_minor = protocol::kVersionMinor;
  for (Client& c : clients) {
    protocol::Hello hello;
    hello.role = protocol::Role::kClient;
    hello.id = c.max_minor;
    hello.max_minor = c.max_minor;
    hello.capabilities = protocol::kCapabilityLayers;
    c.link = std::make_unique<protocol::ServerLink>(*parsed, hello, protocol::LinkOptions{});
  }
  auto shared = [&] {
    size_t n = 0;
    for (const auto& [frame_id, planes] : clients[1].cameras)
      n += clients[0].cameras.count(frame_id) * clients[2].cameras.count(frame_id);
    return n;
  };
  std::vector<protocol::Frame> received;
  for (int round = 0; round < 1500 && shared() < 3; ++round) {
    for (Client& c : clients) {
      received.clear();
      c.link->poll(10, received);
      for (const auto& frame : received) {
        protocol::MeshFrame mesh;
        if (frame.header.type == static_cast<uint16_t>(protocol::MessageType::kMeshFrame) &&
            protocol::decodeFrame(frame, mesh).isOk()) {
          auto decoded = holofuse::decodeMesh(mesh.codec, mesh.mesh.data(), mesh.mesh.size());
          if (!decoded.isOk()) {
            c.refused = decoded.status().toString();
            continue;
          }
          auto& [bytes, vertices] = c.meshes[mesh.frame_id];
          bytes = mesh.mesh.size();
          EXPECT_EQ(decoded->vertex_keys.size(), decoded->vertexCount()) << "keyed";
          for (size_t v = 0; v < decoded->vertex_keys.size(); ++v)
            vertices[decoded->vertex_keys[v]] = decoded->positions[v];
          continue;
        }
        protocol::TextureBundle bundle;
        if (frame.header.type != static_cast<uint16_t>(protocol::MessageType::kTextureBundle) ||
            !protocol::decodeFrame(frame, bundle).isOk() || !bundle.layers)
          continue;
        c.charts_face_surface_around[bundle.frame_id] = bundle.layers->charts_face_surface_around;
        auto& layers = c.cameras[bundle.frame_id];
        for (const auto& planes : bundle.layers->layers) {
          for (const auto& plane : planes) {
            if (plane.kind == protocol::PlaneKind::kColor) {
              c.colour_bytes[bundle.frame_id].push_back(plane.data.size());
              continue;
            }
            auto decoded = holofuse::decodePlane(plane);
            if (!decoded.isOk()) c.refused = decoded.status().toString();
            layers.emplace_back(plane.codec,
                                decoded.isOk() ? decoded->pixels : std::vector<uint8_t>{});
          }
        }
      }
    }
  }
  for (pid_t pod : pods) {
    kill(pod, SIGTERM);
    waitExit(pod, 10);
  }
  kill(server, SIGTERM);
  EXPECT_EQ(waitExit(server, 10), 0);
  ASSERT_GE(shared(), 3u) << readFile(out / "server.log");
  for (const Client& c : clients) {
    EXPECT_EQ(c.refused, "") << "client of 1." << int(c.max_minor);
    const protocol::Codec expected =
        c.max_minor >= 11 ? protocol::Codec::kZstd : protocol::Codec::kLz4;
    for (const auto& [frame_id, layers] : c.cameras) {
      EXPECT_FALSE(layers.empty()) << "frame " << frame_id;
      for (const auto& [codec, texels] : layers)
        EXPECT_EQ(codec, expected) << "client of 1." << int(c.max_minor) << " frame " << frame_id;
    }
  }
  size_t texels_compared = 0;
  for (const auto& [frame_id, newer] : clients[1].cameras) {
    const auto older = clients[0].cameras.find(frame_id);
    if (older == clients[0].cameras.end()) continue;
    ASSERT_EQ(older->second.size(), newer.size()) << "frame " << frame_id;
    for (size_t l = 0; l < newer.size(); ++l) {
      EXPECT_EQ(older->second[l].second, newer[l].second) << "frame " << frame_id << " layer " << l;
      texels_compared += newer[l].second.size();
    }
    EXPECT_EQ(clients[0].colour_bytes[frame_id], clients[1].colour_bytes[frame_id])
        << "frame " << frame_id;
  }
  EXPECT_GT(texels_compared, 0u);
  size_t current_compared = 0;
  for (const auto& [frame_id, current] : clients[2].cameras) {
    EXPECT_FALSE(clients[2].charts_face_surface_around.at(frame_id)) << "frame " << frame_id;
    const auto older = clients[1].cameras.find(frame_id);
    if (older == clients[1].cameras.end()) continue;
    ++current_compared;
    EXPECT_EQ(older->second, current) << "frame " << frame_id << ": the same layers";
  }
  EXPECT_GT(current_compared, 0u);
  size_t meshes_compared = 0;
  for (const auto& [frame_id, newer] : clients[1].meshes) {
    const auto older = clients[0].meshes.find(frame_id);
    if (older == clients[0].meshes.end()) continue;
    ++meshes_compared;
    EXPECT_LT(newer.first, older->second.first) << "frame " << frame_id << ": keys in half steps";
    EXPECT_FALSE(newer.second.empty());
    EXPECT_EQ(newer.second, older->second.second) << "frame " << frame_id;
    // Nor its vertices' places along their edges (1.13): the current
    // client gets the 1.11 client's mesh, on which the layers were built.
    const auto current = clients[2].meshes.find(frame_id);
    if (current == clients[2].meshes.end()) continue;
    EXPECT_EQ(current->second.first, newer.first) << "frame " << frame_id;
    EXPECT_EQ(current->second.second, newer.second) << "frame " << frame_id;
  }
  EXPECT_GT(meshes_compared, 0u);
}

// The live report measures each pod's mask against the hull the client
// receives, about once a second: pod 2 of four films with a sensor so
// noisy that its mask is most of its picture (it carves nothing, so the
// hull is the others'); the report and the client's log name it, and only
// it, with the frames it was set apart in.
TEST(Loop, TheReportNamesThePodWhoseMaskDisagreesWithTheHull) {
  const fs::path out = freshDir("mask_health");
  pid_t server = 0;
  const std::string endpoint = startServer(out, 4, &server);
  ASSERT_FALSE(endpoint.empty()) << readFile(out / "server.log");
  std::vector<pid_t> pods;
  for (int id = 0; id < 4; ++id) {
    pods.push_back(holofuse::test::startSmallPod(
        kBin, endpoint, id, 4, out,
        id == 2 ? std::vector<std::string>{"--noise", "64"} : std::vector<std::string>{}));
  }
  const pid_t client = startSmallClient(endpoint, out, "client", 40, {"--view", "pod:0"});
  EXPECT_EQ(waitExit(client, 120), 0) << readFile(out / "client.log");
  for (pid_t pod : pods) kill(pod, SIGTERM);
  for (pid_t pod : pods) waitExit(pod, 30);
  kill(server, SIGTERM);
  waitExit(server, 30);
  const auto health = readJson(out / "client" / "report.json")["mask_health"];
  ASSERT_GE(health["frames_measured"].size(), 2u) << health.dump();
  ASSERT_EQ(health["cameras"].size(), 4u) << health.dump();
  for (const auto& camera : health["cameras"]) {
    if (camera["camera"] == 2) {
      EXPECT_LT(camera["iou_median"].get<double>(), 0.5) << camera.dump();
      EXPECT_FALSE(camera["frames_set_apart"].empty()) << camera.dump();
      EXPECT_NE(camera["concern"].get<std::string>(), "") << camera.dump();
    } else {
      EXPECT_GT(camera["iou_median"].get<double>(), 0.7) << camera.dump();
      EXPECT_EQ(camera["concern"].get<std::string>(), "") << camera.dump();
    }
  }
  EXPECT_NE(readFile(out / "client.log").find("CHECK pod 2's mask"), std::string::npos)
      << readFile(out / "client.log");
  fs::remove_all(out);
}

TEST(Loop, APodWithoutServerRetriesWithBackoffAndJoinsWhenItAppears) {
  const fs::path out = freshDir("backoff");
  const uint16_t port = freePort();
  ASSERT_NE(port, 0);
  const std::string endpoint = "127.0.0.1:" + std::to_string(port);
  const pid_t pod = spawn({kBin + "/capture_node", "--server", endpoint, "--pod-id", "0", "--pods",
                           "1", "--size", "64x48", "--fps", "5"},
                          out / "pod.log");
  // The server comes up after the pod's third retry, however long the
  // machine takes to get there.
  ASSERT_TRUE(holofuse::test::waitFor([&] {
    return holofuse::test::logSays(out / "pod.log", "retry 3 in 400 ms");
  })) << readFile(out / "pod.log");
  const pid_t server =
      spawn({kBin + "/fusion_server", "--listen", endpoint, "--pods", "1"}, out / "server.log");
  const bool joined = holofuse::test::waitFor(
      [&] { return holofuse::test::logSays(out / "pod.log", "connected to"); });
  kill(pod, SIGTERM);
  EXPECT_EQ(waitExit(pod, 10), 0);
  kill(server, SIGTERM);
  EXPECT_EQ(waitExit(server, 10), 0);
  const std::string log = readFile(out / "pod.log");
  EXPECT_TRUE(joined) << log;
  // Backoff doubles from 100 ms.
  EXPECT_NE(log.find("retry 1 in 100 ms"), std::string::npos) << log;
  EXPECT_NE(log.find("retry 2 in 200 ms"), std::string::npos) << log;
  EXPECT_NE(log.find("retry 3 in 400 ms"), std::string::npos) << log;
  EXPECT_NE(readFile(out / "server.log").find("said bye"), std::string::npos)
      << "SIGTERM closes with Bye";
}

TEST(Loop, HostileConnectionsAreClosedWhileTheOthersAreServed) {
  const fs::path out = freshDir("hostile");
  pid_t server = 0;
  // Two pods expected: the second slot is the crooked peer's (the real pod
  // goes on alone past the sync deadline).
  const std::string endpoint = startServer(out, 2, &server);
  ASSERT_TRUE(holofuse::protocol::parseEndpoint(endpoint).isOk())
      << "the server did not report its port";
  const pid_t pod = spawn({kBin + "/capture_node", "--server", endpoint, "--pod-id", "0", "--pods",
                           "1", "--size", "96x72", "--fps", "5"},
                          out / "pod.log");
  const pid_t client = spawn({kBin + "/render_client", "--server", endpoint, "--out", out.string(),
                              "--frames", "8", "--size", "96x72"},
                             out / "client.log");
  // The hostile peers come while the loop runs: once a picture is out.
  ASSERT_TRUE(holofuse::test::waitFor([&] { return holofuse::test::picturesIn(out) >= 1; }))
      << readFile(out / "client.log");
  auto parsed = holofuse::protocol::parseEndpoint(endpoint);
  ASSERT_TRUE(parsed.isOk());
  // One peer speaks HTTP, another announces a 4 GiB frame.
  auto garbage = holofuse::protocol::connectTcp(*parsed, 1000);
  ASSERT_TRUE(garbage.isOk());
  const std::string http = "GET / HTTP/1.1\r\n\r\n";
  iovec part{const_cast<char*>(http.data()), http.size()};
  garbage->writeVector(&part, 1);
  auto huge = holofuse::protocol::connectTcp(*parsed, 1000);
  ASSERT_TRUE(huge.isOk());
  uint8_t header[holofuse::protocol::kHeaderSize] = {'H', 'F', 'U', 'S', 1,    0,    5,    0,
                                                     1,   0,   0,   0,   0xFF, 0xFF, 0xFF, 0xFF};
  iovec hpart{header, sizeof(header)};
  huge->writeVector(&hpart, 1);
  // A third is pod 1, authenticated with the rig's key, and sends a
  // rectangle whose offset would wrap a 32-bit sum: refused before
  // anything is decompressed.
  holofuse::protocol::Hello hello;
  hello.role = holofuse::protocol::Role::kPod;
  hello.id = 1;
  hello.name = "crooked";
  auto key = holofuse::protocol::loadPeerKey(holofuse::test::testKeyFile(), hello.role, hello.id);
  ASSERT_TRUE(key.isOk()) << key.status().message();
  holofuse::protocol::LinkOptions link_options;
  link_options.key = *key;
  holofuse::protocol::ServerLink crooked(*parsed, hello, link_options);
  std::vector<holofuse::protocol::Frame> ignored;
  while (!crooked.ready() && !crooked.fatalError()) crooked.poll(50, ignored);
  ASSERT_TRUE(crooked.ready()) << crooked.fatalError()->message();
  {
    holofuse::Camera camera = holofuse::scene::SyntheticScene::cameraRig(1, 96, 72)[0];
    camera.id = 1;
    holofuse::protocol::PodFrame frame;
    frame.frame_id = 1;
    frame.camera_id = 1;
    frame.offset_x = 0xFFFFFFF0u;
    holofuse::Image8 tiny(96, 72, 3);
    std::vector<uint8_t> storage;
    frame.planes.push_back(holofuse::encodePlane(tiny, holofuse::protocol::PlaneKind::kColor,
                                                 holofuse::protocol::Codec::kRaw, storage));
    crooked.sendMessage(holofuse::toCalibration(camera));
    crooked.sendMessage(frame);
    // Until both have left (the server closes the link on the second).
    while (crooked.ready() && crooked.queuedFrames() > 0) crooked.poll(50, ignored);
  }
  ASSERT_EQ(waitExit(client, 120), 0) << readFile(out / "client.log");
  kill(pod, SIGTERM);
  waitExit(pod, 10);
  kill(server, SIGTERM);
  EXPECT_EQ(waitExit(server, 10), 0);
  EXPECT_EQ(readJson(out / "report.json")["frames_rendered"], 8);
  const std::string log = readFile(out / "server.log");
  EXPECT_NE(log.find("field 'magic' at offset 0"), std::string::npos) << log;
  EXPECT_NE(log.find("field 'payload_length' at offset 12"), std::string::npos) << log;
  EXPECT_NE(log.find("is 96x72 at (4294967280, 0), calibration says 96x72"), std::string::npos)
      << log;
}

TEST(Loop, ASilentPeerIsClosedAfterTheIdleTimeout) {
  const fs::path out = freshDir("idle");
  const uint16_t port = freePort();
  const std::string endpoint = "127.0.0.1:" + std::to_string(port);
  const pid_t server = spawn(
      {kBin + "/fusion_server", "--listen", endpoint, "--pods", "1", "--idle-timeout-ms", "800"},
      out / "server.log");
  ASSERT_TRUE(holofuse::test::waitFor(
      [&] { return holofuse::test::logSays(out / "server.log", "listening"); }, 30))
      << readFile(out / "server.log");
  auto silent = holofuse::protocol::connectTcp(*holofuse::protocol::parseEndpoint(endpoint), 1000);
  ASSERT_TRUE(silent.isOk()) << silent.status().toString();
  // The server closes its end: reading gives end of stream, once the idle
  // timeout has passed (an error before then would be another fault).
  uint8_t byte;
  holofuse::protocol::IoResult r;
  EXPECT_TRUE(holofuse::test::waitFor(
      [&] {
        r = silent->readSome(std::span<uint8_t>(&byte, 1));
        return !r.would_block;
      },
      30));
  kill(server, SIGTERM);
  EXPECT_EQ(waitExit(server, 10), 0);
  EXPECT_TRUE(r.closed) << "the silent peer was not closed";
  EXPECT_NE(readFile(out / "server.log").find("heard nothing for 800 ms"), std::string::npos);
}

}  // namespace

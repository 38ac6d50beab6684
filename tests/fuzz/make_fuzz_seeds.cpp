// Writes the seed corpus of every fuzz target (tests/fuzz/corpus/<target>/)
// from real encoders: frames as peers send them, LZ4 planes and Draco
// meshes as the pods and the server make them, a recording as the server
// writes it, and each capture format as the tools that make it lay it out.
// The committed corpus is this program's output, beside the inputs fuzzing
// found faults with (named regression-*), which it leaves in place:
//   build/bin/make_fuzz_seeds tests/fuzz/corpus
#include <array>
#include <cmath>
#include <deque>
#include <filesystem>
#include <fstream>
#include <glm/gtc/quaternion.hpp>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <sstream>

#include "codec/image_codec.h"
#include "codec/mesh_codec.h"
#include "codec/pod_frame_codec.h"
#include "dataset/metadata.h"
#include "dataset/record_file.h"
#include "fuzz_capture.h"
#include "fuzz_rig.h"
#include "geometry/marching_cubes.h"
#include "protocol/auth.h"
#include "segmentation/segmentation.h"

namespace holofuse::fuzz {
namespace {

namespace fs = std::filesystem;
using protocol::Bytes;

struct Seed {
  std::string name;
  Bytes bytes;
};
using Corpus = std::map<std::string, std::vector<Seed>>;

Bytes fromString(const std::string& s) { return Bytes(s.begin(), s.end()); }

Bytes withMinor(uint8_t minor, const Bytes& frame) {
  Bytes out{minor};
  out.insert(out.end(), frame.begin() + protocol::kHeaderSize, frame.end());
  return out;
}

// What camera i of the rig sees: a disc of colour stripes, its mask and
// feather map.
struct View {
  Image8 color, mask, feather;
};
View viewOf(int camera) {
  View v{Image8(kRigWidth, kRigHeight, 3), Image8(kRigWidth, kRigHeight, 1), {}};
  for (uint32_t y = 0; y < kRigHeight; ++y) {
    for (uint32_t x = 0; x < kRigWidth; ++x) {
      const double dx = x - 32.0 - 3 * camera, dy = y - 24.0;
      const bool inside = dx * dx + dy * dy < 15.0 * 15.0;
      v.mask.at(x, y)[0] = inside ? 255 : 0;
      uint8_t* c = v.color.at(x, y);
      c[0] = static_cast<uint8_t>(inside ? 40 * ((x / 4) % 5) : 12);
      c[1] = static_cast<uint8_t>(inside ? 200 - 3 * y : 12);
      c[2] = static_cast<uint8_t>(60 + 20 * camera);
    }
  }
  v.feather = featherMap(v.mask);
  return v;
}

protocol::OutgoingFrame podFrameOf(int camera, uint64_t frame_id, const PodEncoding& encoding) {
  static std::map<int, View> views;
  auto [it, made] = views.try_emplace(camera);
  if (made) it->second = viewOf(camera);
  PodPlanes planes;
  planes.frame_id = frame_id;
  planes.capture_time_ns = 1000000 * frame_id;
  planes.color = &it->second.color;
  planes.mask = &it->second.mask;
  planes.feather = &it->second.feather;
  std::vector<protocol::StageStamp> stamps;
  return encodePodFrame(planes, stamps, static_cast<uint32_t>(camera), encoding);
}

// The TextureBundle a server sends for the rig: each camera's foreground
// rectangle, colour in the given codec, mask and feather map in LZ4.
protocol::TextureBundle bundleOf(protocol::Codec codec, std::deque<Bytes>& storage) {
  protocol::TextureBundle bundle;
  bundle.frame_id = 7;
  bundle.stamps = {
      {static_cast<uint16_t>(protocol::Stage::kImageEncode), protocol::kSourceServer, 100, 200}};
  for (int camera = 0; camera < kRigCameras; ++camera) {
    const View v = viewOf(camera);
    const uint32_t x0 = 12, y0 = 6, w = 44, h = 36;
    auto crop = [&](const Image8& image) {
      Image8 out(w, h, image.channels);
      for (uint32_t y = 0; y < h; ++y)
        std::copy_n(image.at(x0, y0 + y), w * image.channels, out.at(0, y));
      return out;
    };
    protocol::BundleImage image;
    image.camera_id = static_cast<uint32_t>(camera);
    image.offset_x = x0;
    image.offset_y = y0;
    image.planes.push_back(
        encodePlane(crop(v.color), protocol::PlaneKind::kColor, codec, storage.emplace_back()));
    image.planes.push_back(encodePlane(crop(v.mask), protocol::PlaneKind::kMask,
                                       protocol::Codec::kLz4, storage.emplace_back()));
    image.planes.push_back(encodePlane(crop(v.feather), protocol::PlaneKind::kFeather,
                                       protocol::Codec::kLz4, storage.emplace_back()));
    bundle.images.push_back(std::move(image));
  }
  return bundle;
}

Mesh sphere() {
  const auto grid = sampleGrid({-0.5, -0.5, -0.5}, 0.1, 11, 11, 11,
                               [](const glm::dvec3& p) { return 0.35 - glm::length(p); });
  return marchingCubes(grid);
}

// edge_spacing above 0: the positions as places along the keys' edges on
// the sphere's grid (protocol 1.13).
Bytes dracoOf(const Mesh& mesh, int speed, std::array<uint64_t, 2> key_lattice = {0, 0},
              double edge_spacing = 0) {
  DracoOptions options;
  options.speed = speed;
  options.key_lattice = key_lattice;
  options.edge_origin = {-0.5, -0.5, -0.5};
  options.edge_spacing = edge_spacing;
  auto bytes = encodeDraco(mesh, options);
  if (!bytes.isOk()) {
    std::cerr << "make_fuzz_seeds: " << bytes.status().toString() << "\n";
    std::exit(1);
  }
  return *bytes;
}

void protocolSeeds(Corpus& corpus) {
  using namespace protocol;
  const auto rig = fuzzRig();
  Hello hello;
  hello.role = Role::kPod;
  hello.id = 1;
  hello.nonce = 0x0123456789abcdefull;
  hello.name = "pod-1";
  HelloAck ack;
  ack.session_id = 9;
  Auth auth;
  auth.step = AuthStep::kChallenge;
  for (size_t i = 0; i < auth.value.size(); ++i) auth.value[i] = static_cast<uint8_t>(i * 13);
  const Calibration calibration = toCalibration(rig.at(1));
  PodEncoding encoding;
  const Bytes pod_frame = podFrameOf(1, 3, encoding).flatten();
  MeshFrame mesh;
  mesh.frame_id = 3;
  mesh.vertex_count = 100;
  mesh.triangle_count = 196;
  mesh.bounds_max = {1, 2, 1};
  mesh.mesh = dracoOf(sphere(), 7);
  std::deque<Bytes> storage;
  const TextureBundle bundle = bundleOf(Codec::kLz4PlanarDelta, storage);
  Stats stats;
  stats.frame_id = 3;
  stats.cameras_expected = 4;
  stats.cameras_present = 0xF;
  stats.cameras_present_count = 4;
  stats.note = "all present";
  // Since 1.8 with each pod's clock against the server's (pod 3: not measured).
  stats.pod_arrivals = {{{0, 10, 100, 2500, 40000},
                         {1, 12, 90, -5'000'000'000, 120000},
                         {2, 11, 80, 0, 1},
                         {3, 13, 70, 0, 0}}};

  const std::vector<std::pair<std::string, Bytes>> frames = {
      {"hello", encodeFrame(hello, 1)},
      {"hello_ack", encodeFrame(ack, 2)},
      {"auth", encodeFrame(auth, 3)},
      {"calibration", encodeFrame(calibration, 4)},
      {"pod_frame", pod_frame},
      {"mesh_frame", encodeFrame(mesh, 6)},
      {"texture_bundle", encodeFrame(bundle, 7)},
      {"heartbeat", encodeFrame(Heartbeat{123}, 8)},
      {"stats", encodeFrame(stats, 9)},
      {"bye", encodeFrame(Bye{"stopping"}, 10)},
      {"error", encodeFrame(ErrorMessage{6, "plane 1 is 9x9"}, 11)},
      {"clock_probe",
       encodeFrame(ClockProbe{ProbeStep::kReply, 1'000'000, 5'001'000'000, 5'001'050'000}, 12)},
      {"frame_request", encodeFrame(FrameRequest{41, kCapabilityLayers}, 13)}};
  Bytes pod_session, client_session;
  for (const auto& [name, frame] : frames) {
    corpus["message_" + name].push_back(
        {"v1." + std::to_string(kVersionMinor), withMinor(kVersionMinor, frame)});
    Bytes& session = name == "mesh_frame" || name == "texture_bundle" || name == "stats"
                         ? client_session
                         : pod_session;
    session.insert(session.end(), frame.begin(), frame.end());
  }
  // The messages whose fields depend on the minor, at each older one.
  for (uint8_t minor = 0; minor < kVersionMinor; ++minor) {
    const std::string v = "v1." + std::to_string(minor);
    corpus["message_texture_bundle"].push_back(
        {v, withMinor(minor, encodeFrame(bundle, 7, 0, minor))});
    Stats old = stats;
    if (minor == 0) old.pod_arrivals.reset();
    corpus["message_stats"].push_back({v, withMinor(minor, encodeFrame(old, 9, 0, minor))});
  }
  corpus["stream"] = {{"pod_session", pod_session}, {"client_session", client_session}};

  // The payloads inside: a pod's frame as the server receives it, in each
  // colour codec, cropped and whole; a bundle as a client receives it.
  for (const auto& [codec, name] : {std::pair{Codec::kLz4PlanarDelta, "lz4_delta"},
                                    std::pair{Codec::kLz4, "lz4"}, std::pair{Codec::kRaw, "raw"}}) {
    for (int margin : {4, kFullFrame}) {
      PodEncoding e;
      e.color_codec = codec;
      e.crop_margin = margin;
      const Bytes frame = podFrameOf(0, 5, e).flatten();
      corpus["server_pod_frame"].push_back(
          {std::string(name) + (margin == kFullFrame ? "_whole" : "_cropped"),
           Bytes(frame.begin() + kHeaderSize, frame.end())});
    }
    std::deque<Bytes> bundle_storage;
    corpus["client_texture_bundle"].push_back(
        {name, withMinor(kVersionMinor, encodeFrame(bundleOf(codec, bundle_storage), 7))});
  }
  // The sphere's grid is 11 points a side; since 1.11 its keys in half
  // steps, since 1.13 its positions as places along their edges.
  corpus["draco_mesh"] = {{"edgebreaker", dracoOf(sphere(), 7)},
                          {"sequential", dracoOf(sphere(), 10)},
                          {"key_half_steps", dracoOf(sphere(), 7, {11, 11})},
                          {"edge_places", dracoOf(sphere(), 7, {11, 11}, 0.1)}};
  // Keyed with normals as the server sends it, then with an atlas's corner
  // coordinates and without normals.
  Mesh atlas = sphere();
  atlas.normals.clear();
  for (size_t c = 0; c < atlas.indices.size(); ++c)
    atlas.corner_uvs.emplace_back((c % 31) / 30.0f, (c % 17) / 16.0f);
  corpus["fp16_lz4_mesh"] = {{"keyed", *encodeFp16Lz4(sphere())},
                             {"atlas_without_normals", *encodeFp16Lz4(atlas)}};
}

// A recording as the server writes one: the dataset's description, each
// camera's calibration, two frames from each; and the same file cut short
// in its index, as a crash leaves one.
void containerSeeds(Corpus& corpus, const fs::path& scratch) {
  using namespace protocol;
  const fs::path file = scratch / "recording.hfr";
  fs::remove(file);
  auto writer = dataset::RecordWriter::create(file.string(), 1700000000000000000ull);
  if (!writer.isOk()) {
    std::cerr << "make_fuzz_seeds: " << writer.status().toString() << "\n";
    std::exit(1);
  }
  dataset::DatasetMetadata metadata;
  metadata.source = "recording";
  metadata.camera_names = {"cam0", "cam1"};
  metadata.volume_min = {-1, 0, -1};
  metadata.volume_max = {1, 2, 1};
  (void)writer->append(dataset::RecordKind::kDatasetInfo, dataset::kServerStream, 0, 0,
                       encodeDatasetMetadata(metadata));
  const auto rig = fuzzRig();
  for (uint32_t camera = 0; camera < 2; ++camera) {
    (void)writer->append(dataset::RecordKind::kCalibration, camera, 0, 0,
                         encodeOutgoing(toCalibration(rig.at(camera)), 1));
  }
  for (uint64_t frame = 1; frame <= 2; ++frame) {
    for (int camera = 0; camera < 2; ++camera) {
      (void)writer->append(dataset::RecordKind::kPodFrame, static_cast<uint32_t>(camera), frame,
                           frame * 100000000, podFrameOf(camera, frame, PodEncoding{}));
    }
  }
  if (!writer->close().isOk()) std::exit(1);
  std::ifstream in(file, std::ios::binary);
  const Bytes whole((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  fs::remove(file);
  corpus["dataset_container"] = {{"indexed", whole},
                                 {"crashed", Bytes(whole.begin(), whole.end() - 40)}};
}

// Each capture format's calibration files for the rig, in the order
// captureTargets() lists them.
std::map<std::string, std::vector<std::string>> captureFiles() {
  const auto rig = fuzzRig();
  std::map<std::string, std::vector<std::string>> files;
  auto rowsOf = [](const glm::dmat3& r) {
    nlohmann::json rows = nlohmann::json::array();
    for (int row = 0; row < 3; ++row) rows.push_back({r[0][row], r[1][row], r[2][row]});
    return rows;
  };
  std::ostringstream cameras_txt, images_txt, par, binary_cameras, binary_images;
  cameras_txt << std::setprecision(17) << "# CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n";
  images_txt << std::setprecision(17)
             << "# IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n";
  par << std::setprecision(17) << kRigCameras << "\n";
  auto put = [](std::ostringstream& out, auto value) {
    out.write(reinterpret_cast<const char*>(&value), sizeof(value));
  };
  put(binary_cameras, uint64_t{kRigCameras});
  put(binary_images, uint64_t{kRigCameras});
  nlohmann::json holofuse, nerf, panoptic;
  holofuse["format"] = "holofuse-capture";
  holofuse["version"] = 1;
  nlohmann::json frame;
  nerf["w"] = kRigWidth;
  nerf["h"] = kRigHeight;
  cv::FileStorage intri(".yml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
  cv::FileStorage extri(".yml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
  intri << "names"
        << "[";
  for (const char* name : kCaptureNames) intri << name;
  intri << "]";
  std::vector<std::string> projections;
  for (const auto& [id, c] : rig) {
    const std::string name = kCaptureNames[id];
    const glm::dquat q = glm::quat_cast(c.rotation);
    cameras_txt << id + 1 << " PINHOLE " << c.width << " " << c.height << " " << c.fx << " " << c.fy
                << " " << c.cx << " " << c.cy << "\n";
    images_txt << id + 1 << " " << q.w << " " << q.x << " " << q.y << " " << q.z << " "
               << c.translation.x << " " << c.translation.y << " " << c.translation.z << " "
               << id + 1 << " " << name << ".png\n\n";
    put(binary_cameras, static_cast<int32_t>(id + 1));
    put(binary_cameras, int32_t{1});  // PINHOLE
    for (uint64_t side : {uint64_t{c.width}, uint64_t{c.height}}) put(binary_cameras, side);
    for (double v : {c.fx, c.fy, c.cx, c.cy}) put(binary_cameras, v);
    put(binary_images, static_cast<int32_t>(id + 1));
    for (double v : {q.w, q.x, q.y, q.z, c.translation.x, c.translation.y, c.translation.z})
      put(binary_images, v);
    put(binary_images, static_cast<int32_t>(id + 1));
    binary_images << name << ".png" << '\0';
    put(binary_images, uint64_t{0});  // no 2D points
    // Middlebury, Panoptic and the projections put the first pixel's
    // centre at 0; holofuse and COLMAP at 0.5.
    par << name << ".png " << c.fx << " 0 " << c.cx - 0.5 << " 0 " << c.fy << " " << c.cy - 0.5
        << " 0 0 1";
    for (int row = 0; row < 3; ++row)
      for (int col = 0; col < 3; ++col) par << " " << c.rotation[col][row];
    par << " " << c.translation.x << " " << c.translation.y << " " << c.translation.z << "\n";
    nlohmann::json cam;
    cam["name"] = name;
    cam["width"] = c.width;
    cam["height"] = c.height;
    cam["K"] = {{c.fx, 0, c.cx}, {0, c.fy, c.cy}, {0, 0, 1}};
    cam["R"] = rowsOf(c.rotation);
    cam["t"] = {c.translation.x, c.translation.y, c.translation.z};
    holofuse["cameras"].push_back(cam);
    frame["images"][name] = "images/" + name + ".png";
    const glm::dmat3 to_world = glm::transpose(c.rotation);
    const glm::dvec3 centre = c.center();
    nlohmann::json m = nlohmann::json::array();
    for (int row = 0; row < 3; ++row)
      m.push_back({to_world[0][row], -to_world[1][row], -to_world[2][row], centre[row]});
    m.push_back({0, 0, 0, 1});
    nerf["frames"].push_back({{"file_path", "images/" + name + ".png"},
                              {"fl_x", c.fx},
                              {"fl_y", c.fy},
                              {"cx", c.cx},
                              {"cy", c.cy},
                              {"transform_matrix", m}});
    nlohmann::json p;
    p["name"] = name;
    p["type"] = "hd";
    p["resolution"] = {c.width, c.height};
    p["K"] = {{c.fx, 0, c.cx - 0.5}, {0, c.fy, c.cy - 0.5}, {0, 0, 1}};
    p["distCoef"] = {0, 0, 0, 0, 0};
    p["R"] = rowsOf(c.rotation);
    p["t"] = {{c.translation.x}, {c.translation.y}, {c.translation.z}};
    panoptic["cameras"].push_back(p);
    const cv::Mat k = (cv::Mat_<double>(3, 3) << c.fx, 0, c.cx - 0.5, 0, c.fy, c.cy - 0.5, 0, 0, 1);
    cv::Mat r(3, 3, CV_64F), t(3, 1, CV_64F);
    for (int row = 0; row < 3; ++row) {
      for (int col = 0; col < 3; ++col) r.at<double>(row, col) = c.rotation[col][row];
      t.at<double>(row) = c.translation[row];
    }
    intri << "K_" + name << k;
    intri << "dist_" + name << cv::Mat::zeros(1, 5, CV_64F);
    extri << "Rot_" + name << r;
    extri << "T_" + name << t;
    cv::Mat rt;
    cv::hconcat(r, t, rt);
    const cv::Mat p34 = k * rt;
    std::ostringstream pa;
    pa << std::setprecision(17);
    for (int row = 0; row < 3; ++row)
      pa << p34.at<double>(row, 0) << " " << p34.at<double>(row, 1) << " " << p34.at<double>(row, 2)
         << " " << p34.at<double>(row, 3) << "\n";
    projections.push_back(pa.str());
  }
  holofuse["frames"].push_back(frame);
  files["import_holofuse"] = {holofuse.dump(1)};
  files["import_colmap_text"] = {cameras_txt.str(), images_txt.str()};
  files["import_colmap_binary"] = {binary_cameras.str(), binary_images.str()};
  files["import_nerf"] = {nerf.dump(1)};
  files["import_opencv"] = {intri.releaseAndGetString(), extri.releaseAndGetString()};
  files["import_projections"] = projections;
  files["import_middlebury"] = {par.str()};
  files["import_panoptic"] = {panoptic.dump(1)};
  return files;
}

void captureSeeds(Corpus& corpus) {
  for (const auto& [target, files] : captureFiles()) {
    corpus[target].push_back({"rig", fromString(joinFiles(files))});
  }
}

}  // namespace
}  // namespace holofuse::fuzz

int main(int argc, char** argv) {
  using namespace holofuse::fuzz;
  if (argc != 2) {
    std::cerr << "usage: make_fuzz_seeds CORPUS_DIR (the committed one: tests/fuzz/corpus)\n";
    return 2;
  }
  const fs::path out = argv[1];
  Corpus corpus;
  protocolSeeds(corpus);
  containerSeeds(corpus, fs::temp_directory_path());
  captureSeeds(corpus);
  for (const auto& [target, seeds] : corpus) {
    const fs::path dir = out / target;
    fs::create_directories(dir);  // other files there (findings kept as regressions) stay
    for (const Seed& seed : seeds) {
      std::ofstream(dir / seed.name, std::ios::binary)
          .write(reinterpret_cast<const char*>(seed.bytes.data()),
                 static_cast<std::streamsize>(seed.bytes.size()));
    }
    std::cout << target << ": " << seeds.size() << " seeds\n";
  }
  return 0;
}

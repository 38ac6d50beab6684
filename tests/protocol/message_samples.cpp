#include "message_samples.h"

#include <deque>

namespace holofuse::protocol::testing {
namespace {
const std::vector<uint8_t>& bytes(size_t n, uint8_t seed) {
  static std::deque<std::vector<uint8_t>> storage;  // deque: references stay valid
  std::vector<uint8_t> b(n);
  for (size_t i = 0; i < n; ++i) b[i] = static_cast<uint8_t>(seed + i * 7);
  storage.push_back(std::move(b));
  return storage.back();
}
const std::vector<uint8_t>& colorBytes() {
  static const std::vector<uint8_t>& b = bytes(4 * 3 * 3, 11);
  return b;
}
const std::vector<uint8_t>& maskBytes() {
  static const std::vector<uint8_t>& b = bytes(4 * 3, 200);
  return b;
}
const std::vector<uint8_t>& meshBytes() {
  static const std::vector<uint8_t>& b = bytes(37, 3);
  return b;
}
Plane plane(PlaneKind kind, PixelFormat format, const std::vector<uint8_t>& data) {
  Plane p;
  p.kind = kind;
  p.codec = Codec::kRaw;
  p.format = format;
  p.width = 4;
  p.height = 3;
  p.raw_size = static_cast<uint32_t>(data.size());
  p.data = data;
  return p;
}
}  // namespace

Hello sampleHello() {
  Hello m;
  m.role = Role::kPod;
  m.id = 3;
  m.capabilities = 0x5;
  m.nonce = 0x1122334455667788ull;
  m.send_time_ns = 123456789;
  m.name = "pod-3";
  return m;
}
HelloAck sampleHelloAck() {
  HelloAck m;
  m.session_id = 42;
  m.server_time_ns = 987654321;
  return m;
}
Calibration sampleCalibration() {
  Calibration m;
  m.camera_id = 2;
  m.width = 320;
  m.height = 240;
  m.fx = 350.5;
  m.fy = 351.25;
  m.cx = 160.0;
  m.cy = 120.5;
  m.skew = 0.25;
  m.distortion = {0.1, -0.05, 0.001, 0.002, 0.0};
  m.rotation = {1, 0, 0, 0, 0, -1, 0, 1, 0};
  m.translation = {0.1, 0.2, 2.5};
  return m;
}
PodFrame samplePodFrame() {
  PodFrame m;
  m.frame_id = 1000;
  m.camera_id = 2;
  m.capture_time_ns = 5000000;
  m.offset_x = 8;
  m.offset_y = 4;
  m.stamps = {{1, 2, 100, 200}, {2, 2, 200, 250}};
  m.planes = {plane(PlaneKind::kColor, PixelFormat::kRgb8, colorBytes()),
              plane(PlaneKind::kMask, PixelFormat::kGray8, maskBytes())};
  return m;
}
MeshFrame sampleMeshFrame() {
  MeshFrame m;
  m.frame_id = 1000;
  m.capture_time_ns = 5000000;
  m.bounds_min = {-0.5f, 0.0f, -0.25f};
  m.bounds_max = {0.5f, 1.75f, 0.25f};
  m.vertex_count = 8;
  m.triangle_count = 12;
  m.stamps = {{7, kSourceServer, 300, 400}};
  m.mesh = meshBytes();
  return m;
}
TextureBundle sampleTextureBundle(uint8_t minor) {
  TextureBundle m;
  m.frame_id = 1000;
  m.stamps = {{9, kSourceServer, 400, 450}};
  BundleImage image;
  image.camera_id = 2;
  image.planes = {plane(PlaneKind::kColor, PixelFormat::kRgb8, colorBytes())};
  // Since 1.2 the server sends each pod's feather map with its image.
  if (minor >= 2)
    image.planes.push_back(plane(PlaneKind::kFeather, PixelFormat::kGray8, maskBytes()));
  m.images = {image, image};
  m.images[1].camera_id = 3;
  return m;
}
TextureBundle sampleLayeredBundle() {
  TextureBundle m;
  m.frame_id = 1000;
  m.stamps = {{18, kSourceServer, 350, 390}, {9, kSourceServer, 400, 450}};
  BundleLayers layers;
  layers.texels = 64;
  layers.squares_per_side = 8;
  layers.square_texels = 8;
  layers.lattice = {40, 41, 42};
  layers.chart_cells = 4;
  layers.texel_metres = 0.0066;
  layers.square_count = 5;
  layers.slots = bytes(9, 91);
  layers.camera_ids = {0, 2, 3};
  for (int l = 0; l < 2; ++l) {
    layers.layers.push_back({plane(PlaneKind::kColor, PixelFormat::kRgb8, colorBytes()),
                             plane(PlaneKind::kCamera, PixelFormat::kGray8, maskBytes())});
  }
  m.layers = std::move(layers);
  return m;
}
TextureBundle sampleLayerVideoBundle() {
  TextureBundle m = sampleLayeredBundle();
  // The stream's header (sequence 7, a key frame) and a few bytes of
  // bitstream: the wire carries them as they are.
  static const std::vector<uint8_t> frame = {7, 0, 0, 0, 1, 0, 0, 0, 1, 0x65, 0x88, 0x84};
  for (auto& planes : m.layers->layers) {
    planes[0].codec = Codec::kH264;
    planes[0].data = frame;
  }
  return m;
}

TextureBundle sampleZstdCameraPlanesBundle() {
  TextureBundle m = sampleLayerVideoBundle();
  // Zstandard's magic number and a few bytes of frame: the wire carries
  // them as they are.
  static const std::vector<uint8_t> frame = {0x28, 0xb5, 0x2f, 0xfd, 0x20, 0x0c, 0x61, 0x00};
  for (auto& planes : m.layers->layers) {
    planes[1].codec = Codec::kZstd;
    planes[1].data = frame;
  }
  return m;
}

Stats sampleStats() {
  Stats m;
  m.frame_id = 1000;
  m.cameras_expected = 4;
  m.cameras_present = 0xB;
  m.late_frames = 2;
  m.dropped_groups = 1;
  m.pod_bytes = 65536;
  m.note = "proceeded without camera(s) 2";
  // Clock offsets since 1.8: pod 1 on a host 5 s ahead, pod 3 not measured.
  m.pod_arrivals = {
      {{0, 120, 1500, -42000, 31000}, {1, 119, 2250, 5'000'012'345, 84000}, {3, 118, 0, 0, 0}}};
  m.cameras_present_count = 3;
  return m;
}

std::vector<Sample> allSamples(uint8_t minor) {
  // A peer of that minor offers and agrees on it.
  Hello hello = sampleHello();
  hello.max_minor = minor;
  HelloAck ack = sampleHelloAck();
  ack.minor = minor;
  std::vector<Sample> samples = {
      {"hello", encodeFrame(hello, 1, 0, minor)},
      {"hello_ack", encodeFrame(ack, 2, 0, minor)},
      {"calibration", encodeFrame(sampleCalibration(), 3, 0, minor)},
      {"pod_frame", encodeFrame(samplePodFrame(), 4, 0, minor)},
      {"mesh_frame", encodeFrame(sampleMeshFrame(), 5, 0, minor)},
      {"texture_bundle", encodeFrame(sampleTextureBundle(minor), 6, 0, minor)},
      {"heartbeat", encodeFrame(Heartbeat{777}, 7, 0, minor)},
      {"stats", encodeFrame(sampleStats(), 8, 0, minor)},  // 1.0: without the arrivals
      {"bye", encodeFrame(Bye{"done"}, 9, 0, minor)},
      {"error", encodeFrame(ErrorMessage{3, "version 2.0 not supported"}, 10, 0, minor)}};
  if (minor >= 5)  // texture layers came with 1.5
    samples.push_back({"texture_bundle_layers", encodeFrame(sampleLayeredBundle(), 12, 0, minor)});
  if (minor >= 7) {  // meshes as half floats through LZ4 with 1.7
    MeshFrame fp16 = sampleMeshFrame();
    fp16.codec = MeshCodec::kFp16Lz4;
    samples.push_back({"mesh_frame_fp16_lz4", encodeFrame(fp16, 14, 0, minor)});
  }
  if (minor >= 6)  // the layers' video with 1.6
    samples.push_back(
        {"texture_bundle_layer_video", encodeFrame(sampleLayerVideoBundle(), 13, 0, minor)});
  if (minor >= 11)  // camera planes in Zstandard with 1.11
    samples.push_back({"texture_bundle_zstd_camera_planes",
                       encodeFrame(sampleZstdCameraPlanesBundle(), 18, 0, minor)});
  if (minor >= 12) {  // charts that say which way they face with 1.12
    TextureBundle own_normals = sampleLayeredBundle();
    own_normals.layers->charts_face_surface_around = false;
    samples.push_back({"texture_bundle_own_normal_charts", encodeFrame(own_normals, 19, 0, minor)});
  }
  if (minor >= 8) {  // clock probes came with 1.8
    ClockProbe request{ProbeStep::kRequest, 68'131'090'000'000, 0, 0};
    ClockProbe reply{ProbeStep::kReply, 68'131'090'000'000, 73'131'090'150'000, 73'131'090'190'000};
    samples.push_back({"clock_probe_request", encodeFrame(request, 15, 0, minor)});
    samples.push_back({"clock_probe_reply", encodeFrame(reply, 16, 0, minor)});
  }
  if (minor >= 9) {  // clients ask for frames since 1.9, and change their layers since 1.10
    FrameRequest request{73'131'090, std::nullopt};
    if (minor >= 10) request.layer_capabilities = kCapabilityLayers | kCapabilityLayerVideo;
    samples.push_back({"frame_request", encodeFrame(request, 17, 0, minor)});
  }
  if (minor >= 4) {  // Auth came with 1.4
    Auth auth;
    auth.step = AuthStep::kResponse;
    for (size_t i = 0; i < auth.value.size(); ++i) auth.value[i] = static_cast<uint8_t>(7 * i + 1);
    samples.push_back({"auth", encodeFrame(auth, 11, 0, minor)});
  }
  return samples;
}

}  // namespace holofuse::protocol::testing

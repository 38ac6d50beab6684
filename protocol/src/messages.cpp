#include "protocol/messages.h"

#include <algorithm>
#include <cmath>

namespace holofuse::protocol {
namespace {

void writeStamps(WireWriter& w, const std::vector<StageStamp>& stamps) {
  const size_t n = std::min(stamps.size(), kMaxStamps);
  w.u16(static_cast<uint16_t>(n));
  for (size_t i = 0; i < n; ++i) {
    w.u16(stamps[i].stage);
    w.u16(stamps[i].source);
    w.u64(stamps[i].start_ns);
    w.u64(stamps[i].end_ns);
  }
}

void readStamps(WireReader& r, std::vector<StageStamp>& stamps) {
  const uint16_t n = r.u16("stamps.count");
  if (n > kMaxStamps) {
    r.failValue("stamps.count", StatusCode::kTooLarge,
                std::to_string(n) + " above cap " + std::to_string(kMaxStamps));
    return;
  }
  // Each stamp is 20 bytes: check before reserving so a lying count cannot
  // make us allocate.
  if (!r.ok() || static_cast<size_t>(n) * 20 > r.remaining()) {
    r.raw("stamps", static_cast<size_t>(n) * 20);
    return;
  }
  stamps.resize(n);
  for (auto& s : stamps) {
    s.stage = r.u16("stamp.stage");
    s.source = r.u16("stamp.source");
    s.start_ns = r.u64("stamp.start");
    s.end_ns = r.u64("stamp.end");
  }
}

void writePlanes(WireWriter& w, const std::vector<Plane>& planes) {
  w.u8(static_cast<uint8_t>(planes.size()));
  for (const auto& p : planes) {
    w.u8(static_cast<uint8_t>(p.kind));
    w.u8(static_cast<uint8_t>(p.codec));
    w.u8(static_cast<uint8_t>(p.format));
    w.u32(p.width);
    w.u32(p.height);
    w.u32(p.raw_size);
    w.bytes32(p.data);
  }
}

// max_codec: the highest codec id the field may hold (video codecs only in
// a 1.6 bundle's layers, Zstandard only in a 1.11 bundle's).
void readPlanes(WireReader& r, std::vector<Plane>& planes,
                Codec max_codec = Codec::kLz4PlanarDelta) {
  const uint8_t n = r.u8("planes.count");
  if (n > kMaxPlanes) {
    r.failValue("planes.count", StatusCode::kTooLarge,
                std::to_string(n) + " above cap " + std::to_string(kMaxPlanes));
    return;
  }
  planes.resize(r.ok() ? n : 0);
  for (auto& p : planes) {
    const uint8_t kind = r.u8("plane.kind");
    const uint8_t codec = r.u8("plane.codec");
    const uint8_t format = r.u8("plane.format");
    p.width = r.u32("plane.width");
    p.height = r.u32("plane.height");
    p.raw_size = r.u32("plane.raw_size");
    if (!r.ok()) return;
    if (kind < 1 || kind > 5) {
      r.failValue("plane.kind", StatusCode::kMalformed, "unknown kind " + std::to_string(kind));
      return;
    }
    if (codec > static_cast<uint8_t>(max_codec)) {
      r.failValue("plane.codec", StatusCode::kMalformed, "unknown codec " + std::to_string(codec));
      return;
    }
    if (format < 1 || format > 3) {
      r.failValue("plane.format", StatusCode::kMalformed,
                  "unknown format " + std::to_string(format));
      return;
    }
    p.kind = static_cast<PlaneKind>(kind);
    p.codec = static_cast<Codec>(codec);
    p.format = static_cast<PixelFormat>(format);
    // Bound the sides before multiplying: width * height * 3 must not wrap.
    if (p.width == 0 || p.height == 0 || p.width > kMaxImageSide || p.height > kMaxImageSide) {
      r.failValue("plane.width", StatusCode::kMalformed,
                  std::to_string(p.width) + "x" + std::to_string(p.height) + " outside 1.." +
                      std::to_string(kMaxImageSide));
      return;
    }
    const uint64_t expected = static_cast<uint64_t>(p.width) * p.height * bytesPerPixel(p.format);
    if (expected != p.raw_size || p.raw_size > kMaxPlaneBytes) {
      r.failValue("plane.raw_size", StatusCode::kMalformed,
                  std::to_string(p.raw_size) + " does not match " + std::to_string(p.width) + "x" +
                      std::to_string(p.height) + " or is above the cap");
      return;
    }
    p.data = r.bytes32("plane.data", kMaxPlaneBytes);
    if (r.ok() && p.codec == Codec::kRaw && p.data.size() != p.raw_size) {
      r.failValue("plane.data", StatusCode::kMalformed, "raw plane size differs from raw_size");
      return;
    }
  }
}

Status finish(const WireReader& r) { return r.status(); }

}  // namespace

const std::vector<uint16_t>& stagesInPipelineOrder() {
  static const std::vector<uint16_t> order = [] {
    std::vector<uint16_t> ids;
    for (Stage s : {Stage::kPodRender, Stage::kSegment, Stage::kFeather, Stage::kPodEncode,
                    Stage::kReplayRead, Stage::kSend, Stage::kServerDecode, Stage::kSyncWait,
                    Stage::kHull, Stage::kRefine, Stage::kMeshEncode, Stage::kLayers,
                    Stage::kLayerVideo, Stage::kImageEncode, Stage::kFanout, Stage::kDecode,
                    Stage::kUpload, Stage::kRender, Stage::kWrite}) {
      ids.push_back(static_cast<uint16_t>(s));
    }
    return ids;
  }();
  return order;
}

std::string stageName(uint16_t stage) {
  static const char* const kNames[] = {
      "pod_render",  "segment",       "feather", "pod_encode", "send",       "sync_wait", "hull",
      "mesh_encode", "image_encode",  "fanout",  "decode",     "upload",     "render",    "write",
      "replay_read", "server_decode", "refine",  "layers",     "layer_video"};
  if (stage >= kFirstStage && stage <= kLastStage) return kNames[stage - kFirstStage];
  return "stage_" + std::to_string(stage);
}

double stampedMs(const std::vector<StageStamp>& stamps, Stage stage) {
  double ms = 0;
  for (const auto& stamp : stamps) {
    if (stamp.stage == static_cast<uint16_t>(stage) && stamp.end_ns >= stamp.start_ns) {
      ms += 1e-6 * static_cast<double>(stamp.end_ns - stamp.start_ns);
    }
  }
  return ms;
}

uint32_t bytesPerPixel(PixelFormat format) {
  switch (format) {
    case PixelFormat::kRgb8:
      return 3;
    case PixelFormat::kGray8:
      return 1;
    case PixelFormat::kR16:
      return 2;
  }
  return 0;
}

void writePayload(WireWriter& w, const Hello& m) {
  w.u8(static_cast<uint8_t>(m.role));
  w.u32(m.id);
  w.u8(m.min_major);
  w.u8(m.min_minor);
  w.u8(m.max_major);
  w.u8(m.max_minor);
  w.u64(m.capabilities);
  w.u64(m.nonce);
  w.u64(m.send_time_ns);
  w.str(m.name);
}

Status readPayload(std::span<const uint8_t> payload, Hello& m, size_t base_offset) {
  WireReader r(payload, base_offset);
  const uint8_t role = r.u8("hello.role");
  if (r.ok() && role != 1 && role != 2) {
    r.failValue("hello.role", StatusCode::kMalformed, "unknown role " + std::to_string(role));
  }
  m.role = static_cast<Role>(role);
  m.id = r.u32("hello.id");
  m.min_major = r.u8("hello.min_major");
  m.min_minor = r.u8("hello.min_minor");
  m.max_major = r.u8("hello.max_major");
  m.max_minor = r.u8("hello.max_minor");
  m.capabilities = r.u64("hello.capabilities");
  m.nonce = r.u64("hello.nonce");
  m.send_time_ns = r.u64("hello.send_time");
  m.name = r.str("hello.name");
  if (r.ok() &&
      (m.min_major > m.max_major || (m.min_major == m.max_major && m.min_minor > m.max_minor))) {
    r.failValue("hello.min_major", StatusCode::kMalformed, "version range is empty");
  }
  return finish(r);
}

void writePayload(WireWriter& w, const HelloAck& m) {
  w.u8(m.major);
  w.u8(m.minor);
  w.u32(m.session_id);
  w.u64(m.server_time_ns);
  w.u32(m.heartbeat_interval_ms);
  w.u32(m.idle_timeout_ms);
}

Status readPayload(std::span<const uint8_t> payload, HelloAck& m, size_t base_offset) {
  WireReader r(payload, base_offset);
  m.major = r.u8("hello_ack.major");
  m.minor = r.u8("hello_ack.minor");
  m.session_id = r.u32("hello_ack.session_id");
  m.server_time_ns = r.u64("hello_ack.server_time");
  m.heartbeat_interval_ms = r.u32("hello_ack.heartbeat_interval_ms");
  m.idle_timeout_ms = r.u32("hello_ack.idle_timeout_ms");
  return finish(r);
}

void writePayload(WireWriter& w, const Auth& m) {
  w.u8(static_cast<uint8_t>(m.step));
  w.raw(m.value);
}

Status readPayload(std::span<const uint8_t> payload, Auth& m, size_t base_offset) {
  WireReader r(payload, base_offset);
  const uint8_t step = r.u8("auth.step");
  if (r.ok() && (step < 1 || step > 3))
    r.failValue("auth.step", StatusCode::kMalformed, "unknown step " + std::to_string(step));
  m.step = static_cast<AuthStep>(step);
  const auto value = r.raw("auth.value", kAuthBytes);
  if (r.ok()) std::copy(value.begin(), value.end(), m.value.begin());
  return finish(r);
}

void writePayload(WireWriter& w, const Calibration& m) {
  w.u32(m.camera_id);
  w.u32(m.width);
  w.u32(m.height);
  for (double v : {m.fx, m.fy, m.cx, m.cy, m.skew}) w.f64(v);
  const size_t n = std::min(m.distortion.size(), kMaxDistortion);
  w.u8(static_cast<uint8_t>(n));
  for (size_t i = 0; i < n; ++i) w.f64(m.distortion[i]);
  for (double v : m.rotation) w.f64(v);
  for (double v : m.translation) w.f64(v);
}

Status readPayload(std::span<const uint8_t> payload, Calibration& m, size_t base_offset) {
  WireReader r(payload, base_offset);
  m.camera_id = r.u32("calibration.camera_id");
  m.width = r.u32("calibration.width");
  m.height = r.u32("calibration.height");
  m.fx = r.f64("calibration.fx");
  m.fy = r.f64("calibration.fy");
  m.cx = r.f64("calibration.cx");
  m.cy = r.f64("calibration.cy");
  m.skew = r.f64("calibration.skew");
  const uint8_t n = r.u8("calibration.distortion_count");
  if (n > kMaxDistortion) {
    r.failValue("calibration.distortion_count", StatusCode::kTooLarge,
                std::to_string(n) + " above cap " + std::to_string(kMaxDistortion));
  }
  m.distortion.assign(r.ok() ? n : 0, 0.0);
  for (auto& d : m.distortion) d = r.f64("calibration.distortion");
  for (auto& v : m.rotation) v = r.f64("calibration.rotation");
  for (auto& v : m.translation) v = r.f64("calibration.translation");
  if (r.ok()) {
    bool finite = std::isfinite(m.fx) && std::isfinite(m.fy) && std::isfinite(m.cx) &&
                  std::isfinite(m.cy) && std::isfinite(m.skew);
    for (double v : m.rotation) finite = finite && std::isfinite(v);
    for (double v : m.translation) finite = finite && std::isfinite(v);
    for (double v : m.distortion) finite = finite && std::isfinite(v);
    if (!finite) r.failValue("calibration", StatusCode::kMalformed, "non-finite value");
    if (r.ok() && (m.width == 0 || m.height == 0 || m.width > 16384 || m.height > 16384)) {
      r.failValue("calibration.width", StatusCode::kMalformed,
                  "image size " + std::to_string(m.width) + "x" + std::to_string(m.height) +
                      " outside 1..16384");
    }
    if (r.ok() && (m.fx <= 0 || m.fy <= 0)) {
      r.failValue("calibration.fx", StatusCode::kMalformed, "focal length must be positive");
    }
  }
  return finish(r);
}

void writePayload(WireWriter& w, const PodFrame& m) {
  w.u64(m.frame_id);
  w.u32(m.camera_id);
  w.u64(m.capture_time_ns);
  w.u32(m.offset_x);
  w.u32(m.offset_y);
  writeStamps(w, m.stamps);
  writePlanes(w, m.planes);
}

Status readPayload(std::span<const uint8_t> payload, PodFrame& m, size_t base_offset) {
  WireReader r(payload, base_offset);
  m.frame_id = r.u64("pod_frame.frame_id");
  m.camera_id = r.u32("pod_frame.camera_id");
  m.capture_time_ns = r.u64("pod_frame.capture_time");
  m.offset_x = r.u32("pod_frame.offset_x");
  m.offset_y = r.u32("pod_frame.offset_y");
  readStamps(r, m.stamps);
  readPlanes(r, m.planes);
  return finish(r);
}

void writePayload(WireWriter& w, const MeshFrame& m) {
  w.u64(m.frame_id);
  w.u64(m.capture_time_ns);
  for (float v : m.bounds_min) w.f32(v);
  for (float v : m.bounds_max) w.f32(v);
  w.u32(m.vertex_count);
  w.u32(m.triangle_count);
  w.u8(static_cast<uint8_t>(m.codec));
  writeStamps(w, m.stamps);
  w.bytes32(m.mesh);
}

Status readPayload(std::span<const uint8_t> payload, MeshFrame& m, size_t base_offset,
                   uint8_t minor) {
  WireReader r(payload, base_offset);
  m.frame_id = r.u64("mesh_frame.frame_id");
  m.capture_time_ns = r.u64("mesh_frame.capture_time");
  for (auto& v : m.bounds_min) v = r.f32("mesh_frame.bounds_min");
  for (auto& v : m.bounds_max) v = r.f32("mesh_frame.bounds_max");
  m.vertex_count = r.u32("mesh_frame.vertex_count");
  m.triangle_count = r.u32("mesh_frame.triangle_count");
  const uint8_t codec = r.u8("mesh_frame.codec");
  const uint8_t known = minor >= 7 ? 2 : 1;  // fp16-lz4 since 1.7
  if (r.ok() && (codec < 1 || codec > known)) {
    r.failValue("mesh_frame.codec", StatusCode::kMalformed,
                "unknown mesh codec " + std::to_string(codec) + " in a 1." + std::to_string(minor) +
                    " frame");
  }
  m.codec = static_cast<MeshCodec>(codec);
  readStamps(r, m.stamps);
  m.mesh = r.bytes32("mesh_frame.mesh", kMaxPlaneBytes);
  return finish(r);
}

void writePayload(WireWriter& w, const TextureBundle& m, uint8_t minor) {
  w.u64(m.frame_id);
  writeStamps(w, m.stamps);
  const size_t count = std::min(m.images.size(), maxCamerasIn(minor));
  w.u8(static_cast<uint8_t>(count));
  for (size_t k = 0; k < count; ++k) {
    const auto& image = m.images[k];
    w.u32(image.camera_id);
    w.u32(image.offset_x);
    w.u32(image.offset_y);
    writePlanes(w, image.planes);
  }
  if (minor < 5) return;
  const BundleLayers* layers = m.layers ? &*m.layers : nullptr;
  const size_t layer_count = layers ? std::min(layers->layers.size(), kMaxLayers) : 0;
  w.u8(static_cast<uint8_t>(layer_count));
  if (layer_count == 0) return;
  w.u32(layers->texels);
  w.u32(layers->squares_per_side);
  w.u32(layers->square_texels);
  for (const uint32_t side : layers->lattice) w.u32(side);
  w.u8(layers->chart_cells);
  if (minor >= 12) w.u8(layers->charts_face_surface_around ? 1 : 0);
  w.f64(layers->texel_metres);
  w.u32(layers->square_count);
  w.bytes32(layers->slots);
  const size_t cameras = std::min(layers->camera_ids.size(), size_t{kMaxCameras});
  w.u8(static_cast<uint8_t>(cameras));
  for (size_t k = 0; k < cameras; ++k) w.u32(layers->camera_ids[k]);
  for (size_t l = 0; l < layer_count; ++l) writePlanes(w, layers->layers[l]);
}

Status readPayload(std::span<const uint8_t> payload, TextureBundle& m, size_t base_offset,
                   uint8_t minor) {
  WireReader r(payload, base_offset);
  m.frame_id = r.u64("texture_bundle.frame_id");
  readStamps(r, m.stamps);
  const uint8_t n = r.u8("texture_bundle.image_count");
  if (n > maxCamerasIn(minor)) {
    r.failValue("texture_bundle.image_count", StatusCode::kTooLarge,
                std::to_string(n) + " above cap " + std::to_string(maxCamerasIn(minor)));
  }
  m.images.resize(r.ok() ? n : 0);
  for (auto& image : m.images) {
    image.camera_id = r.u32("texture_bundle.camera_id");
    image.offset_x = r.u32("texture_bundle.offset_x");
    image.offset_y = r.u32("texture_bundle.offset_y");
    readPlanes(r, image.planes);
    if (!r.ok()) break;
  }
  if (minor < 5 || !r.ok()) return finish(r);
  const uint8_t layer_count = r.u8("texture_bundle.layer_count");
  if (layer_count > kMaxLayers) {
    r.failValue("texture_bundle.layer_count", StatusCode::kTooLarge,
                std::to_string(layer_count) + " above cap " + std::to_string(kMaxLayers));
  }
  if (layer_count == 0 || !r.ok()) return finish(r);
  BundleLayers& layers = m.layers.emplace();
  layers.texels = r.u32("texture_bundle.atlas_texels");
  layers.squares_per_side = r.u32("texture_bundle.squares_per_side");
  layers.square_texels = r.u32("texture_bundle.square_texels");
  for (uint32_t& side : layers.lattice) side = r.u32("texture_bundle.lattice");
  layers.chart_cells = r.u8("texture_bundle.chart_cells");
  layers.charts_face_surface_around = false;
  if (minor >= 12) {
    const uint8_t facing = r.u8("texture_bundle.chart_facing");
    if (facing > 1)
      r.failValue("texture_bundle.chart_facing", StatusCode::kMalformed,
                  std::to_string(facing) + " is neither 0 (own normal) nor 1 (surface around)");
    layers.charts_face_surface_around = facing == 1;
  }
  layers.texel_metres = r.f64("texture_bundle.texel_metres");
  layers.square_count = r.u32("texture_bundle.square_count");
  layers.slots = r.bytes32("texture_bundle.slots", kMaxPlaneBytes);
  const uint8_t cameras = r.u8("texture_bundle.layer_camera_count");
  if (cameras > kMaxCameras) {
    r.failValue("texture_bundle.layer_camera_count", StatusCode::kTooLarge,
                std::to_string(cameras) + " above cap " + std::to_string(kMaxCameras));
  }
  if (r.ok()) {
    layers.camera_ids.resize(cameras);
    for (uint32_t& id : layers.camera_ids) id = r.u32("texture_bundle.layer_camera_id");
  }
  layers.layers.resize(r.ok() ? layer_count : 0);
  for (auto& planes : layers.layers) {
    readPlanes(r, planes,
               minor >= 11  ? Codec::kZstd
               : minor >= 6 ? Codec::kAv1
                            : Codec::kLz4PlanarDelta);
    if (!r.ok()) break;
  }
  return finish(r);
}

void writePayload(WireWriter& w, const Heartbeat& m) { w.u64(m.send_time_ns); }

Status readPayload(std::span<const uint8_t> payload, Heartbeat& m, size_t base_offset) {
  WireReader r(payload, base_offset);
  m.send_time_ns = r.u64("heartbeat.send_time");
  return finish(r);
}

void writePayload(WireWriter& w, const Stats& m, uint8_t minor) {
  w.u64(m.frame_id);
  w.u32(m.cameras_expected);
  w.u64(m.cameras_present);
  w.u64(m.late_frames);
  w.u64(m.dropped_groups);
  w.u64(m.pod_bytes);
  w.str(m.note);
  if (minor >= 1) {
    const std::vector<PodArrivals> none;
    const auto& arrivals = m.pod_arrivals ? *m.pod_arrivals : none;
    const size_t count = std::min(arrivals.size(), maxCamerasIn(minor));
    w.u16(static_cast<uint16_t>(count));
    for (size_t k = 0; k < count; ++k) {
      w.u16(arrivals[k].pod);
      w.u64(arrivals[k].frames);
      w.u32(arrivals[k].jitter_us);
      if (minor >= 8) {
        w.u64(static_cast<uint64_t>(arrivals[k].clock_offset_ns));
        w.u64(arrivals[k].clock_uncertainty_ns);
      }
    }
  }
  if (minor >= 3) w.u32(m.cameras_present_count.value_or(0));
}

Status readPayload(std::span<const uint8_t> payload, Stats& m, size_t base_offset, uint8_t minor) {
  WireReader r(payload, base_offset);
  m.frame_id = r.u64("stats.frame_id");
  m.cameras_expected = r.u32("stats.cameras_expected");
  m.cameras_present = r.u64("stats.cameras_present");
  m.late_frames = r.u64("stats.late_frames");
  m.dropped_groups = r.u64("stats.dropped_groups");
  m.pod_bytes = r.u64("stats.pod_bytes");
  m.note = r.str("stats.note");
  m.pod_arrivals.reset();
  // Since 1.1: a 1.0 payload ends here.
  if (minor >= 1) {
    const uint16_t n = r.u16("stats.pod_arrivals.count");
    const size_t kBytesPerPod = minor >= 8 ? 30 : 14;
    if (n > maxCamerasIn(minor)) {
      r.failValue("stats.pod_arrivals.count", StatusCode::kTooLarge,
                  std::to_string(n) + " above cap " + std::to_string(maxCamerasIn(minor)));
      return finish(r);
    }
    if (!r.ok() || static_cast<size_t>(n) * kBytesPerPod > r.remaining()) {
      r.raw("stats.pod_arrivals", static_cast<size_t>(n) * kBytesPerPod);
      return finish(r);
    }
    m.pod_arrivals.emplace(n);
    for (auto& a : *m.pod_arrivals) {
      a.pod = r.u16("stats.pod_arrivals.pod");
      a.frames = r.u64("stats.pod_arrivals.frames");
      a.jitter_us = r.u32("stats.pod_arrivals.jitter_us");
      if (minor >= 8) {
        a.clock_offset_ns = static_cast<int64_t>(r.u64("stats.pod_arrivals.clock_offset"));
        a.clock_uncertainty_ns = r.u64("stats.pod_arrivals.clock_uncertainty");
      }
    }
  }
  m.cameras_present_count.reset();
  if (minor >= 3) m.cameras_present_count = r.u32("stats.cameras_present_count");
  return finish(r);
}

void writePayload(WireWriter& w, const Bye& m) { w.str(m.reason); }

Status readPayload(std::span<const uint8_t> payload, Bye& m, size_t base_offset) {
  WireReader r(payload, base_offset);
  m.reason = r.str("bye.reason");
  return finish(r);
}

void writePayload(WireWriter& w, const ErrorMessage& m) {
  w.u16(m.code);
  w.str(m.message);
}

Status readPayload(std::span<const uint8_t> payload, ErrorMessage& m, size_t base_offset) {
  WireReader r(payload, base_offset);
  m.code = r.u16("error.code");
  m.message = r.str("error.message");
  return finish(r);
}

void writePayload(WireWriter& w, const ClockProbe& m) {
  w.u8(static_cast<uint8_t>(m.step));
  w.u64(m.origin_ns);
  w.u64(m.receive_ns);
  w.u64(m.transmit_ns);
}

Status readPayload(std::span<const uint8_t> payload, ClockProbe& m, size_t base_offset) {
  WireReader r(payload, base_offset);
  const uint8_t step = r.u8("clock_probe.step");
  if (r.ok() && step != static_cast<uint8_t>(ProbeStep::kRequest) &&
      step != static_cast<uint8_t>(ProbeStep::kReply)) {
    r.failValue("clock_probe.step", StatusCode::kMalformed,
                "unknown step " + std::to_string(step) + " (1 request, 2 reply)");
    return finish(r);
  }
  m.step = static_cast<ProbeStep>(step);
  m.origin_ns = r.u64("clock_probe.origin");
  m.receive_ns = r.u64("clock_probe.receive");
  m.transmit_ns = r.u64("clock_probe.transmit");
  return finish(r);
}

void writePayload(WireWriter& w, const FrameRequest& m, uint8_t minor) {
  w.u64(m.frames_through);
  if (minor >= 10) w.u64(m.layer_capabilities.value_or(0));
}

Status readPayload(std::span<const uint8_t> payload, FrameRequest& m, size_t base_offset,
                   uint8_t minor) {
  WireReader r(payload, base_offset);
  m.frames_through = r.u64("frame_request.frames_through");
  m.layer_capabilities.reset();
  if (minor >= 10) m.layer_capabilities = r.u64("frame_request.layer_capabilities");
  return finish(r);
}

}  // namespace holofuse::protocol

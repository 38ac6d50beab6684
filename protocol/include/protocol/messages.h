// The messages of protocol/SPEC.md section 5: plain structs, their payload
// encoders, and decoders that are safe on untrusted bytes. Bulk data (image
// planes, Draco bytes) is carried as spans into the frame buffer: decoding
// copies nothing.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "base/status.h"
#include "protocol/frame.h"
#include "protocol/wire.h"

namespace holofuse::protocol {

// Stage ids of SPEC.md section 5, in loop order.
enum class Stage : uint16_t {
  kPodRender = 1,
  kSegment = 2,
  kFeather = 3,
  kPodEncode = 4,
  kSend = 5,
  kSyncWait = 6,
  kHull = 7,
  kMeshEncode = 8,
  kImageEncode = 9,
  kFanout = 10,
  kDecode = 11,
  kUpload = 12,
  kRender = 13,
  kWrite = 14,
  kReplayRead = 15,    // a replay pod reads and checks a recorded frame (in place of 1-4)
  kServerDecode = 16,  // the server parses a PodFrame and decompresses its planes
  kRefine = 17,      // the server moves the hull's vertices by photo-consistency (off unless asked)
  kLayers = 18,      // the server lays the mesh out in an atlas and fills the texture layers
  kLayerVideo = 19,  // the server codes the layers' colour as video (since 1.6)
};
constexpr uint16_t kFirstStage = 1;
constexpr uint16_t kLastStage = 19;
// Snake-case name of a stage id ("pod_render"), or "stage_<n>" for unknown ids.
std::string stageName(uint16_t stage);
// Every known stage id in the order a frame passes them (reports list them so).
const std::vector<uint16_t>& stagesInPipelineOrder();

// Cameras one loop serves: pods, the server's frame groups, the client's
// views, eval and imports all take up to this many (the renderer's
// HOLOFUSE_MAX_CAMERAS is the same).
constexpr uint32_t kMaxCameras = 128;

constexpr uint16_t kSourceServer = 0xFFFF;
constexpr uint16_t kSourceClient = 0xFFFE;
constexpr size_t kMaxStamps = 1024;
constexpr size_t kMaxPlanes = 8;
// Images of a TextureBundle and pods of a Stats' arrivals a message of that
// minor may hold: 64 before 1.3, every camera since.
constexpr size_t kMaxCamerasBefore13 = 64;
inline size_t maxCamerasIn(uint8_t minor) {
  return minor >= 3 ? size_t{kMaxCameras} : kMaxCamerasBefore13;
}
constexpr size_t kMaxDistortion = 8;
constexpr uint32_t kMaxPlaneBytes = 256u << 20;
constexpr uint32_t kMaxImageSide = 16384;  // width and height of any plane

struct StageStamp {
  uint16_t stage = 0;
  uint16_t source = 0;
  uint64_t start_ns = 0;
  uint64_t end_ns = 0;
  bool operator==(const StageStamp&) const = default;
};

// Milliseconds of every finished stamp of `stage` in stamps, added up (0
// when none; a stamp still open or ending before it starts counts 0).
double stampedMs(const std::vector<StageStamp>& stamps, Stage stage);

// kCamera (since 1.5): a texture layer's camera per texel, GRAY8, an index
// into the layers' camera ids (BundleLayers), 255 where none sees it.
enum class PlaneKind : uint8_t { kColor = 1, kMask = 2, kFeather = 3, kDepth = 4, kCamera = 5 };
// kH264, kHevc, kAv1 (since 1.6): a texture layer's colour as one frame of
// that layer's video stream (codec/layer_video.h), only to a client that
// asked for it (kCapabilityLayerVideo). kZstd (since 1.11): one Zstandard
// frame (RFC 8878) stating its content size; a texture layer's camera
// plane to a client of 1.11.
enum class Codec : uint8_t { kRaw, kLz4, kLz4PlanarDelta, kH264, kHevc, kAv1, kZstd };
enum class PixelFormat : uint8_t { kRgb8 = 1, kGray8 = 2, kR16 = 3 };
uint32_t bytesPerPixel(PixelFormat format);

struct Plane {
  PlaneKind kind = PlaneKind::kColor;
  Codec codec = Codec::kRaw;
  PixelFormat format = PixelFormat::kRgb8;
  uint32_t width = 0;
  uint32_t height = 0;
  uint32_t raw_size = 0;
  std::span<const uint8_t> data;
};

enum class Role : uint8_t { kPod = 1, kClient = 2 };

// Hello's capability bits.
// The client asks for texture layers instead of camera images (since 1.5;
// a server of an older minor ignores it and sends images).
constexpr uint64_t kCapabilityLayers = 1;
// With kCapabilityLayers: the client decodes the layers' colour as video
// (since 1.6; a server of 1.5 sends them with LZ4).
constexpr uint64_t kCapabilityLayerVideo = 2;
// The client asks for its fused frames (FrameRequest, since 1.9): the
// server sends it none until its first request, then only those asked for.
constexpr uint64_t kCapabilityAsksForFrames = 4;

struct Hello {
  static constexpr MessageType kType = MessageType::kHello;
  Role role = Role::kPod;
  uint32_t id = 0;
  uint8_t min_major = kVersionMajor, min_minor = 0;
  uint8_t max_major = kVersionMajor, max_minor = kVersionMinor;
  uint64_t capabilities = 0;
  uint64_t nonce = 0;
  uint64_t send_time_ns = 0;
  std::string name;
};

struct HelloAck {
  static constexpr MessageType kType = MessageType::kHelloAck;
  uint8_t major = kVersionMajor, minor = kVersionMinor;
  uint32_t session_id = 0;
  uint64_t server_time_ns = 0;
  uint32_t heartbeat_interval_ms = 500;
  uint32_t idle_timeout_ms = 5000;
};

// Since 1.4: the HMAC-SHA256 challenge of SPEC.md section 4
// (protocol/auth.h). One type, three steps: the server's challenge, the
// peer's answer, the server's proof that it holds the key too.
enum class AuthStep : uint8_t { kChallenge = 1, kResponse = 2, kProof = 3 };
constexpr size_t kAuthBytes = 32;
struct Auth {
  static constexpr MessageType kType = MessageType::kAuth;
  AuthStep step = AuthStep::kChallenge;
  std::array<uint8_t, kAuthBytes> value{};  // the challenge nonce, or a MAC
};

struct Calibration {
  static constexpr MessageType kType = MessageType::kCalibration;
  uint32_t camera_id = 0;
  uint32_t width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0, skew = 0;
  std::vector<double> distortion;    // OpenCV order k1 k2 p1 p2 k3 ...
  std::array<double, 9> rotation{};  // world to camera, row major
  std::array<double, 3> translation{};
};

struct PodFrame {
  static constexpr MessageType kType = MessageType::kPodFrame;
  uint64_t frame_id = 0;
  uint32_t camera_id = 0;
  uint64_t capture_time_ns = 0;
  uint32_t offset_x = 0, offset_y = 0;
  std::vector<StageStamp> stamps;
  std::vector<Plane> planes;
};

// 2 since 1.7: half floats through LZ4 (codec/mesh_codec.h).
enum class MeshCodec : uint8_t { kDraco = 1, kFp16Lz4 = 2 };

struct MeshFrame {
  static constexpr MessageType kType = MessageType::kMeshFrame;
  uint64_t frame_id = 0;
  uint64_t capture_time_ns = 0;
  std::array<float, 3> bounds_min{}, bounds_max{};
  uint32_t vertex_count = 0;
  uint32_t triangle_count = 0;
  MeshCodec codec = MeshCodec::kDraco;
  std::vector<StageStamp> stamps;
  std::span<const uint8_t> mesh;
};

struct BundleImage {
  uint32_t camera_id = 0;
  uint32_t offset_x = 0, offset_y = 0;
  std::vector<Plane> planes;
};

// Since 1.5: layered view-dependent texture maps (Volino and Hilton 2016)
// in the frame's atlas (Dong and Hollerer 2017), in place of the camera
// images for a client that asked (kCapabilityLayers). The atlas travels
// as its layout (texture/texture_atlas.h: the grid, the key lattice and
// each square's slot); the receiver lays the mesh out from its vertex keys.
constexpr size_t kMaxLayers = 16;
struct BundleLayers {
  uint32_t texels = 0, squares_per_side = 0, square_texels = 0;
  std::array<uint32_t, 3> lattice{};
  // 0: a square per pair of triangles; n: charts of n^3 lattice cells per
  // dominant axis, texel_metres of surface a texel.
  uint8_t chart_cells = 0;
  // Since 1.12: a triangle's chart faces the dominant axis of the normal
  // summed over its lattice cell and the cell's face neighbours (true), or
  // of its own normal (false; always so before 1.12).
  bool charts_face_surface_around = true;
  double texel_metres = 0;
  uint32_t square_count = 0;
  std::span<const uint8_t> slots;          // encodeAtlasSlots
  std::vector<uint32_t> camera_ids;        // what a camera plane's index names
  std::vector<std::vector<Plane>> layers;  // per layer: colour (RGB) and camera (kCamera)
};

struct TextureBundle {
  static constexpr MessageType kType = MessageType::kTextureBundle;
  uint64_t frame_id = 0;
  std::vector<StageStamp> stamps;
  std::vector<BundleImage> images;
  std::optional<BundleLayers> layers;  // since 1.5; absent before, or when images are sent
};

struct Heartbeat {
  static constexpr MessageType kType = MessageType::kHeartbeat;
  uint64_t send_time_ns = 0;
};

// Since 1.1: one pod's PodFrames as they reached the server, every one of
// them (also those no client renders), for the RFC 3550 jitter.
struct PodArrivals {
  uint16_t pod = 0;
  uint64_t frames = 0;     // PodFrames received from this pod so far
  uint32_t jitter_us = 0;  // RFC 3550 interarrival jitter over them, microseconds
  // Since 1.8: the pod's clock minus the server's as the server estimates
  // it (protocol/clock_sync.h), and half the round trip of the sample it
  // came from: the true offset lies within offset +- uncertainty. An
  // uncertainty of 0 means not measured (a pod before 1.8, or no answer
  // yet); the pod's stamps are then taken as they are.
  int64_t clock_offset_ns = 0;
  uint64_t clock_uncertainty_ns = 0;
  bool operator==(const PodArrivals&) const = default;
};

struct Stats {
  static constexpr MessageType kType = MessageType::kStats;
  uint64_t frame_id = 0;
  uint32_t cameras_expected = 0;
  uint64_t cameras_present = 0;
  uint64_t late_frames = 0;
  uint64_t dropped_groups = 0;
  uint64_t pod_bytes = 0;
  std::string note;
  // Since 1.1: read from a 1.1 Stats (absent when read from a 1.0 one);
  // written as the encoding's minor asks (before 1.3, the first 64).
  std::optional<std::vector<PodArrivals>> pod_arrivals;
  // Since 1.3: the cameras the group held, whatever their ids
  // (cameras_present's bits end at camera 63); absent before.
  std::optional<uint32_t> cameras_present_count;
};

// Since 1.8: one exchange of NTP's four timestamps (RFC 5905 section 8).
// The requester sends origin (its clock); the responder copies it and adds
// receive (its clock when the request arrived) and transmit (its clock when
// it answers). With the requester's arrival time the pair gives the
// responder's offset and the round trip (protocol/clock_sync.h).
enum class ProbeStep : uint8_t { kRequest = 1, kReply = 2 };
struct ClockProbe {
  static constexpr MessageType kType = MessageType::kClockProbe;
  ProbeStep step = ProbeStep::kRequest;
  uint64_t origin_ns = 0;
  uint64_t receive_ns = 0;   // 0 in a request
  uint64_t transmit_ns = 0;  // 0 in a request
  bool operator==(const ClockProbe&) const = default;
};

// Since 1.9: a client asks for fused frames (a MeshFrame with its
// TextureBundle and Stats each) until it has received frames_through
// MeshFrames on this connection. Counted from the connection's start, a
// request states the whole want: a repeated, lost or flooded one cannot
// inflate it. A client that asks is sent only what it asked for, and the
// server fuses a group only while some client can take it: a client that
// renders slower than the pods capture costs no fusion it would not
// render, and its next mesh is fused while it renders the last. A client
// that never asks is sent every frame, as before 1.9.
//
// Since 1.10 it also states what the client takes from the next frame on:
// Hello's capability bits 0 and 1 (texture layers; their colour as video),
// so a viewer changes to or from mode layered without reconnecting. A
// request of 1.9 has none: the Hello's bits stand.
struct FrameRequest {
  static constexpr MessageType kType = MessageType::kFrameRequest;
  uint64_t frames_through = 0;
  std::optional<uint64_t> layer_capabilities;
  bool operator==(const FrameRequest&) const = default;
};

struct Bye {
  static constexpr MessageType kType = MessageType::kBye;
  std::string reason;
};

struct ErrorMessage {
  static constexpr MessageType kType = MessageType::kError;
  uint16_t code = 0;
  std::string message;
};

// Payload encoders.
void writePayload(WireWriter& w, const Hello& m);
void writePayload(WireWriter& w, const HelloAck& m);
void writePayload(WireWriter& w, const Auth& m);
void writePayload(WireWriter& w, const Calibration& m);
void writePayload(WireWriter& w, const PodFrame& m);
void writePayload(WireWriter& w, const MeshFrame& m);
// Before 1.3, the first 64 images only.
void writePayload(WireWriter& w, const TextureBundle& m, uint8_t minor = kVersionMinor);
void writePayload(WireWriter& w, const Heartbeat& m);
// The fields of the given minor: from 1.1 on the pods' arrivals (an empty
// list when m has none), before that not; from 1.3 the cameras present;
// from 1.8 each pod's clock offset.
void writePayload(WireWriter& w, const Stats& m, uint8_t minor = kVersionMinor);
void writePayload(WireWriter& w, const Bye& m);
void writePayload(WireWriter& w, const ErrorMessage& m);
void writePayload(WireWriter& w, const ClockProbe& m);
// From 1.10 on the layer capabilities (0 when m has none).
void writePayload(WireWriter& w, const FrameRequest& m, uint8_t minor = kVersionMinor);

// Payload decoders: read the fields this build knows, ignore trailing bytes
// (a newer minor's fields). base_offset positions errors in the stream.
Status readPayload(std::span<const uint8_t> payload, Hello& m, size_t base_offset = 0);
Status readPayload(std::span<const uint8_t> payload, HelloAck& m, size_t base_offset = 0);
Status readPayload(std::span<const uint8_t> payload, Auth& m, size_t base_offset = 0);
Status readPayload(std::span<const uint8_t> payload, Calibration& m, size_t base_offset = 0);
Status readPayload(std::span<const uint8_t> payload, PodFrame& m, size_t base_offset = 0);
// Codec 2 only from a frame of 1.7 or later.
Status readPayload(std::span<const uint8_t> payload, MeshFrame& m, size_t base_offset = 0,
                   uint8_t minor = kVersionMinor);
Status readPayload(std::span<const uint8_t> payload, TextureBundle& m, size_t base_offset = 0,
                   uint8_t minor = kVersionMinor);
Status readPayload(std::span<const uint8_t> payload, Heartbeat& m, size_t base_offset = 0);
// A Stats of minor 1 or later must hold the pods' arrivals; one of 1.0 has none.
Status readPayload(std::span<const uint8_t> payload, Stats& m, size_t base_offset = 0,
                   uint8_t minor = kVersionMinor);
Status readPayload(std::span<const uint8_t> payload, Bye& m, size_t base_offset = 0);
Status readPayload(std::span<const uint8_t> payload, ErrorMessage& m, size_t base_offset = 0);
Status readPayload(std::span<const uint8_t> payload, ClockProbe& m, size_t base_offset = 0);
// One of 1.10 or later must hold the layer capabilities; one of 1.9 has none.
Status readPayload(std::span<const uint8_t> payload, FrameRequest& m, size_t base_offset = 0,
                   uint8_t minor = kVersionMinor);

// A whole frame for message m: one copy of the payload into the frame
// buffer (reserved up front from payload_hint), then one CRC pass.
// A message whose fields depend on the minor writes the given minor's, the
// minor the header says.
template <typename Message>
void writePayloadAt(WireWriter& w, const Message& m, uint8_t minor) {
  if constexpr (requires { writePayload(w, m, minor); }) {
    writePayload(w, m, minor);
  } else {
    writePayload(w, m);
  }
}

// minor pins the encoding to an older minor: its header and its fields.
template <typename Message>
Bytes encodeFrame(const Message& m, uint64_t sequence, size_t payload_hint = 0,
                  uint8_t minor = kVersionMinor) {
  FrameBuilder builder(Message::kType, sequence, payload_hint);
  builder.setMinor(minor);
  writePayloadAt(builder.writer(), m, minor);
  return std::move(builder).finish();
}

// The same frame for sending: bulk ranges (planes, Draco bytes) are
// borrowed, not copied, when keep_alive owns them; one CRC pass remains.
template <typename Message>
OutgoingFrame encodeOutgoing(const Message& m, uint64_t sequence,
                             std::shared_ptr<const void> keep_alive = nullptr,
                             uint8_t minor = kVersionMinor) {
  // Room for every field and the small planes that are copied, so the own
  // buffer never grows while it is written.
  FrameBuilder builder(Message::kType, sequence, 4 * kBorrowMinBytes);
  builder.setMinor(minor);
  builder.borrowBulk(std::move(keep_alive));
  writePayloadAt(builder.writer(), m, minor);
  return std::move(builder).finishParts();
}

// Decodes a frame's payload as Message after checking its type.
template <typename Message>
Status decodeFrame(const Frame& frame, Message& m) {
  if (frame.header.type != static_cast<uint16_t>(Message::kType)) {
    return Status(StatusCode::kUnexpectedMessage,
                  std::string("expected ") +
                      messageTypeName(static_cast<uint16_t>(Message::kType)) + ", got " +
                      messageTypeName(frame.header.type));
  }
  // A message whose fields depend on the minor reads the frame's.
  if constexpr (requires { readPayload(frame.payload(), m, kHeaderSize, frame.header.minor); }) {
    return readPayload(frame.payload(), m, kHeaderSize, frame.header.minor);
  } else {
    return readPayload(frame.payload(), m, kHeaderSize);
  }
}

}  // namespace holofuse::protocol

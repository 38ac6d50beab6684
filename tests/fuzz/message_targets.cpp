// Fuzz targets of the protocol (protocol/SPEC.md): the stream decoder as a
// peer's socket feeds it, and each message's payload decoder. Input of a
// message target: one byte choosing the minor (modulo the minors this
// build speaks), then the payload. What decodes must re-encode, and the
// re-encoded frame must decode back to the same bytes (no field is lost or
// invented between a decoder and its encoder).
#include <span>

#include "fuzz_frames.h"
#include "fuzz_target.h"
#include "protocol/frame.h"
#include "protocol/messages.h"

namespace holofuse::fuzz {
namespace {

using namespace protocol;

template <typename Message>
int decodeAndReencode(const char* target, const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const uint8_t minor = minorOf(data[0]);
  // A message's bulk fields point into its frame, which must outlive them.
  const Frame frame = frameAround(Message::kType, minor, {data + 1, size - 1});
  Message m;
  if (!decodeFrame(frame, m).isOk()) return 0;
  ++accepted()[target];
  const Bytes once = encodeFrame(m, 1, 0, minor);
  Message again;
  const std::span<const uint8_t> payload = std::span<const uint8_t>(once).subspan(kHeaderSize);
  const Frame reencoded = frameAround(Message::kType, minor, payload);
  require(decodeFrame(reencoded, again).isOk(),
          "a decoded message re-encodes to a frame its own decoder takes");
  require(encodeFrame(again, 1, 0, minor) == once,
          "decoding a re-encoded message and encoding it again gives the same bytes");
  return 0;
}

// The message a frame of the stream holds, decoded by its type's decoder.
void decodeAny(const Frame& frame) {
  const auto decode = [&]<typename Message>(Message m) { (void)decodeFrame(frame, m); };
  switch (static_cast<MessageType>(frame.header.type)) {
    case MessageType::kHello:
      return decode(Hello{});
    case MessageType::kHelloAck:
      return decode(HelloAck{});
    case MessageType::kAuth:
      return decode(Auth{});
    case MessageType::kCalibration:
      return decode(Calibration{});
    case MessageType::kPodFrame:
      return decode(PodFrame{});
    case MessageType::kMeshFrame:
      return decode(MeshFrame{});
    case MessageType::kTextureBundle:
      return decode(TextureBundle{});
    case MessageType::kHeartbeat:
      return decode(Heartbeat{});
    case MessageType::kStats:
      return decode(Stats{});
    case MessageType::kBye:
      return decode(Bye{});
    case MessageType::kError:
      return decode(ErrorMessage{});
    case MessageType::kClockProbe:
      return decode(ClockProbe{});
    case MessageType::kFrameRequest:
      return decode(FrameRequest{});
  }
}

}  // namespace

// Bytes as a socket delivers them, in two uneven reads so that frames
// straddle a read boundary. A frame the decoder hands on is whole: its
// length is what the header says, within the cap.
HOLOFUSE_FUZZ_TARGET(stream) {
  constexpr uint32_t kCap = 1u << 20;
  StreamDecoder decoder(kCap);
  const size_t split = size / 3;
  decoder.feed({data, split});
  decoder.feed({data + split, size - split});
  while (decoder.hasFrame()) {
    const Frame frame = decoder.takeFrame();
    ++accepted()["stream"];
    require(frame.bytes.size() == kHeaderSize + frame.header.payload_length,
            "a whole frame is its header and the payload length it states");
    require(frame.header.payload_length <= kCap, "no frame past the decoder's cap");
    decodeAny(frame);
  }
  return 0;
}

// One target per message type.
#define HOLOFUSE_MESSAGE_FUZZ_TARGET(name, Message) \
  HOLOFUSE_FUZZ_TARGET(name) { return decodeAndReencode<Message>(#name, data, size); }

HOLOFUSE_MESSAGE_FUZZ_TARGET(message_hello, Hello)
HOLOFUSE_MESSAGE_FUZZ_TARGET(message_hello_ack, HelloAck)
HOLOFUSE_MESSAGE_FUZZ_TARGET(message_auth, Auth)
HOLOFUSE_MESSAGE_FUZZ_TARGET(message_calibration, Calibration)
HOLOFUSE_MESSAGE_FUZZ_TARGET(message_pod_frame, PodFrame)
HOLOFUSE_MESSAGE_FUZZ_TARGET(message_mesh_frame, MeshFrame)
HOLOFUSE_MESSAGE_FUZZ_TARGET(message_texture_bundle, TextureBundle)
HOLOFUSE_MESSAGE_FUZZ_TARGET(message_heartbeat, Heartbeat)
HOLOFUSE_MESSAGE_FUZZ_TARGET(message_stats, Stats)
HOLOFUSE_MESSAGE_FUZZ_TARGET(message_bye, Bye)
HOLOFUSE_MESSAGE_FUZZ_TARGET(message_error, ErrorMessage)
HOLOFUSE_MESSAGE_FUZZ_TARGET(message_clock_probe, ClockProbe)
HOLOFUSE_MESSAGE_FUZZ_TARGET(message_frame_request, FrameRequest)

}  // namespace holofuse::fuzz

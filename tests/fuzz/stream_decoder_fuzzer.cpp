// libFuzzer target: arbitrary bytes through the stream decoder and every
// message decoder. Built with clang and -DHOLOFUSE_FUZZ=ON; without a
// fuzzing engine, fuzz_corpus_replay.cpp runs the committed corpus.
#include <cstddef>
#include <cstdint>

#include "protocol/frame.h"
#include "protocol/messages.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace holofuse::protocol;
  StreamDecoder decoder(1u << 20);
  // Feed in two uneven chunks so chunk boundaries are exercised too.
  const size_t split = size / 3;
  decoder.feed(std::span<const uint8_t>(data, split));
  decoder.feed(std::span<const uint8_t>(data + split, size - split));
  while (decoder.hasFrame()) {
    const Frame frame = decoder.takeFrame();
    switch (static_cast<MessageType>(frame.header.type)) {
      case MessageType::kHello: {
        Hello m;
        (void)decodeFrame(frame, m);
        break;
      }
      case MessageType::kHelloAck: {
        HelloAck m;
        (void)decodeFrame(frame, m);
        break;
      }
      case MessageType::kCalibration: {
        Calibration m;
        (void)decodeFrame(frame, m);
        break;
      }
      case MessageType::kPodFrame: {
        PodFrame m;
        (void)decodeFrame(frame, m);
        break;
      }
      case MessageType::kMeshFrame: {
        MeshFrame m;
        (void)decodeFrame(frame, m);
        break;
      }
      case MessageType::kTextureBundle: {
        TextureBundle m;
        (void)decodeFrame(frame, m);
        break;
      }
      case MessageType::kHeartbeat: {
        Heartbeat m;
        (void)decodeFrame(frame, m);
        break;
      }
      case MessageType::kStats: {
        Stats m;
        (void)decodeFrame(frame, m);
        break;
      }
      case MessageType::kBye: {
        Bye m;
        (void)decodeFrame(frame, m);
        break;
      }
      case MessageType::kError: {
        ErrorMessage m;
        (void)decodeFrame(frame, m);
        break;
      }
      case MessageType::kAuth: {
        Auth m;
        (void)decodeFrame(frame, m);
        break;
      }
      default:
        break;
    }
  }
  return 0;
}

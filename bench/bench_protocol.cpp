// PodFrame encode and decode against a plain memcpy of the same bytes in
// the same run (target: at least 50% of memcpy's throughput: no needless
// copies). Input: a real pod frame of the synthetic scene at the demo size.
#include <benchmark/benchmark.h>

#include <cstring>

#include "capture_node/pod.h"
#include "protocol/frame.h"
#include "protocol/messages.h"

namespace {

using namespace holofuse;

struct Input {
  std::vector<uint8_t> frame;              // an encoded PodFrame
  protocol::PodFrame message;              // its decoded form (views into frame)
};

const Input& input() {
  static const Input kInput = [] {
    const capture::SyntheticScene scene;
    const auto cam = capture::SyntheticScene::cameraRig(4, 320, 240)[0];
    capture::PodCapture capture = capture::capturePodFrame(scene, cam, scene.backgroundPlate(cam), 10, 0);
    Input in;
    in.frame = capture::encodePodFrame(capture, 0, protocol::Codec::kLz4PlanarDelta);
    protocol::StreamDecoder decoder;
    decoder.feed(in.frame);
    static protocol::Frame frame = decoder.takeFrame();
    (void)protocol::decodeFrame(frame, in.message);
    return in;
  }();
  return kInput;
}

void BM_Memcpy(benchmark::State& state) {
  const auto& in = input();
  std::vector<uint8_t> dst(in.frame.size());
  for (auto _ : state) {
    std::memcpy(dst.data(), in.frame.data(), in.frame.size());
    benchmark::DoNotOptimize(dst.data());
    benchmark::ClobberMemory();
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * in.frame.size()));
}

void BM_EncodePodFrame(benchmark::State& state) {
  const auto& in = input();
  for (auto _ : state) {
    auto bytes = protocol::encodeFrame(in.message, 1, in.frame.size());
    benchmark::DoNotOptimize(bytes.data());
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * in.frame.size()));
}

void BM_DecodePodFrame(benchmark::State& state) {
  const auto& in = input();
  for (auto _ : state) {
    protocol::StreamDecoder decoder;
    decoder.feed(in.frame);  // one copy into the frame buffer, as a socket read would do
    protocol::Frame frame = decoder.takeFrame();
    protocol::PodFrame message;
    benchmark::DoNotOptimize(protocol::decodeFrame(frame, message).isOk());
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * in.frame.size()));
}

BENCHMARK(BM_Memcpy);
BENCHMARK(BM_EncodePodFrame);
BENCHMARK(BM_DecodePodFrame);

}  // namespace

BENCHMARK_MAIN();

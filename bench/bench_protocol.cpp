// PodFrame encode and decode against a plain memcpy of the same bytes in
// the same run (target: at least 50% of memcpy's throughput: no needless
// copies). Input: a real pod frame of the synthetic scene at the demo size.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstring>
#include <map>
#include <string>

#include "capture_node/pod.h"
#include "protocol/crc32c.h"
#include "protocol/frame.h"
#include "protocol/messages.h"

namespace {

using namespace holofuse;

struct Input {
  protocol::Bytes frame;       // an encoded PodFrame
  protocol::PodFrame message;  // its decoded form (views into frame)
};

const Input& input() {
  static const Input kInput = [] {
    const scene::SyntheticScene scene;
    const auto cam = scene::SyntheticScene::cameraRig(4, 320, 240)[0];
    capture::PodCapture capture =
        capture::capturePodFrame(scene, cam, scene.backgroundPlate(cam), 10, 0);
    Input in;
    in.frame = capture::encodePodFrame(capture, 0, {protocol::Codec::kLz4PlanarDelta, kFullFrame})
                   .flatten();
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

// The checksum alone: encode and decode each make one pass of it.
void BM_Crc32c(benchmark::State& state) {
  const auto& in = input();
  for (auto _ : state)
    benchmark::DoNotOptimize(protocol::crc32c(0, in.frame.data(), in.frame.size()));
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * in.frame.size()));
}

// Encode as the transport does it: header and small fields into the
// frame's own buffer, the planes borrowed in place (sendmsg gathers them),
// one CRC pass over everything.
void BM_EncodePodFrame(benchmark::State& state) {
  const auto& in = input();
  const auto owner = std::make_shared<int>(0);  // stands for the planes' owner
  for (auto _ : state) {
    auto frame = protocol::encodeOutgoing(in.message, 1, owner);
    benchmark::DoNotOptimize(frame.parts().data());
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * in.frame.size()));
}

// The same into one contiguous buffer: one copy of the planes plus the CRC.
void BM_EncodePodFrameContiguous(benchmark::State& state) {
  const auto& in = input();
  for (auto _ : state) {
    auto bytes = protocol::encodeFrame(in.message, 1, in.frame.size());
    benchmark::DoNotOptimize(bytes.data());
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * in.frame.size()));
}

// Decode as the transport does it: the socket read lands in the frame's own
// buffer (StreamDecoder::writableSpan), then the header is checked, the CRC
// verified and the message decoded into views (no payload copy).
void BM_DecodePodFrame(benchmark::State& state) {
  const auto& in = input();
  protocol::Frame frame;
  frame.bytes = in.frame;
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        protocol::parseHeader(frame.bytes, protocol::kDefaultMaxPayload, 0, frame.header).isOk());
    benchmark::DoNotOptimize(protocol::verifyCrc(frame, 0).isOk());
    protocol::PodFrame message;
    benchmark::DoNotOptimize(protocol::decodeFrame(frame, message).isOk());
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * in.frame.size()));
}

// The same through StreamDecoder::feed, which adds the copy a socket read
// would have made (and a fresh frame allocation per message).
void BM_FeedAndDecodePodFrame(benchmark::State& state) {
  const auto& in = input();
  for (auto _ : state) {
    protocol::StreamDecoder decoder;
    decoder.feed(in.frame);
    protocol::Frame frame = decoder.takeFrame();
    protocol::PodFrame message;
    benchmark::DoNotOptimize(protocol::decodeFrame(frame, message).isOk());
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * in.frame.size()));
}

// Paper 004's valid region on the pod link: one pod's capture encoded
// whole (margin -1) and as the foreground's rectangle grown by the default
// 8 pixels, the same capture in the same run. wire_bytes: the frame as
// sent. Compare the two rows' times and bytes.
void BM_EncodePodCapture(benchmark::State& state) {
  static const capture::PodCapture kCaptured = [] {
    const scene::SyntheticScene scene;
    const auto cam = scene::SyntheticScene::cameraRig(4, 320, 240)[0];
    return capture::capturePodFrame(scene, cam, scene.backgroundPlate(cam), 10, 0);
  }();
  const int margin = static_cast<int>(state.range(0));
  size_t wire_bytes = 0;
  for (auto _ : state) {
    state.PauseTiming();
    capture::PodCapture capture = kCaptured;  // the encoder appends a stamp and borrows the planes
    state.ResumeTiming();
    const auto frame =
        capture::encodePodFrame(capture, 0, {protocol::Codec::kLz4PlanarDelta, margin});
    wire_bytes = frame.size();
    benchmark::DoNotOptimize(wire_bytes);
  }
  state.counters["wire_bytes"] = static_cast<double>(wire_bytes);
}

BENCHMARK(BM_Memcpy);
BENCHMARK(BM_Crc32c);
BENCHMARK(BM_EncodePodFrame);
BENCHMARK(BM_EncodePodFrameContiguous);
BENCHMARK(BM_DecodePodFrame);
BENCHMARK(BM_FeedAndDecodePodFrame);
BENCHMARK(BM_EncodePodCapture)
    ->ArgName("crop_margin")
    ->Arg(kFullFrame)
    ->Arg(8)
    ->Unit(benchmark::kMicrosecond);

}  // namespace

// Prints each benchmark's throughput as a share of memcpy's in this run:
// the machine is noisy, ratios are what to compare (target: >= 50%).
class RatioReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const auto& run : runs) {
      auto it = run.counters.find("bytes_per_second");
      if (it != run.counters.end()) throughput_[run.benchmark_name()] = it->second.value;
    }
  }
  void printRatios() const {
    auto base = throughput_.find("BM_Memcpy");
    if (base == throughput_.end() || base->second <= 0) return;
    std::printf(
        "\nthroughput relative to memcpy in this run (target for encode and decode: >= 50%%)\n");
    for (const auto& [name, value] : throughput_) {
      if (name != "BM_Memcpy")
        std::printf("  %-28s %5.1f%%\n", name.c_str(), 100.0 * value / base->second);
    }
  }

 private:
  std::map<std::string, double> throughput_;
};

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  RatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  reporter.printRatios();
  benchmark::Shutdown();
  return 0;
}

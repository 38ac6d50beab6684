// Replays the committed seed corpus through the fuzz target as an ordinary
// test (no fuzzing engine needed), plus mutations of each seed: every
// single-byte flip and every truncation.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

TEST(FuzzCorpus, EverySeedAndItsMutationsDecodeWithoutHarm) {
  size_t seeds = 0;
  for (const auto& entry : std::filesystem::directory_iterator(HOLOFUSE_FUZZ_CORPUS_DIR)) {
    std::ifstream in(entry.path(), std::ios::binary);
    std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                               std::istreambuf_iterator<char>());
    EXPECT_EQ(LLVMFuzzerTestOneInput(bytes.data(), bytes.size()), 0);
    for (size_t n = 0; n < bytes.size(); ++n) LLVMFuzzerTestOneInput(bytes.data(), n);
    for (size_t i = 0; i < bytes.size(); ++i) {
      auto flipped = bytes;
      flipped[i] ^= 0xA5;
      LLVMFuzzerTestOneInput(flipped.data(), flipped.size());
    }
    ++seeds;
  }
  EXPECT_GE(seeds, 10u) << "the seed corpus should hold one frame of every message type";
}

// Every fuzz target's committed seed corpus (tests/fuzz/corpus/<target>/,
// written by make_fuzz_seeds) replayed as a test, with no fuzzing engine:
// each seed, each of its truncations and single-byte flips. A target whose
// seeds the code refuses has a stale corpus: its fuzzing would start at
// the first check and never reach the parser behind it.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <vector>

#include "fuzz_target.h"

namespace holofuse::fuzz {
namespace {

namespace fs = std::filesystem;
const fs::path kCorpus = HOLOFUSE_FUZZ_CORPUS_DIR;

std::vector<std::string> targetNames() {
  std::vector<std::string> names;
  for (const auto& [name, target] : targets()) names.push_back(name);
  return names;
}

std::vector<std::vector<uint8_t>> seedsOf(const std::string& target) {
  std::vector<fs::path> files;
  if (fs::is_directory(kCorpus / target))
    for (const auto& entry : fs::directory_iterator(kCorpus / target))
      files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  std::vector<std::vector<uint8_t>> seeds;
  for (const fs::path& file : files) {
    std::ifstream in(file, std::ios::binary);
    seeds.emplace_back(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  return seeds;
}

class FuzzCorpus : public ::testing::TestWithParam<std::string> {};

TEST_P(FuzzCorpus, SeedsAreAcceptedAndTheirMutationsHandled) {
  const std::string& name = GetParam();
  const Target target = targets().at(name);
  const auto seeds = seedsOf(name);
  ASSERT_FALSE(seeds.empty()) << "no seeds in " << (kCorpus / name)
                              << "; write them with build/bin/make_fuzz_seeds tests/fuzz/corpus";
  accepted()[name] = 0;
  for (const auto& seed : seeds) EXPECT_EQ(target(seed.data(), seed.size()), 0);
  EXPECT_GE(accepted()[name], 1u) << "the code refuses every seed of " << name
                                  << ": regenerate them with make_fuzz_seeds";
  // Mutations of each seed, at most 512 positions each, spread evenly.
  for (const auto& seed : seeds) {
    const size_t step = std::max<size_t>(1, seed.size() / 512);
    for (size_t n = 0; n < seed.size(); n += step) target(seed.data(), n);
    for (size_t i = 0; i < seed.size(); i += step) {
      auto flipped = seed;
      flipped[i] ^= 0xA5;
      target(flipped.data(), flipped.size());
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Targets, FuzzCorpus, ::testing::ValuesIn(targetNames()),
                         [](const auto& info) { return info.param; });

// No corpus without its target: a renamed target leaves none behind.
TEST(FuzzCorpusFolders, EachBelongsToATarget) {
  for (const auto& entry : fs::directory_iterator(kCorpus)) {
    EXPECT_TRUE(targets().contains(entry.path().filename().string()))
        << entry.path() << " has no fuzz target";
  }
  EXPECT_GE(targets().size(), 20u);
}

}  // namespace
}  // namespace holofuse::fuzz

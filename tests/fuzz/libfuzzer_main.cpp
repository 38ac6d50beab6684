// libFuzzer's entry point for one target: the build names it in
// HOLOFUSE_FUZZ_TARGET_NAME, and an unknown name stops the run at once.
#include "fuzz_target.h"

namespace {

holofuse::fuzz::Target chosen() {
  static const holofuse::fuzz::Target target = [] {
    auto& all = holofuse::fuzz::targets();
    auto it = all.find(HOLOFUSE_FUZZ_TARGET_NAME);
    if (it == all.end()) {
      std::fprintf(stderr, "no fuzz target named %s in this binary\n", HOLOFUSE_FUZZ_TARGET_NAME);
      std::abort();
    }
    return it->second;
  }();
  return target;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return chosen()(data, size);
}

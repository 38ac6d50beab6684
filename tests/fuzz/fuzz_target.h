// A fuzz target: a function of arbitrary bytes that must neither crash, nor
// touch memory it does not own, nor break the property it checks (a broken
// property aborts, which every fuzzing engine reports as a finding).
//
// Each target is written once, with HOLOFUSE_FUZZ_TARGET(name), and built
// two ways: into the test executable, where the targets register by name
// and the committed seed corpora (tests/fuzz/corpus/<name>/) replay as
// tests; and, with clang, as one libFuzzer binary per target
// (fuzz_<name>), whose entry point runs the target its build names.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>

namespace holofuse::fuzz {

using Target = int (*)(const uint8_t* data, size_t size);

// Every target linked into this program, by name.
std::map<std::string, Target>& targets();

struct Registration {
  Registration(const char* name, Target target) { targets()[name] = target; }
};

// Inputs each target took as valid, so a replay of the seed corpus can
// tell seeds that reach the code past its first checks from stale ones.
std::map<std::string, size_t>& accepted();

// A property a target checks on what the code under test returned: on a
// violation, say which and abort.
inline void require(bool holds, const char* what) {
  if (holds) return;
  std::fprintf(stderr, "fuzz property violated: %s\n", what);
  std::abort();
}

}  // namespace holofuse::fuzz

#define HOLOFUSE_FUZZ_TARGET(name)                                             \
  static int holofuseFuzz_##name(const uint8_t* data, size_t size);            \
  static const ::holofuse::fuzz::Registration holofuseFuzzRegistration_##name( \
      #name, holofuseFuzz_##name);                                             \
  static int holofuseFuzz_##name(const uint8_t* data, size_t size)

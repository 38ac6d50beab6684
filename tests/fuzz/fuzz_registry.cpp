#include "fuzz_target.h"

namespace holofuse::fuzz {

std::map<std::string, Target>& targets() {
  static std::map<std::string, Target> all;
  return all;
}

std::map<std::string, size_t>& accepted() {
  static std::map<std::string, size_t> counts;
  return counts;
}

}  // namespace holofuse::fuzz

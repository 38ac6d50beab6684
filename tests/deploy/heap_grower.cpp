// A program whose heap grows when asked, in one named function, for the
// heap profile's test (test_soak.cpp) to trace with heaptrack. Each line
// on stdin is answered "done" on stdout once its work is in the trace:
// "grow" keeps 256 blocks of 4 KiB (1 MiB) more; every line then makes
// and frees enough small blocks to push the trace's buffer out.
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <string>
#include <vector>

namespace {

std::vector<void*> g_sessions;

__attribute__((noinline)) void keepSessionState(size_t blocks) {
  for (size_t i = 0; i < blocks; ++i) {
    void* block = std::malloc(4096);
    std::memset(block, 1, 4096);
    g_sessions.push_back(block);
  }
}

__attribute__((noinline)) void passTemporaries(size_t count) {
  for (size_t i = 0; i < count; ++i) {
    void* volatile block = std::malloc(64);
    std::free(block);
  }
}

}  // namespace

int main() {
  g_sessions.reserve(1 << 16);
  for (std::string line; std::getline(std::cin, line);) {
    if (line == "grow") keepSessionState(256);
    passTemporaries(20000);
    std::cout << "done" << std::endl;
  }
  for (void* block : g_sessions) std::free(block);
  return 0;
}

// The Vulkan message log (gpu::kMessageLogVariable): every process that
// opens a context appends the layers' messages to one file, so
// `./holofuse validate` judges the programs the tests start, not only the
// tests themselves.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>

#include "base/process.h"
#include "gpu/vulkan_context.h"

namespace fs = std::filesystem;
using namespace holofuse;

namespace {

std::string readText(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

bool validationLayerEnabled() {
  const char* layers = std::getenv("VK_INSTANCE_LAYERS");
  return layers && std::string(layers).find("VK_LAYER_KHRONOS_validation") != std::string::npos;
}

// Runs the probe below in a child of this test with the message log set
// to `message_log`: its exit code; what it printed goes to `output`.
int runProbe(const fs::path& message_log, const fs::path& output) {
  setenv(gpu::kMessageLogVariable, message_log.c_str(), 1);
  SpawnOptions options;
  options.log_path = output.string();
  auto pid = spawnProcess({"/proc/self/exe", "--gtest_also_run_disabled_tests",
                           "--gtest_filter=VulkanMessages.DISABLED_ProbeBreaksAValidUsageRule"},
                          options);
  unsetenv(gpu::kMessageLogVariable);
  if (!pid.isOk()) return -1;
  const auto code = waitProcess(*pid, 120'000);
  return code ? *code : -1;
}

struct ScratchDir {
  fs::path path = fs::temp_directory_path() / ("holofuse_messages_" + std::to_string(getpid()));
  ScratchDir() {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~ScratchDir() { fs::remove_all(path); }
};

}  // namespace

// Run only as runProbe's child: a buffer with no usage breaks
// VUID-VkBufferCreateInfo-usage-requiredbitmask, which the validation
// layer reports (and then refuses the call).
TEST(VulkanMessages, DISABLED_ProbeBreaksAValidUsageRule) {
  gpu::VulkanContext context;
  VkBufferCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
  info.size = 256;
  info.usage = 0;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  VkBuffer buffer = VK_NULL_HANDLE;
  if (vkCreateBuffer(context.device(), &info, nullptr, &buffer) == VK_SUCCESS)
    vkDestroyBuffer(context.device(), buffer, nullptr);
}

// A log that cannot be written would let every message pass unheard: the
// context refuses to open and names the variable, the path and why.
TEST(VulkanMessages, ALogThatCannotBeWrittenStopsTheContextWithItsPath) {
  ScratchDir dir;
  const fs::path log = dir.path / "no_such_dir" / "messages.log";
  EXPECT_NE(runProbe(log, dir.path / "probe.out"), 0);
  const std::string said = readText(dir.path / "probe.out");
  EXPECT_NE(said.find(std::string(gpu::kMessageLogVariable) + "=" + log.string() +
                      ": cannot append to it (No such file or directory)"),
            std::string::npos)
      << said;
}

// Under the validation layer (./holofuse validate), two processes' messages
// land in the one log, a line each, naming the program, its pid and the
// rule; neither clobbers the other's.
TEST(VulkanMessages, TwoProcessesAppendTheLayersMessagesToOneLog) {
  if (!validationLayerEnabled())
    GTEST_SKIP() << "needs VK_INSTANCE_LAYERS=VK_LAYER_KHRONOS_validation (./holofuse validate)";
  ScratchDir dir;
  const fs::path log = dir.path / "messages.log";
  ASSERT_EQ(runProbe(log, dir.path / "first.out"), 0) << readText(dir.path / "first.out");
  ASSERT_EQ(runProbe(log, dir.path / "second.out"), 0) << readText(dir.path / "second.out");
  std::istringstream lines(readText(log));
  std::set<std::string> pids;
  for (std::string line; std::getline(lines, line);) {
    if (line.find("VUID-VkBufferCreateInfo-usage-requiredbitmask") == std::string::npos) continue;
    EXPECT_EQ(line.rfind("Vulkan error in test_gpu (pid ", 0), 0u) << line;
    pids.insert(line.substr(0, line.find(')')));
  }
  EXPECT_EQ(pids.size(), 2u) << readText(log);
}

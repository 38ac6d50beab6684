// One run of the live loop (holofuse_loop, as the user starts it) for a
// benchmark that reads its report.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "base/process.h"

namespace holofuse::bench {

// The folder of this program, where holofuse_loop is built beside it.
inline std::string programDir() {
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::string(".") : self.parent_path().string();
}

// Runs holofuse_loop with flags, writing into dir (emptied first; its log
// in dir/loop.log), and returns its client's report.json; nullopt with
// *error saying what failed and where its log is.
inline std::optional<nlohmann::ordered_json> runLoop(const std::vector<std::string>& flags,
                                                     const std::filesystem::path& dir,
                                                     std::string* error) {
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  std::filesystem::create_directories(dir, ec);
  std::vector<std::string> command = {programDir() + "/holofuse_loop", "--out", dir.string()};
  command.insert(command.end(), flags.begin(), flags.end());
  const std::filesystem::path log = dir / "loop.log";
  SpawnOptions spawn;
  spawn.log_path = log.string();
  const auto pid = spawnProcess(command, spawn);
  if (!pid.isOk()) {
    *error = command.front() + ": " + pid.status().message();
    return std::nullopt;
  }
  const int status = waitProcess(*pid, -1).value_or(-1);
  std::ifstream in(dir / "report.json");
  auto report = nlohmann::ordered_json::parse(in, nullptr, false);
  if (status != 0 || report.is_discarded() || !report.contains("latency_ms")) {
    *error = "exit " + std::to_string(status) + (report.is_discarded() ? ", no report.json" : "") +
             "; see " + log.string();
    return std::nullopt;
  }
  return report;
}

}  // namespace holofuse::bench

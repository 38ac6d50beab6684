#include "protocol/stage_budget.h"

#include <fstream>
#include <nlohmann/json.hpp>
#include <set>

#include "protocol/messages.h"

namespace holofuse::protocol {

StatusOr<Budget> loadBudget(const std::string& path) {
  std::ifstream in(path);
  if (!in) return Status(StatusCode::kIoError, path + ": cannot be read");
  std::set<std::string> names = {"end_to_end"};
  std::string valid = "end_to_end";
  for (uint16_t stage : stagesInPipelineOrder()) {
    names.insert(stageName(stage));
    valid += ", " + stageName(stage);
  }
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    return Status(StatusCode::kMalformed, path + ": not JSON (" + e.what() + ")");
  }
  if (!j.is_object())
    return Status(StatusCode::kMalformed, path + ": expected an object of stage -> ms");
  Budget budget;
  for (const auto& [name, value] : j.items()) {
    if (names.count(name) == 0) {
      return Status(StatusCode::kMalformed,
                    path + ": unknown stage '" + name + "'; valid: " + valid);
    }
    if (!value.is_number() || !(value.get<double>() > 0)) {
      return Status(StatusCode::kMalformed,
                    path + ": budget of '" + name + "' must be a positive number of ms");
    }
    budget[name] = value.get<double>();
  }
  return budget;
}

StatusOr<Budget> loadBudgetFlag(const std::string& path) {
  if (path.empty()) return Budget{};
  auto loaded = loadBudget(path);
  if (!loaded.isOk())
    return Status(loaded.status().code(), "--budget: " + loaded.status().message());
  return loaded;
}

}  // namespace holofuse::protocol

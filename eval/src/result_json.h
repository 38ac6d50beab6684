// SceneResult to and from JSON: quality.json's per-scene object, and the
// sweep's point files (read back when a sweep resumes).
#pragma once

#include <nlohmann/json.hpp>

#include "eval/leave_one_out.h"

namespace holofuse::eval {

// A value that may not have been measured (negative in the structs) is
// null in JSON, and null or absent reads back as -1.
inline nlohmann::json measuredJson(double value) {
  return value >= 0 ? nlohmann::json(value) : nlohmann::json();
}
inline double measuredFromJson(const nlohmann::json& object, const char* key) {
  return object.contains(key) && object[key].is_number() ? object[key].get<double>() : -1.0;
}

nlohmann::json sceneResultJson(const SceneResult& scene);
SceneResult sceneResultFromJson(const std::string& name, const nlohmann::json& json);

}  // namespace holofuse::eval

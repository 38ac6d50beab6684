// SceneResult to and from JSON: quality.json's per-scene object, and the
// sweep's point files (read back when a sweep resumes).
#pragma once

#include <nlohmann/json.hpp>

#include "eval/leave_one_out.h"

namespace holofuse::eval {

nlohmann::json sceneResultJson(const SceneResult& scene);
SceneResult sceneResultFromJson(const std::string& name, const nlohmann::json& json);

}  // namespace holofuse::eval

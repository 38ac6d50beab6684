#include "render_client/blend_mode.h"

namespace holofuse::render {

std::optional<BlendMode> blendModeFromName(const std::string& name) {
  if (name == "normal") return BlendMode::kNormal;
  return std::nullopt;
}

std::string blendModeName(BlendMode mode) {
  switch (mode) {
    case BlendMode::kNormal: return "normal";
  }
  return "unknown";
}

std::vector<std::string> blendModeNames() { return {"normal"}; }

}  // namespace holofuse::render

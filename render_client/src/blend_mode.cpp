#include "render_client/blend_mode.h"

namespace holofuse::render {

std::optional<BlendMode> blendModeFromName(const std::string& name) {
  if (name == "normal") return BlendMode::kNormal;
  if (name == "holoportation") return BlendMode::kHoloportation;
  if (name == "montage4d") return BlendMode::kMontage4D;
  if (name == "fragment") return BlendMode::kFragment;
  if (name == "layered") return BlendMode::kLayered;
  return std::nullopt;
}

std::string blendModeName(BlendMode mode) {
  switch (mode) {
    case BlendMode::kNormal:
      return "normal";
    case BlendMode::kHoloportation:
      return "holoportation";
    case BlendMode::kMontage4D:
      return "montage4d";
    case BlendMode::kFragment:
      return "fragment";
    case BlendMode::kLayered:
      return "layered";
  }
  return "unknown";
}

std::vector<std::string> blendModeNames() {
  return {"normal", "holoportation", "montage4d", "fragment", "layered"};
}

}  // namespace holofuse::render

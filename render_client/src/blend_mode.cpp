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

std::vector<std::string> stylisationNames() { return {"none", "stipple"}; }

std::optional<Stylisation> stylisationFromName(const std::string& name) {
  if (name == "none") return Stylisation::kNone;
  if (name == "stipple") return Stylisation::kStipple;
  return std::nullopt;
}

std::string stylisationName(Stylisation stylisation) {
  return stylisation == Stylisation::kStipple ? "stipple" : "none";
}

std::vector<std::string> overlayNames() {
  return {"none", "cameras", "seams", "geodesics", "visibility"};
}

std::optional<Overlay> overlayFromName(const std::string& name) {
  const std::vector<std::string> names = overlayNames();
  for (size_t k = 0; k < names.size(); ++k) {
    if (names[k] == name) return static_cast<Overlay>(k);
  }
  return std::nullopt;
}

std::string overlayName(Overlay overlay) {
  const size_t k = static_cast<size_t>(overlay);
  return k < kOverlayCount ? overlayNames()[k] : "unknown";
}

}  // namespace holofuse::render

#include "eval/knobs.h"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "common/command_line.h"
#include "common/image_codec.h"
#include "scene/scene_library.h"

namespace holofuse::eval {
namespace {

// Parses a number in [lo, hi]; "" or an error naming the value.
std::string parseNumber(const std::string& text, double lo, double hi, double& out) {
  const char* end = text.data() + text.size();
  const auto [stop, error] = std::from_chars(text.data(), end, out);
  if (error != std::errc() || stop != end || text.empty() || !(out >= lo && out <= hi)) {
    char range[96];
    std::snprintf(range, sizeof(range), "a number in [%g, %g]", lo, hi);
    return "'" + text + "' is not " + range;
  }
  return "";
}

// The shortest text that reads back as v (every digit a --set value may
// have); a setting held as a float reads back as that float, so 0.15f is
// "0.15", not "0.150000006".
std::string formatNumber(double v) {
  const bool single = static_cast<double>(static_cast<float>(v)) == v;
  char buffer[40];
  for (int digits = 1; digits <= 17; ++digits) {
    std::snprintf(buffer, sizeof(buffer), "%.*g", digits, v);
    // (20 as "20", not "2e+01")
    const bool exponent =
        std::strchr(buffer, 'e') != nullptr && std::abs(v) >= 1e-4 && std::abs(v) < 1e15;
    const double back = std::strtod(buffer, nullptr);
    if (exponent) continue;
    if (back == v || (single && static_cast<float>(back) == static_cast<float>(v))) break;
  }
  return buffer;
}

Knob numberKnob(const std::string& name, const std::string& loop_flag, const std::string& meaning,
                double lo, double hi, bool integer, std::function<void(EvalOptions&, double)> set,
                std::function<double(const EvalOptions&)> get) {
  Knob knob;
  knob.name = name;
  knob.loop_flag = loop_flag;
  knob.meaning = meaning;
  knob.apply = [=](EvalOptions& options, const std::string& text) {
    double v = 0;
    std::string error = parseNumber(text, lo, hi, v);
    if (error.empty() && integer && v != std::floor(v))
      error = "'" + text + "' is not a whole number";
    if (error.empty()) set(options, v);
    return error;
  };
  knob.current = [=](const EvalOptions& options) { return formatNumber(get(options)); };
  return knob;
}

// A knob that is a flag of the live loop: its meaning and range are the
// flag's, so a value the sweep takes is one the loop takes.
Knob flagKnob(const std::string& name, const char* flag, bool integer,
              std::function<void(EvalOptions&, double)> set,
              std::function<double(const EvalOptions&)> get) {
  const SharedFlag& f = sharedFlag(flag);
  return numberKnob(name, flag, f.description, f.min, f.max, integer, std::move(set),
                    std::move(get));
}

Knob choiceKnob(const std::string& name, const char* flag,
                std::function<void(EvalOptions&, const std::string&)> set,
                std::function<std::string(const EvalOptions&)> get) {
  const SharedFlag& f = sharedFlag(flag);
  Knob knob;
  knob.name = name;
  knob.loop_flag = flag;
  knob.meaning = f.description;
  knob.apply = [choices = f.choices, set](EvalOptions& options,
                                          const std::string& text) -> std::string {
    if (std::find(choices.begin(), choices.end(), text) == choices.end()) {
      std::string names;
      for (const auto& c : choices) names += (names.empty() ? "" : ", ") + c;
      return "'" + text + "' is not one of " + names;
    }
    set(options, text);
    return "";
  };
  knob.current = std::move(get);
  return knob;
}

std::vector<Knob> makeKnobs() {
  std::vector<Knob> knobs;
  knobs.push_back(flagKnob(
      "voxel", "--voxel", false,
      [](EvalOptions& o, double v) {
        o.voxel_size = v;
        o.voxel_from_dataset = false;
      },
      [](const EvalOptions& o) { return o.voxel_size; }));
  knobs.push_back(flagKnob(
      "hull-error-mm", "--hull-error-mm", false,
      [](EvalOptions& o, double v) { o.hull_error_target = v / 1000.0; },
      [](const EvalOptions& o) { return 1000.0 * o.hull_error_target; }));
  knobs.push_back(flagKnob(
      "refine-voxels", "--refine-voxels", false,
      [](EvalOptions& o, double v) { o.refine_voxels = v; },
      [](const EvalOptions& o) { return o.refine_voxels; }));
  knobs.push_back(flagKnob(
      "k", "--geodesic-rings", true,
      [](EvalOptions& o, double v) { o.fields.geodesic_rings = static_cast<int>(v); },
      [](const EvalOptions& o) { return double(o.fields.geodesic_rings); }));
  knobs.push_back(flagKnob(
      "radius", "--geodesic-radius", false,
      [](EvalOptions& o, double v) { o.fields.geodesic_radius = static_cast<float>(v); },
      [](const EvalOptions& o) { return double(o.fields.geodesic_radius); }));
  knobs.push_back(flagKnob(
      "K", "--geodesic-passes", true,
      [](EvalOptions& o, double v) { o.fields.geodesic_iterations = static_cast<int>(v); },
      [](const EvalOptions& o) { return double(o.fields.geodesic_iterations); }));
  knobs.push_back(flagKnob(
      "alpha", "--alpha", false, [](EvalOptions& o, double v) { o.alpha = static_cast<float>(v); },
      [](const EvalOptions& o) { return double(o.alpha); }));
  knobs.push_back(flagKnob(
      "lambda", "--lambda", false, [](EvalOptions& o, double v) { o.lambda = v; },
      [](const EvalOptions& o) { return o.lambda; }));
  knobs.push_back(flagKnob(
      "beta", "--beta", false, [](EvalOptions& o, double v) { o.beta = static_cast<float>(v); },
      [](const EvalOptions& o) { return double(o.beta); }));
  knobs.push_back(flagKnob(
      "feather-width", "--feather-width", false,
      [](EvalOptions& o, double v) { o.feather_width_px = static_cast<float>(v); },
      [](const EvalOptions& o) { return double(o.feather_width_px); }));
  knobs.push_back(choiceKnob(
      "fragment-test", "--fragment-test",
      [](EvalOptions& o, const std::string& v) { o.fragment_test = v == "on"; },
      [](const EvalOptions& o) { return std::string(o.fragment_test ? "on" : "off"); }));
  // Leave-one-out needs a camera left to blend: 2 at least, where the
  // loop's --pods takes 1.
  knobs.push_back(numberKnob(
      "cameras", "--pods", "pods on the ring", 2, 16, true,
      [](EvalOptions& o, double v) { o.cameras = static_cast<int>(v); },
      [](const EvalOptions& o) { return double(camerasOf(o)); }));
  knobs.back().synthetic_only = true;
  knobs.push_back(flagKnob(
      "dilation", "--dilation", true,
      [](EvalOptions& o, double v) { o.fields.dilation_px = static_cast<int>(v); },
      [](const EvalOptions& o) { return double(o.fields.dilation_px); }));
  knobs.push_back(flagKnob(
      "delta", "--vote-delta", false,
      [](EvalOptions& o, double v) { o.fields.vote_delta = static_cast<float>(v); },
      [](const EvalOptions& o) { return double(o.fields.vote_delta); }));
  knobs.push_back(flagKnob(
      "draco-bits", "--draco-bits", true,
      [](EvalOptions& o, double v) { o.draco.position_bits = static_cast<int>(v); },
      [](const EvalOptions& o) { return double(o.draco.position_bits); }));
  knobs.push_back(flagKnob(
      "lz4-acceleration", "--lz4-acceleration", true,
      [](EvalOptions& o, double v) { o.lz4_acceleration = static_cast<int>(v); },
      [](const EvalOptions& o) { return double(o.lz4_acceleration); }));
  knobs.push_back(flagKnob(
      "lz4-hc-level", "--lz4-hc-level", true,
      [](EvalOptions& o, double v) { o.lz4_hc_level = static_cast<int>(v); },
      [](const EvalOptions& o) { return double(o.lz4_hc_level); }));
  knobs.push_back(flagKnob(
      "crop-margin", "--crop-margin", true,
      [](EvalOptions& o, double v) { o.crop_margin = static_cast<int>(v); },
      [](const EvalOptions& o) { return double(o.crop_margin); }));
  knobs.push_back(choiceKnob(
      "image-codec", "--image-codec",
      [](EvalOptions& o, const std::string& v) { o.image_codec = *imageCodecFromName(v); },
      [](const EvalOptions& o) { return imageCodecName(o.image_codec); }));
  knobs.push_back(choiceKnob(
      "vertex-precision", "--vertex-precision",
      [](EvalOptions& o, const std::string& v) { o.half_precision_vertices = v == "fp16"; },
      [](const EvalOptions& o) {
        return std::string(o.half_precision_vertices ? "fp16" : "fp32");
      }));
  Knob size;
  size.name = "size";
  size.loop_flag = "--size";
  size.meaning = "camera and output image size WxH";
  size.apply = [](EvalOptions& o, const std::string& v) -> std::string {
    return parseImageSize(v, o.width, o.height);
  };
  size.current = [](const EvalOptions& o) {
    return std::to_string(o.width) + "x" + std::to_string(o.height);
  };
  size.synthetic_only = true;
  knobs.push_back(size);
  return knobs;
}

}  // namespace

int camerasOf(const EvalOptions& o) {
  if (o.cameras != 0 || o.scenes.empty()) return o.cameras;
  const scene::ScenePreset* scene = scene::findScene(o.scenes.front());
  return scene != nullptr ? scene->cameras : 0;
}

const std::vector<Knob>& sweepKnobs() {
  static const std::vector<Knob> knobs = makeKnobs();
  return knobs;
}

const Knob* findKnob(const std::string& name) {
  for (const auto& knob : sweepKnobs()) {
    if (knob.name == name) return &knob;
  }
  return nullptr;
}

std::string knobNames() {
  std::string names;
  for (const auto& knob : sweepKnobs()) names += (names.empty() ? "" : ", ") + knob.name;
  return names;
}

KnobFlags::KnobFlags(CLI::App& app, const std::vector<std::string>& except) {
  for (const Knob& knob : sweepKnobs()) {
    if (std::find(except.begin(), except.end(), knob.name) != except.end()) continue;
    auto given = std::make_unique<Given>();
    given->knob = &knob;
    given->option = app.add_option(knob.loop_flag, given->value,
                                   knob.meaning + " (sweep knob " + knob.name + ")");
    flags_.push_back(std::move(given));
  }
}

std::string KnobFlags::apply(EvalOptions& options) const {
  for (const auto& given : flags_) {
    if (given->option->count() == 0) continue;
    if (const std::string error = given->knob->apply(options, given->value); !error.empty()) {
      return given->knob->loop_flag + ": " + error;
    }
  }
  return "";
}

}  // namespace holofuse::eval

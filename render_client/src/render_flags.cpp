#include "protocol/stage_budget.h"
#include "render_client/render_settings.h"

namespace holofuse::render {

const std::vector<Setting<RenderSettings>>& renderFlags() {
  using S = RenderSettings;
  static const std::vector<Setting<S>> flags = {
      numberSetting<S>("--alpha",
                       "exponent of the normal weight max(0, n . d_i) (normal, holoportation, "
                       "fragment, montage4d's fallback)",
                       0, 1000, [](S& s) -> float& { return s.blend.alpha; }),
      numberSetting<S>("--lambda", "montage4d: temporal rate per frame at 30 fps (eq. 5)", 0, 1,
                       [](S& s) -> double& { return s.blend.lambda; }),
      numberSetting<S>("--depth-tolerance", "occlusion test tolerance, metres", 0, 10,
                       [](S& s) -> float& { return s.blend.depth_tolerance; }),
      numberSetting<S>("--dilation",
                       "eps: depth discontinuities dilated by this many pixels (-1: paper's 4 px "
                       "at 2048 wide, scaled)",
                       -1, 64, [](S& s) -> int& { return s.blend.fields.dilation_px; }),
      numberSetting<S>("--vote-delta",
                       "majority vote: Lab distance / 100 under which two views agree (eq. 3; 0: "
                       "no vote, the default; paper 000: 0.15)",
                       0, 10, [](S& s) -> float& { return s.blend.fields.vote_delta; }),
      numberSetting<S>("--best-views",
                       "holoportation and montage4d: cameras each vertex blends, its largest "
                       "field weights (the blend's cost per pixel follows this, not the camera "
                       "count)",
                       1, HOLOFUSE_MAX_BEST_VIEWS,
                       [](S& s) -> int& { return s.blend.fields.best_views; }),
      numberSetting<S>("--geodesic-rings", "montage4d: k, the geodesic reach in triangle rings", 1,
                       kMaxGeodesicRings,
                       [](S& s) -> int& { return s.blend.fields.geodesic_rings; }),
      numberSetting<S>("--geodesic-passes", "montage4d: K, the geodesic Jacobi passes", 1, 200,
                       [](S& s) -> int& { return s.blend.fields.geodesic_iterations; }),
      numberSetting<S>(
          "--geodesic-radius",
          "montage4d: metres from a seam where gamma reaches 1 (0: k mean edge lengths)", 0, 1000,
          [](S& s) -> float& { return s.blend.fields.geodesic_radius; }),
      choiceSetting<S>(
          "--vertex-precision",
          "vertex positions and normals on the GPU: fp32, or fp16 in half the memory",
          {"fp32", "fp16"},
          [](S& s, const std::string& v) { s.half_precision_vertices = v == "fp16"; },
          [](const S& s) { return std::string(s.half_precision_vertices ? "fp16" : "fp32"); }),
      numberSetting<S>("--beta",
                       "exponent of the view weight: (d_k . d_v + 1) in fragment (paper 004 eq. "
                       "4), max(0, v . v_i) in montage4d (paper 000 eq. 4)",
                       0, 1000, [](S& s) -> float& { return s.blend.beta; }),
      numberSetting<S>("--feather-width",
                       "pixels over which a pod's weight ramps from its silhouette's edge to 1 "
                       "(paper 004's feather weight; 0: none)",
                       0, 1000, [](S& s) -> float& { return s.blend.feather_width_px; }),
      onOffSetting<S>("--fragment-test",
                      "holoportation and montage4d: also test each fragment against every pod's "
                      "depth map and mask and feather it (paper 004), on or off",
                      [](S& s) -> bool& { return s.blend.fragment_test; })};
  return flags;
}

namespace {

// "orbit", or "pod:N" with N a number: "" or what is wrong with view.
std::string checkViewName(const std::string& view) {
  const bool pod = view.rfind("pod:", 0) == 0 && view.size() > 4 &&
                   view.find_first_not_of("0123456789", 4) == std::string::npos;
  return view == "orbit" || pod ? "" : "'" + view + "': expected orbit or pod:N";
}

std::string checkBudgetFile(const std::string& path) {
  if (path.empty()) return "";
  const auto budget = protocol::loadBudget(path);
  return budget.isOk() ? "" : budget.status().message();
}

}  // namespace

const std::vector<Setting<ClientRunSettings>>& clientRunFlags() {
  using S = ClientRunSettings;
  static const std::vector<Setting<S>> flags = {
      choiceSetting<S>(
          "--mode", "blending mode", blendModeNames(),
          [](S& s, const std::string& name) { s.mode = *blendModeFromName(name); },
          [](const S& s) { return blendModeName(s.mode); }),
      textSetting<S>(
          "--view", "user camera: orbit, or pod:N to sit at pod camera N",
          [](S& s) -> std::string& { return s.view; }, checkViewName),
      numberSetting<S>("--frames-ahead",
                       "fused frames to ask the server for ahead of the one rendering (1.9); the "
                       "server fuses only what a client asked for. 0: ask for none and take "
                       "every frame it fuses. More than 2 where the link's round trip is long "
                       "against a frame",
                       0, 8, [](S& s) -> uint32_t& { return s.frames_ahead; }),
      choiceSetting<S>(
          "--overlap-render",
          "on: receive and decode the next frame while the device renders this one; off: wait "
          "for each render; auto: on with a GPU, off with a CPU device",
          {"auto", "on", "off"}, [](S& s, const std::string& text) { s.overlap_render = text; },
          [](const S& s) { return s.overlap_render; }),
      onOffSetting<S>(
          "--window",
          "on: show the pictures in a window as well: 0-9 the orbit or a pod's camera, M "
          "the next mode, F the next overlay, C its pod, P the live panel, T stippling, L "
          "relighting, S a screenshot, mouse drag/wheel orbit, pan, zoom; Escape or "
          "Q closes it and ends the client. Without a display: one line, headless",
          [](S& s) -> bool& { return s.window; }),
      choiceSetting<S>(
          "--overlay",
          "drawn over the blend: cameras (each pod's weight as its colour), seams, geodesics "
          "(distance from the seams) or visibility of the --overlay-pod; the window's F key "
          "steps through them",
          overlayNames(), [](S& s, const std::string& name) { s.overlay = *overlayFromName(name); },
          [](const S& s) { return overlayName(s.overlay); }),
      choiceSetting<S>(
          "--stylise",
          "a pass over the final picture (paper 000, section 6): stipple, sketchy "
          "stippling; the window's T key steps through them",
          stylisationNames(),
          [](S& s, const std::string& name) { s.stylisation = *stylisationFromName(name); },
          [](const S& s) { return stylisationName(s.stylisation); }),
      textSetting<S>("--light-probe",
                     "relight by this equirectangular environment map (EXR, HDR, PNG; paper 000, "
                     "section 6.2): lighter where its light is above 50% grey, darker below; the "
                     "window's L key turns it off and on",
                     [](S& s) -> std::string& { return s.light_probe; }),
      numberSetting<S>("--overlay-pod",
                       "the pod whose seams, geodesics or visibility the overlay shows (the "
                       "window's C key steps through the pods)",
                       0, HOLOFUSE_MAX_CAMERAS - 1,
                       [](S& s) -> uint32_t& { return s.overlay_pod; }),
      textSetting<S>("--record-layers",
                     "with --mode layered and the server's --layer-video h264, hevc or av1: "
                     "write each texture layer's video as received into this folder, as files "
                     "ffprobe reads and a player plays (layer<L>_part<N>.ts, .ivf for AV1; a "
                     "part begins at a key frame; the demo's several clients: DIR/client<N>)",
                     [](S& s) -> std::string& { return s.record_layers; }),
      textSetting<S>("--device", "Vulkan device: index or part of its name (default: a GPU if any)",
                     [](S& s) -> std::string& { return s.device; }),
      textSetting<S>(
          "--budget",
          "JSON of per-stage ms budgets (stage names of report.json, end_to_end); "
          "each stage's p95 over its budget is flagged in the reports",
          [](S& s) -> std::string& { return s.budget; }, checkBudgetFile),
  };
  return flags;
}

}  // namespace holofuse::render

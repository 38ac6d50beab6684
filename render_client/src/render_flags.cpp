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

}  // namespace holofuse::render

// How the client renders: the blend mode and its parameters, the texture-
// field passes' parameters and the flags that set them. Plain data, no
// Vulkan: the launcher, eval and the sweep embed and forward these without
// linking the renderer.
#pragma once

#include <array>
#include <glm/glm.hpp>
#include <string>
#include <vector>

#include "config/settings.h"
#include "render_client/blend_mode.h"
#include "shaders/config.h"

namespace holofuse::render {

// The largest geodesic reach in rings (k) the packed ring field holds.
constexpr int kMaxGeodesicRings = 64;
static_assert(kMaxGeodesicRings < static_cast<int>(HOLOFUSE_NO_RING));

struct FieldParameters {
  float relative_jump = 0.03f;  // discontinuity: relative depth step
  int dilation_px = -1;         // discontinuity: eps; -1: paper 000's 4 px at 2048 wide, scaled
                                // (reference::scaledDilationPx)
  float relative_depth_tolerance = 0.015f;
  // The majority vote's delta; 0: no vote, every visible view trusted.
  // Paper 000's vote (delta = 0.15) rejects a view whose colour disagrees;
  // on a visual hull every view disagrees somewhat, the hull lying off the
  // surface, and the vote cost the temple 0.7-0.9 dB while gaining no
  // synthetic scene more than 0.1 (docs/blending.md).
  float vote_delta = 0.0f;
  int vote_levels = 3;
  float alpha = 2.0f;
  // The views each vertex keeps for the blend (1 to HOLOFUSE_MAX_BEST_VIEWS):
  // its largest field weights, renormalised where any is left out. The
  // blend's cost per fragment grows with this, not with the camera count.
  int best_views = 8;
  // Seams, the global visibility and the geodesic distance from the seams
  // (docs/design.md section 6, steps 5 to 7): run only when a mode needs them (montage4d); the
  // Holoportation baseline does not pay for them.
  bool geodesics = false;
  // montage4d: the field depends on the view, and recordMontage computes it
  // for every rendered view in place of the per-mesh field pass ("field").
  bool field_per_view = false;
  int geodesic_rings = 15;       // k
  int geodesic_iterations = 20;  // K
  // Metres from a seam at which gamma reaches 1, and beyond which no
  // distance is computed (0: k mean edge lengths, distance unbounded).
  // Paper 000's k = 15 triangles on its ~4 mm-edge captures is about 6 cm;
  // a fixed length keeps that reach on coarser meshes, where 15 rings would
  // span a whole limb and the fields would sum below 1 almost everywhere.
  float geodesic_radius = 0.06f;
  // Measurement only (bench_texture_fields): record the per-mesh passes up
  // to this stage of stageNames() and skip the rest (-1: all). Wall clock
  // differences between stops give each stage's cost where a CPU device's
  // timestamps cannot (it rasterises lazily). A stop before stage 6 ("field") skips
  // montage4d's per-view field as well.
  int last_stage = -1;
  // Measurement only: record the dispatches of stage repeated_stage (1 to
  // 6 of stageNames(); 6 in montage4d is its per-view field pass)
  // stage_repeats times over. Stages that cost a
  // fraction of a millisecond drown in a shared machine's noise once; the
  // extra time of many repeats, divided by their number, does not. The
  // global visibility counts come out multiplied: timing runs only.
  int repeated_stage = -1;
  int stage_repeats = 1;
  bool operator==(const FieldParameters&) const = default;
};

struct BlendSettings {
  BlendMode mode = BlendMode::kNormal;
  float alpha = 2.0f;                      // exponent of the normal weight
  float depth_tolerance = 0.03f;           // metres behind the depth map still visible
  glm::vec3 hole_color{0.5f, 0.5f, 0.5f};  // surface that no camera sees
  std::vector<bool> camera_enabled;        // empty: all cameras take part
  FieldParameters fields;                  // texture-field passes (holoportation, montage4d)
  double lambda = 0.05;                    // montage4d: temporal rate at 30 fps (eq. 5)
  double frame_interval_s = 1.0 / 30.0;    // montage4d: real time since the previous rendered frame
  // The per-fragment test of paper 004 (Li, Magnor, Seidel 2004, section
  // 4.4): mode fragment always takes it; the field modes multiply their
  // interpolated weights by it when fragment_test is set. A fragment is
  // visible to a pod when it lies inside its mask and within
  // fields.relative_depth_tolerance of the depth plus the mesh's mean edge
  // (Renderer::fragmentDepthSlack) of the pod's depth map; its feather
  // weight is min(1, the pod's feather map / feather_width_px) (0: none).
  float feather_width_px = 8.0f;
  bool fragment_test = false;
  // Exponent of the view weight: (d_k . d_v + 1) in mode fragment (paper
  // 004 eq. 4, its 5) and max(0, v . v_i) in montage4d's target field.
  float beta = 5.0f;
  // An overlay (the viewer's F key, render_client --overlay), Overlay below.
  Overlay overlay = Overlay::kNone;
  // The pod whose seams, geodesic distances or visibility the overlay
  // shows (the viewer's C key); a pod not in the arrays shows none.
  uint32_t overlay_pod = 0;
  // A screen-space pass over the final picture (Stylisation above).
  Stylisation stylisation = Stylisation::kNone;
  // Relighting (paper 000, section 6.2): each fragment's colour blended
  // with a light probe's light along its view-space normal (eqs. 6 to 8);
  // the probe's spherical harmonics, bands 0 to 2, red, green, blue
  // (render_client/light_probe.h's LightProbe::coefficients).
  bool relight = false;
  std::array<glm::vec3, 9> light_probe{};
};

// The client's rendering settings, which eval and the launcher embed.
struct RenderSettings {
  BlendSettings blend;
  bool half_precision_vertices = false;  // Renderer::setHalfPrecisionVertices
};

// The client's flags of RenderSettings (config/settings.h); eval and the
// launcher take the same. The mode is not among them: eval and the sweep
// run several.
const std::vector<Setting<RenderSettings>>& renderFlags();

// How a client session runs, beside how it renders: the mode it blends
// with, where the user's camera sits, how far ahead it asks for frames,
// whether decoding overlaps the render, the Vulkan device and the stage
// budget. The client, the launcher (which forwards them), eval and the
// sweep (--device, --budget) all bind them from clientRunFlags().
struct ClientRunSettings {
  BlendMode mode = BlendMode::kNormal;
  std::string view = "orbit";  // "orbit", or "pod:N" to sit at pod camera N
  // Fused frames asked for ahead of the one rendering (protocol 1.9
  // FrameRequest; a server fuses no group no client asked for). 0: ask for
  // none, take every frame the server fuses. 2, not 1: asked for one at a
  // time, a mesh is fused from a group held since the client's last ask
  // (up to a pod interval old) and then waits for the render in hand.
  uint32_t frames_ahead = 2;
  // "on": the next frame is received and decoded while the device renders
  // this one; "off": each render is waited for; "auto": on a GPU only (a
  // CPU device renders on the cores the decode would take).
  std::string overlap_render = "auto";
  std::string device;                // Vulkan device selector (VulkanContext); "": a GPU if any
  std::string budget;                // a JSON file of per-stage ms budgets; "": none
  bool window = false;               // the pictures shown in a window too (viewer_window.h)
  Overlay overlay = Overlay::kNone;  // BlendSettings::overlay at the start (the window's F key)
  uint32_t overlay_pod = 0;          // BlendSettings::overlay_pod at the start (C)
  Stylisation stylisation = Stylisation::kNone;  // BlendSettings::stylisation at the start (T)
  // An equirectangular environment map to relight by (BlendSettings::
  // relight; the window's L key turns it off and on); "": none.
  std::string light_probe;
  // A folder for each texture layer's video as received, as files a player
  // opens (codec/layer_video_file.h); "": none.
  std::string record_layers;
};

const std::vector<Setting<ClientRunSettings>>& clientRunFlags();

}  // namespace holofuse::render

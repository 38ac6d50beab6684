// CPU reference of texture-field stages 8 to 10 (docs/design.md section 6):
// target fields (paper 000 eq. 2 for the Holoportation baseline, eq. 4 for
// Montage4D), the temporal field (eq. 5) with lambda rescaled by the real
// frame interval, and normalisation with the normal-weighted fallback.
// Fields are indexed [camera][vertex]. Every output is finite and in [0, 1].
#pragma once

#include <cstdint>
#include <glm/glm.hpp>
#include <vector>

#include "geometry/camera.h"
#include "geometry/mesh.h"

namespace holofuse::render::reference {

using Field = std::vector<std::vector<double>>;

// max(0, x)^alpha that is 0 for NaN and never produces NaN or Inf.
double clampedPower(double x, double alpha);

// Eq. 2: T = V * max(0, n . d_i)^alpha, d_i the unit direction from the
// vertex to camera i's centre.
Field holoportationField(const Mesh& mesh, const std::vector<Camera>& cameras,
                         const std::vector<std::vector<uint8_t>>& visible, double alpha);

// Eq. 4: T = V * g^i * gamma * max(0, v . v_i)^beta, v the unit direction
// from the user's eye to the vertex, v_i from camera i's centre to it. (The
// paper's exponent is named alpha; here it is the view weight's exponent,
// beta, as in mode fragment: BlendSettings::beta.)
Field montageTargetField(const Mesh& mesh, const std::vector<Camera>& cameras,
                         const std::vector<std::vector<uint8_t>>& visible,
                         const std::vector<double>& global_visibility, const Field& geodesic,
                         const glm::dvec3& user_eye, double beta);

// The per-frame lambda for a frame interval of dt seconds, so that the
// field decays by as much per second as lambda_reference does per frame at
// reference_fps: 1 - (1 - lambda_reference)^(dt * reference_fps).
double temporalLambda(double lambda_reference, double dt_seconds, double reference_fps = 30.0);

// Eq. 5 in place, F = (1 - lambda) F + lambda T, among the cameras that see
// each vertex now (visible[i][v]; empty: every camera). A camera that no
// longer sees a vertex leaves its field at once: eq. 5 smooths how the
// weights follow the view, but a carried weight for a camera now occluded
// would sample the occluder (on a moving subject that cost montage4d
// 0.1-0.25 dB against holoportation). When it sees the vertex again it
// fades in from 0.
void temporalUpdate(Field& temporal, const Field& target, double lambda,
                    const std::vector<std::vector<uint8_t>>& visible = {});

struct BlendWeights {
  Field weight;                   // normalised per vertex: sums to 1 where not a hole
  std::vector<uint8_t> hole;      // 1 where no camera contributes
  std::vector<uint8_t> fallback;  // 1 where the normal-weighted field was used
};

// Step 10: normalise the temporal field per vertex; where the geodesic
// fields sum below 1 (highly occluded regions) use the normalised
// normal-weighted field instead; where that is zero too, the vertex is a
// hole. A camera's distances reach only the vertices it sees: elsewhere its
// gamma is 1, as far from its seams.
BlendWeights normalizeFields(const Field& temporal, const Field& geodesic,
                             const Field& normal_weighted);

// The blend's best views (shaders/compute_common.glsl keepBestViews): at
// each vertex the `count` largest weights of `weights` ([camera][vertex]),
// equal weights kept in camera order, the rest 0; a vertex that lost any
// weight has the kept ones renormalised to their sum, one that lost none
// keeps them as they were.
Field keepBestViews(const Field& weights, int count);

}  // namespace holofuse::render::reference

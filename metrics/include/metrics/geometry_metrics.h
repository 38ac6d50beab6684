// How far a reconstructed surface is from the truth: the symmetric Chamfer
// distance between two meshes, vertices to surface, and how well its
// silhouette covers a camera's true mask (intersection over union).
#pragma once

#include <vector>

#include "geometry/camera.h"
#include "geometry/mesh.h"
#include "image/image.h"

namespace holofuse::metrics {

// Mean of (mean distance from a's vertices to b's surface) and (b's
// vertices to a's), metres; +infinity when either mesh has no vertices. The
// surface is the triangles (nearest point on any), or the vertices of a
// mesh without triangles. To the surface rather than its vertices, so a
// hull finer than the truth's 1 cm sampling is not held at the sampling's
// spacing.
double chamferDistance(const Mesh& a, const Mesh& b);

// The mesh rasterised from the camera against the mask (non-zero = subject).
double silhouetteIoU(const Mesh& mesh, const Camera& camera, const Image8& mask);

}  // namespace holofuse::metrics

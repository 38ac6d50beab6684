// How far a reconstructed surface is from the truth: the symmetric Chamfer
// distance between two meshes' vertices, and how well its silhouette covers
// a camera's true mask (intersection over union).
#pragma once

#include <vector>

#include "common/camera.h"
#include "common/image.h"
#include "common/mesh.h"

namespace holofuse::eval {

// Mean of (mean nearest distance from a's vertices to b's) and (b's to a's),
// metres; +infinity when either mesh has no vertices. Dense vertex sets
// (marching cubes at the voxel size) make this the usual surface Chamfer.
double chamferDistance(const Mesh& a, const Mesh& b);

// The mesh rasterised from the camera against the mask (non-zero = subject).
double silhouetteIoU(const Mesh& mesh, const Camera& camera, const Image8& mask);

}  // namespace holofuse::eval

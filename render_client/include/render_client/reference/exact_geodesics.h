// Exact polyhedral geodesic distance, the yardstick for the approximate
// geodesics of stage 6 (render::reference::approximateGeodesic and its GPU
// twin).
//
// Why it is exact (Mitchell, Mount and Papadimitriou 1987, section 3): on a
// triangle mesh a shortest path is straight inside every face it crosses,
// straight across every edge once the two faces are unfolded into one
// plane, and bends only at saddle vertices (angle sum above 2 pi) or
// boundary vertices. So:
//  - from a point, a beam (a wedge of straight rays in the unfolded plane)
//    carried face by face and split at every vertex it meets, reaches each
//    vertex by every straight unfolded line there is;
//  - a Dijkstra search over the sources and the bend vertices, each one
//    casting its beams when it is settled, finds the shortest chain of such
//    straight pieces.
// Unlike the window methods (Surazhsky et al. 2005) nothing is trimmed or
// merged, so there is no approximation to argue about; the price is time,
// which the distance bound keeps small on test meshes.
#pragma once

#include <cstdint>
#include <vector>

#include "geometry/mesh.h"

namespace holofuse::render::reference {

// Distance over the surface from the nearest source vertex to every vertex,
// +infinity beyond max_distance (and where the surface does not connect).
// Edges with more than two triangles are treated as boundaries.
std::vector<double> exactGeodesic(const Mesh& mesh, const std::vector<uint8_t>& is_source,
                                  double max_distance);

// Vertices where a shortest path may bend: angle sum above 2 pi, or on a
// boundary.
std::vector<uint8_t> bendVertices(const Mesh& mesh);

}  // namespace holofuse::render::reference

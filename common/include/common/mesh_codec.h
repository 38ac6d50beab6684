// Mesh to and from Draco bytes. Draco is lossless unless asked, so the
// quantisation is always set explicitly (PLATFORM.md).
#pragma once

#include <cstdint>
#include <vector>

#include "base/status.h"
#include "common/mesh.h"

namespace holofuse {

struct DracoOptions {
  int position_bits = 11;
  int normal_bits = 8;
  int uv_bits = 16;  // texture coordinates of an atlas: 1/65536 of its side
  int speed = 7;     // Draco's encoding/decoding speed, 0 (smallest) .. 10 (fastest)
};

StatusOr<std::vector<uint8_t>> encodeDraco(const Mesh& mesh, const DracoOptions& options = {});

// What a Draco mesh says it holds, read from its header and connectivity
// header (Draco bitstream 2.2) before anything is decoded.
struct DracoCounts {
  uint32_t vertices = 0;  // encoded vertices (edgebreaker) or points (sequential)
  uint32_t faces = 0;
};
StatusOr<DracoCounts> readDracoCounts(const uint8_t* data, size_t size);

// Caps checked against readDracoCounts before Draco allocates anything
// (SECURITY.md). A decoded mesh has at most 3 points a face.
struct DracoLimits {
  uint32_t max_vertices = 1u << 21;
  uint32_t max_faces = 1u << 22;
};

// Decodes untrusted Draco bytes: the counts are capped first, then the
// result is validated (indices in range, finite positions) and normals are
// recomputed when absent.
StatusOr<Mesh> decodeDraco(const uint8_t* data, size_t size, const DracoLimits& limits = {});

}  // namespace holofuse

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
  int speed = 7;  // Draco's encoding/decoding speed, 0 (smallest) .. 10 (fastest)
};

StatusOr<std::vector<uint8_t>> encodeDraco(const Mesh& mesh, const DracoOptions& options = {});

// Decodes untrusted Draco bytes; the result is validated (indices in range,
// finite positions) and normals are recomputed when absent.
StatusOr<Mesh> decodeDraco(const uint8_t* data, size_t size);

}  // namespace holofuse

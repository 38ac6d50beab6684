// Half floats through LZ4: the open Holoportation stack's mesh coding
// (layout in codec/mesh_codec.h).
#include <lz4.h>
#include <meshoptimizer.h>

#include <algorithm>
#include <cmath>
#include <glm/gtc/packing.hpp>
#include <string>

#include "codec/mesh_codec.h"
#include "protocol/wire.h"

namespace holofuse {

namespace {

constexpr char kMagic[4] = {'H', 'F', '1', '6'};
constexpr uint8_t kVersion = 1;
constexpr uint8_t kNormals = 1, kKeys = 2, kUvs = 4;
constexpr size_t kHeaderBytes = 32;
// LZ4 expands a block by at most 255 to 1 (each byte of a match length
// extension adds 255 bytes).
constexpr uint64_t kMostExpansion = 255;

struct Header {
  uint8_t flags = 0;
  uint32_t vertices = 0, faces = 0;
  glm::vec3 centre{0.0f};
  uint32_t raw_size = 0;
};

uint64_t rawSize(uint8_t flags, uint64_t vertices, uint64_t faces) {
  return vertices * 6 + ((flags & kNormals) ? vertices * 6 : 0) +
         ((flags & kKeys) ? vertices * 8 : 0) + faces * 12 + ((flags & kUvs) ? faces * 12 : 0);
}

Status malformed(const std::string& what) {
  return Status(StatusCode::kMalformed, "fp16-lz4 mesh: " + what);
}

StatusOr<Header> readHeader(const uint8_t* data, size_t size) {
  if (size < kHeaderBytes) {
    return Status(StatusCode::kTruncated, "fp16-lz4 mesh: " + std::to_string(size) +
                                              " bytes, shorter than its " +
                                              std::to_string(kHeaderBytes) + "-byte header");
  }
  // Every read below lies inside the header's 32 bytes.
  protocol::WireReader in(std::span<const uint8_t>(data, kHeaderBytes));
  const auto magic = in.raw("the magic", 4);
  if (!std::equal(magic.begin(), magic.end(), kMagic))
    return Status(StatusCode::kBadMagic, "fp16-lz4 mesh: no HF16 magic");
  if (const uint8_t version = in.u8("the version"); version != kVersion) {
    return Status(StatusCode::kUnsupportedVersion,
                  "fp16-lz4 mesh: version " + std::to_string(version) + ", not 1");
  }
  Header h;
  h.flags = in.u8("the flags");
  if ((h.flags & ~(kNormals | kKeys | kUvs)) != 0)
    return malformed("unknown flags " + std::to_string(h.flags));
  in.u16("the padding");
  h.vertices = in.u32("the vertex count");
  h.faces = in.u32("the face count");
  for (int k = 0; k < 3; ++k) h.centre[k] = in.f32("the centre");
  h.raw_size = in.u32("the raw size");
  if (!std::isfinite(h.centre.x) || !std::isfinite(h.centre.y) || !std::isfinite(h.centre.z))
    return malformed("its centre is not finite");
  return h;
}

// The mesh in an order a GPU's post-transform vertex cache reuses well:
// triangles by meshoptimizer's FIFO cache optimisation (a 16-entry cache;
// its full optimiser took 3.5 ms at 8k vertices, this 0.8), vertices in
// the order the triangles first use them. Draco's edgebreaker traverses
// the surface and so orders it well; in marching cubes' cell order the
// render took 56.6 ms against Draco's 47.2 in one bench loop (mode
// normal, lavapipe), in this order 52.1 against 48.5. With an atlas's
// corner coordinates, which follow the triangles, only the vertices move.
Mesh inCacheOrder(const Mesh& mesh) {
  const size_t n = mesh.vertexCount();
  Mesh ordered = mesh;
  // Indices past the vertices are the decoder's to refuse; nothing to order.
  for (uint32_t index : mesh.indices)
    if (index >= n) return ordered;
  if (mesh.corner_uvs.empty()) {
    meshopt_optimizeVertexCacheFifo(ordered.indices.data(), mesh.indices.data(),
                                    mesh.indices.size(), n, 16);
  }
  std::vector<uint32_t> remap(n);
  if (meshopt_optimizeVertexFetchRemap(remap.data(), ordered.indices.data(), ordered.indices.size(),
                                       n) != n) {
    return ordered;  // a vertex no triangle uses: the vertices stay as they are
  }
  for (uint32_t& index : ordered.indices) index = remap[index];
  for (size_t v = 0; v < n; ++v) {
    ordered.positions[remap[v]] = mesh.positions[v];
    if (ordered.normals.size() == n) ordered.normals[remap[v]] = mesh.normals[v];
    if (ordered.vertex_keys.size() == n) ordered.vertex_keys[remap[v]] = mesh.vertex_keys[v];
  }
  return ordered;
}

}  // namespace

StatusOr<std::vector<uint8_t>> encodeFp16Lz4(const Mesh& unordered, bool with_normals) {
  const Mesh mesh = inCacheOrder(unordered);
  const size_t n = mesh.vertexCount(), faces = mesh.triangleCount();
  const bool normals = with_normals && mesh.normals.size() == n && n > 0;
  const bool keys = mesh.vertex_keys.size() == n && n > 0;
  const bool uvs = !mesh.corner_uvs.empty();
  if (uvs && mesh.corner_uvs.size() != faces * 3)
    return malformed("corner coordinates not 3 a face");
  const uint8_t flags = (normals ? kNormals : 0) | (keys ? kKeys : 0) | (uvs ? kUvs : 0);
  const uint64_t raw_size = rawSize(flags, n, faces);
  if (raw_size > static_cast<uint64_t>(LZ4_MAX_INPUT_SIZE))
    return Status(StatusCode::kTooLarge,
                  "fp16-lz4 mesh: " + std::to_string(raw_size) + " bytes raw, past LZ4's block");
  const Bounds bounds = meshBounds(mesh);
  const glm::vec3 centre = n > 0 ? 0.5f * (bounds.min + bounds.max) : glm::vec3(0.0f);
  std::vector<uint8_t> raw;
  raw.reserve(raw_size);
  protocol::WireWriter body(raw);
  std::vector<uint16_t> halves(3 * n);
  for (size_t v = 0; v < n; ++v)
    for (int k = 0; k < 3; ++k)
      halves[3 * v + k] = glm::packHalf1x16(mesh.positions[v][k] - centre[k]);
  body.array<uint16_t>(halves);
  if (normals) {
    for (size_t v = 0; v < n; ++v)
      for (int k = 0; k < 3; ++k) halves[3 * v + k] = glm::packHalf1x16(mesh.normals[v][k]);
    body.array<uint16_t>(halves);
  }
  if (keys) body.array<uint64_t>(mesh.vertex_keys);
  body.array<uint32_t>(mesh.indices);
  if (uvs) {
    std::vector<uint16_t> coordinates(2 * mesh.corner_uvs.size());
    for (size_t c = 0; c < mesh.corner_uvs.size(); ++c)
      for (int k = 0; k < 2; ++k)
        coordinates[2 * c + k] = static_cast<uint16_t>(
            std::lround(std::clamp(mesh.corner_uvs[c][k], 0.0f, 1.0f) * 65535.0f));
    body.array<uint16_t>(coordinates);
  }
  std::vector<uint8_t> out;
  out.reserve(kHeaderBytes + LZ4_compressBound(static_cast<int>(raw.size())));
  protocol::WireWriter header(out);
  header.raw(std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(kMagic), 4));
  header.u8(kVersion);
  header.u8(flags);
  header.u16(0);
  header.u32(static_cast<uint32_t>(n));
  header.u32(static_cast<uint32_t>(faces));
  for (int k = 0; k < 3; ++k) header.f32(centre[k]);
  header.u32(static_cast<uint32_t>(raw.size()));
  const size_t at = out.size();
  out.resize(at + LZ4_compressBound(static_cast<int>(raw.size())));
  const int packed = LZ4_compress_default(
      reinterpret_cast<const char*>(raw.data()), reinterpret_cast<char*>(out.data() + at),
      static_cast<int>(raw.size()), static_cast<int>(out.size() - at));
  if (packed <= 0 && !raw.empty())
    return Status(StatusCode::kIoError, "fp16-lz4 mesh: LZ4 could not compress it");
  out.resize(at + static_cast<size_t>(std::max(packed, 0)));
  return out;
}

StatusOr<DracoCounts> readFp16Lz4Counts(const uint8_t* data, size_t size) {
  auto header = readHeader(data, size);
  if (!header.isOk()) return header.status();
  return DracoCounts{header->vertices, header->faces};
}

StatusOr<Mesh> decodeFp16Lz4(const uint8_t* data, size_t size, const DracoLimits& limits) {
  auto header = readHeader(data, size);
  if (!header.isOk()) return header.status();
  const Header& h = *header;
  if (h.vertices > limits.max_vertices || h.faces > limits.max_faces) {
    return Status(StatusCode::kTooLarge, "fp16-lz4 mesh: " + std::to_string(h.vertices) +
                                             " vertices and " + std::to_string(h.faces) +
                                             " faces, above the caps of " +
                                             std::to_string(limits.max_vertices) + " and " +
                                             std::to_string(limits.max_faces));
  }
  const uint64_t expected = rawSize(h.flags, h.vertices, h.faces);
  if (h.raw_size != expected) {
    return malformed("states " + std::to_string(h.raw_size) + " raw bytes where its counts make " +
                     std::to_string(expected));
  }
  const size_t payload = size - kHeaderBytes;
  if (expected > payload * kMostExpansion + 16) {
    return malformed(std::to_string(payload) + " bytes of LZ4 cannot hold " +
                     std::to_string(expected) + " raw bytes");
  }
  std::vector<uint8_t> raw(expected);
  if (expected > 0) {
    const int got = LZ4_decompress_safe(reinterpret_cast<const char*>(data + kHeaderBytes),
                                        reinterpret_cast<char*>(raw.data()),
                                        static_cast<int>(payload), static_cast<int>(expected));
    if (got != static_cast<int>(expected)) {
      return malformed(got < 0 ? std::string("corrupt LZ4 block")
                               : "LZ4 gave " + std::to_string(got) + " of " +
                                     std::to_string(expected) + " raw bytes");
    }
  }
  // raw holds exactly what the counts make (LZ4 gave every byte), so no
  // read below can fail; the cursor checks each anyway.
  protocol::WireReader in(raw);
  Mesh mesh;
  std::vector<uint16_t> halves(3 * static_cast<size_t>(h.vertices));
  in.array<uint16_t>("the positions", halves);
  mesh.positions.resize(h.vertices);
  for (uint32_t v = 0; v < h.vertices; ++v) {
    for (int k = 0; k < 3; ++k) mesh.positions[v][k] = glm::unpackHalf1x16(halves[3 * v + k]);
    if (!std::isfinite(mesh.positions[v].x) || !std::isfinite(mesh.positions[v].y) ||
        !std::isfinite(mesh.positions[v].z)) {
      return malformed("vertex " + std::to_string(v) + " is not finite");
    }
    mesh.positions[v] += h.centre;
  }
  if (h.flags & kNormals) {
    in.array<uint16_t>("the normals", halves);
    mesh.normals.resize(h.vertices);
    for (uint32_t v = 0; v < h.vertices; ++v) {
      glm::vec3& normal = mesh.normals[v];
      for (int k = 0; k < 3; ++k) normal[k] = glm::unpackHalf1x16(halves[3 * v + k]);
      const float length = glm::length(normal);
      normal = (std::isfinite(length) && length > 0) ? normal / length : glm::vec3(0.0f);
    }
  }
  if (h.flags & kKeys) {
    mesh.vertex_keys.resize(h.vertices);
    in.array<uint64_t>("the vertex keys", mesh.vertex_keys);
  }
  mesh.indices.resize(static_cast<size_t>(h.faces) * 3);
  in.array<uint32_t>("the indices", mesh.indices);
  for (size_t i = 0; i < mesh.indices.size(); ++i) {
    if (mesh.indices[i] >= h.vertices) {
      return malformed("face " + std::to_string(i / 3) + " index " +
                       std::to_string(mesh.indices[i]) + " out of range");
    }
  }
  if (h.flags & kUvs) {
    std::vector<uint16_t> coordinates(2 * mesh.indices.size());
    in.array<uint16_t>("the corner coordinates", coordinates);
    mesh.corner_uvs.resize(mesh.indices.size());
    for (size_t c = 0; c < mesh.corner_uvs.size(); ++c)
      for (int k = 0; k < 2; ++k)
        mesh.corner_uvs[c][k] = static_cast<float>(coordinates[2 * c + k]) / 65535.0f;
  }
  if (!in.ok()) return malformed(in.status().message());
  if (!(h.flags & kNormals)) computeVertexNormals(mesh);
  return mesh;
}

}  // namespace holofuse

// Mesh to and from Draco bytes. Draco is lossless unless asked, so the
// quantisation is always set explicitly (PLATFORM.md).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "base/status.h"
#include "geometry/mesh.h"
#include "protocol/messages.h"

namespace holofuse {

struct DracoOptions {
  int position_bits = 11;
  int normal_bits = 8;
  int uv_bits = 16;  // texture coordinates of an atlas: 1/65536 of its side
  // Draco's encoding/decoding speed, 0 (smallest) .. 10 (fastest). Below
  // 5 Draco codes the connectivity by valence and predicts from several
  // parallelograms: bench_mesh_codec's hulls (keys and places) at 20 mm
  // 12.2 KB at 7, 6 and 5, 9.5 at 3, 9.6 at 0; at 10 mm 44.6 -> 32.7 KB
  // at 3; encoding within noise of 7's, decoding about a tenth slower.
  int speed = 3;
  // Normals go out only when asked. The hull's are computeVertexNormals of
  // its positions, which every decoder recomputes from the decoded ones
  // when absent; sent, they were 11.4 of bench_mesh_codec's 37.9 KB a hull.
  bool normals = false;
  // The key lattice's x and y sides (hull::keyLattice) where the mesh's
  // vertex keys lie on it: each key then goes out as the middle of its
  // edge in half-lattice steps, three small integers that Draco predicts
  // from the neighbours like positions (protocol 1.11; bench_mesh_codec's
  // hulls at 20 mm: 26.5 -> 18.9 KB), the sides in the mesh's metadata.
  // 0: a key as its two 32-bit halves, as before 1.11.
  std::array<uint64_t, 2> key_lattice{0, 0};
  // Positions from the keys (protocol 1.13): the hull's marching cubes puts
  // each vertex on the lattice edge its key names, so with key_lattice and
  // edge_spacing set, and every vertex on its edge, a vertex goes out as its
  // key (the POSITION attribute, the half steps above) and its place along
  // the edge in edge_bits bits, a step of edge_spacing / 2^edge_bits; the
  // lattice's first point (edge_origin) and spacing in the metadata. Any
  // vertex off its edge (a refined mesh), or edge_spacing 0: coordinates.
  // 5 bits: a step of 0.6 mm at 20 mm voxels, finer than 11 bits over a
  // standing person's 1.8 m (0.9 mm). bench_mesh_codec's hulls at 20 mm:
  // 18.9 KB with coordinates; 11.2, 12.2, 13.1 and 15.0 KB at 4, 5, 6 and
  // 8 bits; eval's clean scene 19.1 -> 11.9 KB a frame at 5 bits, PSNR
  // and SSIM the same or better.
  int edge_bits = 5;
  std::array<double, 3> edge_origin{0, 0, 0};
  double edge_spacing = 0;
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

// The open Holoportation stack's mesh coding: half-float positions and
// normals and the indices as they are, through LZ4, with no prediction or
// entropy coding: several times Draco's bytes in a fraction of its time
// (bench_mesh_codec measures the trade). holofuse's meshes also carry
// their vertex keys (exact) and an atlas's corner coordinates (16-bit
// fixed point, Draco's default). Positions are halves of their offset
// from the mesh's bounds centre (kept as floats): a step of 2^-11 of the
// offset, under 0.5 mm on a 2 m subject, like Draco's 11 bits over its box.
// Like Draco it reorders: triangles and vertices go out in the order a
// GPU's vertex cache reuses best (meshoptimizer), the keys with their
// vertices; with corner coordinates the triangles keep their order.
// Layout, little endian: "HF16", u8 version 1, u8 flags (1 normals, 2
// vertex keys, 4 corner coordinates), u16 0, u32 vertices, u32 faces,
// f32 x3 centre, u32 raw size, then one LZ4 block of the raw arrays in
// this order: positions (u16 x3 a vertex), normals (u16 x3), keys (u64),
// indices (u32 x3 a face), corner coordinates (u16 x2 a corner).
// normals: as DracoOptions::normals (the open stack sends them).
StatusOr<std::vector<uint8_t>> encodeFp16Lz4(const Mesh& mesh, bool normals = true);
// The counts its header states, read before anything is decoded.
StatusOr<DracoCounts> readFp16Lz4Counts(const uint8_t* data, size_t size);
// Decodes untrusted bytes: the counts are capped and the stated raw size
// checked against the counts and against what LZ4 can expand the payload
// to before anything is allocated; then as decodeDraco's result (indices
// in range, finite positions, normals recomputed when absent).
StatusOr<Mesh> decodeFp16Lz4(const uint8_t* data, size_t size, const DracoLimits& limits = {});

// The codecs under their flag names ("draco", "fp16-lz4"), and by the
// MeshFrame's codec: what the server sends (--mesh-codec) and what a
// client decodes.
std::vector<std::string> meshCodecNames();
std::string meshCodecName(protocol::MeshCodec codec);
std::optional<protocol::MeshCodec> meshCodecFromName(const std::string& name);
StatusOr<std::vector<uint8_t>> encodeMesh(protocol::MeshCodec codec, const Mesh& mesh,
                                          const DracoOptions& draco = {});
StatusOr<DracoCounts> readMeshCounts(protocol::MeshCodec codec, const uint8_t* data, size_t size);
StatusOr<Mesh> decodeMesh(protocol::MeshCodec codec, const uint8_t* data, size_t size,
                          const DracoLimits& limits = {});

}  // namespace holofuse

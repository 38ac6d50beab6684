// The image and mesh codecs: exact or within quantisation, and refusing
// corrupt or forged bytes by name.
#include <draco/compression/encode.h>
#include <draco/mesh/triangle_soup_mesh_builder.h>
#include <draco/metadata/geometry_metadata.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <map>
#include <memory>
#include <set>

#include "codec/image_codec.h"
#include "codec/mesh_codec.h"
#include "geometry/marching_cubes.h"

namespace holofuse {
namespace {

TEST(ImageCodec, EveryCodecRoundTripsExactly) {
  Image8 image(37, 23, 3);
  for (size_t i = 0; i < image.pixels.size(); ++i)
    image.pixels[i] = static_cast<uint8_t>((i * 7) ^ (i >> 3));
  for (auto codec : {protocol::Codec::kRaw, protocol::Codec::kLz4, protocol::Codec::kLz4PlanarDelta,
                     protocol::Codec::kZstd}) {
    std::vector<uint8_t> storage;
    const auto plane = encodePlane(image, protocol::PlaneKind::kColor, codec, storage);
    auto back = decodePlane(plane);
    ASSERT_TRUE(back.isOk()) << back.status().toString();
    EXPECT_EQ(back->pixels, image.pixels);
  }
}

// LZ4HC writes the same block format: the decoder reads it unchanged, and on
// an image with repeats it is smaller than the fast mode's.
TEST(ImageCodec, Lz4HcLevelsDecodeAsLz4AndCompressMore) {
  Image8 image(96, 64, 3);
  for (uint32_t y = 0; y < image.height; ++y) {
    for (uint32_t x = 0; x < image.width; ++x) {
      for (int c = 0; c < 3; ++c)
        image.at(x, y)[c] = static_cast<uint8_t>(((x / 3) * 37 + (y / 5) * 11 + c * 50) % 251);
    }
  }
  std::vector<uint8_t> fast, hc;
  encodePlane(image, protocol::PlaneKind::kColor, protocol::Codec::kLz4, fast, 1, 0);
  for (int level : {1, 9, kMaxLz4HcLevel}) {
    const auto plane =
        encodePlane(image, protocol::PlaneKind::kColor, protocol::Codec::kLz4, hc, 1, level);
    EXPECT_EQ(plane.codec, protocol::Codec::kLz4) << "the wire's codec is LZ4";
    auto back = decodePlane(plane);
    ASSERT_TRUE(back.isOk()) << back.status().toString();
    EXPECT_EQ(back->pixels, image.pixels) << "level " << level;
    if (level >= 9) {
      EXPECT_LT(hc.size(), fast.size()) << "level " << level;
    }
  }
}

TEST(ImageCodec, CorruptOrLyingPlanesAreErrorsNamingThePlane) {
  Image8 image(16, 16, 1, 9);
  std::vector<uint8_t> storage;
  auto plane = encodePlane(image, protocol::PlaneKind::kMask, protocol::Codec::kLz4, storage);
  std::vector<uint8_t> cut(storage.begin(), storage.begin() + storage.size() / 2);
  plane.data = cut;
  auto bad = decodePlane(plane);
  ASSERT_FALSE(bad.isOk());
  EXPECT_NE(bad.status().message().find("16x16"), std::string::npos);
  plane.data = storage;
  plane.raw_size = 5;
  EXPECT_FALSE(decodePlane(plane).isOk());
}

// A camera plane in Zstandard (protocol 1.11): exact, smaller than LZ4 HC
// on runs of camera indices with ragged borders, and refused by name when
// its frame lies about its size, is cut short or is not Zstandard.
TEST(ImageCodec, ZstandardCameraPlanesRoundTripAndLiesAreRefused) {
  Image8 cameras(128, 96, 1);
  for (uint32_t y = 0; y < cameras.height; ++y)
    for (uint32_t x = 0; x < cameras.width; ++x)
      cameras.at(x, y)[0] = static_cast<uint8_t>(
          (x + (y * 7 % 5)) / 24 % 4 == 3 ? 255 : (x / 17 + y / 13 + (x * y % 11 == 0)) % 6);
  std::vector<uint8_t> zstd, lz4;
  const auto plane =
      encodePlane(cameras, protocol::PlaneKind::kCamera, protocol::Codec::kZstd, zstd);
  encodePlane(cameras, protocol::PlaneKind::kCamera, protocol::Codec::kLz4, lz4, 1, 6);
  EXPECT_EQ(plane.codec, protocol::Codec::kZstd);
  auto back = decodePlane(plane);
  ASSERT_TRUE(back.isOk()) << back.status().toString();
  EXPECT_EQ(back->pixels, cameras.pixels);
  EXPECT_LT(zstd.size(), lz4.size());
  auto refused = [&](protocol::Plane lying, const std::string& says) {
    auto result = decodePlane(lying);
    ASSERT_FALSE(result.isOk()) << says;
    EXPECT_EQ(result.status().code(), StatusCode::kMalformed);
    EXPECT_NE(result.status().message().find(says), std::string::npos) << result.status().message();
    EXPECT_NE(result.status().message().find("128x96"), std::string::npos);
  };
  // A frame of another image's size under this plane's.
  Image8 smaller(64, 96, 1);
  std::vector<uint8_t> other;
  protocol::Plane lying = plane;
  lying.data =
      encodePlane(smaller, protocol::PlaneKind::kCamera, protocol::Codec::kZstd, other).data;
  refused(lying, "states 6144 bytes instead of 12288");
  lying = plane;
  lying.data = std::span<const uint8_t>(zstd).first(zstd.size() / 2);
  refused(lying, "Zstandard data is corrupt");
  lying = plane;
  lying.data = lz4;
  refused(lying, "nothing readable");
}

TEST(MeshCodec, DracoRoundTripIsWithinQuantisation) {
  const auto grid = sampleGrid({-0.5, -0.5, -0.5}, 0.05, 21, 21, 21,
                               [](const glm::dvec3& p) { return 0.4 - glm::length(p); });
  const Mesh mesh = marchingCubes(grid);
  DracoOptions options;
  options.position_bits = 11;
  auto bytes = encodeDraco(mesh, options);
  ASSERT_TRUE(bytes.isOk());
  auto back = decodeDraco(bytes->data(), bytes->size());
  ASSERT_TRUE(back.isOk()) << back.status().toString();
  EXPECT_EQ(back->triangleCount(), mesh.triangleCount());
  // Draco reorders vertices: compare each decoded vertex with the sphere.
  // 11 bits over a 0.8 m box is 0.4 mm per step.
  for (const auto& p : back->positions) EXPECT_NEAR(glm::length(glm::dvec3(p)), 0.4, 0.011);
  EXPECT_LT(bytes->size(), mesh.vertexCount() * 24 / 4) << "quantisation must shrink the mesh";
  EXPECT_FALSE(decodeDraco(bytes->data(), bytes->size() / 3).isOk());
}

// The server's meshes go without normals: the receiver computes them from
// the decoded positions, as the hull computed its own, so they agree with
// the hull's to within the positions' quantisation, for fewer bytes.
TEST(MeshCodec, NormalsAreLeftToTheReceiverUnlessAsked) {
  const auto grid = sampleGrid({-0.5, -0.5, -0.5}, 0.05, 21, 21, 21,
                               [](const glm::dvec3& p) { return 0.4 - glm::length(p); });
  const Mesh mesh = marchingCubes(grid);
  ASSERT_EQ(mesh.normals.size(), mesh.vertexCount());
  DracoOptions with_normals;
  with_normals.normals = true;
  auto bare = encodeDraco(mesh);
  auto full = encodeDraco(mesh, with_normals);
  ASSERT_TRUE(bare.isOk() && full.isOk());
  // At speed 3 Draco predicts normals from the surface: still a tenth.
  EXPECT_LT(bare->size() * 10, full->size() * 9) << "normals were a tenth of the bytes or more";
  for (const auto& bytes : {*bare, *full}) {
    auto back = decodeDraco(bytes.data(), bytes.size());
    ASSERT_TRUE(back.isOk()) << back.status().toString();
    ASSERT_EQ(back->normals.size(), back->vertexCount());
    // Each decoded vertex against the hull's vertex nearest it.
    for (size_t v = 0; v < back->vertexCount(); ++v) {
      size_t nearest = 0;
      for (size_t u = 1; u < mesh.vertexCount(); ++u)
        if (glm::length(mesh.positions[u] - back->positions[v]) <
            glm::length(mesh.positions[nearest] - back->positions[v]))
          nearest = u;
      EXPECT_GT(glm::dot(back->normals[v], mesh.normals[nearest]), 0.99f) << v;
    }
  }
  auto fp16_bare = encodeFp16Lz4(mesh, false);
  auto fp16_full = encodeFp16Lz4(mesh);
  ASSERT_TRUE(fp16_bare.isOk() && fp16_full.isOk());
  EXPECT_LT(fp16_bare->size(), fp16_full->size());
  auto back = decodeFp16Lz4(fp16_bare->data(), fp16_bare->size());
  ASSERT_TRUE(back.isOk());
  std::map<uint64_t, size_t> by_key;
  for (size_t v = 0; v < mesh.vertexCount(); ++v) by_key[mesh.vertex_keys[v]] = v;
  for (size_t v = 0; v < back->vertexCount(); ++v)
    EXPECT_GT(glm::dot(back->normals[v], mesh.normals[by_key.at(back->vertex_keys[v])]), 0.999f);
}

// A mesh built by hand, with its metadata, through Draco and our decoder.
StatusOr<Mesh> throughDraco(draco::Mesh& built, std::unique_ptr<draco::GeometryMetadata> metadata) {
  built.AddMetadata(std::move(metadata));
  draco::Encoder encoder;
  encoder.SetSpeedOptions(10, 10);
  draco::EncoderBuffer buffer;
  EXPECT_TRUE(encoder.EncodeMeshToBuffer(built, &buffer).ok());
  return decodeDraco(reinterpret_cast<const uint8_t*>(buffer.data()), buffer.size());
}

// Since 1.11 Draco carries a hull's vertex keys as their edges' middles in
// half steps on the key lattice: the same keys come back for fewer bytes,
// and a lattice or a key that lies is refused by name.
TEST(MeshCodec, DracoKeysInHalfStepsComeBackTheSameForFewerBytes) {
  const auto grid = sampleGrid({-0.5, -0.5, -0.5}, 0.05, 21, 21, 21,
                               [](const glm::dvec3& p) { return 0.4 - glm::length(p); });
  // Keys on its grid of 21 points a side, moved as the hull moves them to
  // the capture volume's lattice (103 a side at 20 mm over 2 m).
  Mesh mesh = marchingCubes(grid);
  ASSERT_EQ(mesh.vertex_keys.size(), mesh.vertexCount());
  for (uint64_t& key : mesh.vertex_keys) {
    const uint64_t axis = key % 3, point = key / 3;
    const uint64_t x = point % 21 + 40, y = point / 21 % 21 + 30, z = point / 441 + 41;
    key = ((z * 103 + y) * 103 + x) * 3 + axis;
  }
  DracoOptions halves, steps;
  steps.key_lattice = {103, 103};
  auto as_halves = encodeDraco(mesh, halves);
  auto as_steps = encodeDraco(mesh, steps);
  ASSERT_TRUE(as_halves.isOk() && as_steps.isOk());
  EXPECT_LT(as_steps->size() * 10, as_halves->size() * 9) << "a tenth fewer bytes at least";
  auto keysOf = [](const std::vector<uint8_t>& bytes) {
    auto back = decodeDraco(bytes.data(), bytes.size());
    EXPECT_TRUE(back.isOk()) << back.status().toString();
    std::map<uint64_t, glm::vec3> keys;
    if (back.isOk()) {
      EXPECT_EQ(back->vertex_keys.size(), back->vertexCount());
      for (size_t v = 0; v < back->vertexCount(); ++v)
        keys[back->vertex_keys[v]] = back->positions[v];
    }
    return keys;
  };
  const auto from_halves = keysOf(*as_halves), from_steps = keysOf(*as_steps);
  ASSERT_EQ(from_steps.size(), mesh.vertexCount());
  EXPECT_EQ(from_steps, from_halves) << "the same keys at the same positions";
  for (uint64_t key : mesh.vertex_keys) EXPECT_EQ(from_steps.count(key), 1u) << key;
  // A lattice too small for the keys is not used: they go out as halves.
  DracoOptions small;
  small.key_lattice = {103, 0};
  auto fallback = encodeDraco(mesh, small);
  ASSERT_TRUE(fallback.isOk());
  EXPECT_EQ(keysOf(*fallback), from_halves);
  // What no encoder of ours writes: a key naming no edge (two odd half
  // steps, or none), one past its lattice's side, a lattice without sides.
  auto lying = [](std::array<uint32_t, 3> key, std::vector<int32_t> lattice) {
    draco::TriangleSoupMeshBuilder builder;
    builder.Start(1);
    const int position =
        builder.AddAttribute(draco::GeometryAttribute::POSITION, 3, draco::DT_FLOAT32);
    const int keys = builder.AddAttribute(draco::GeometryAttribute::GENERIC, 3, draco::DT_UINT32);
    const float corners[3][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    builder.SetAttributeValuesForFace(position, draco::FaceIndex(0), corners[0], corners[1],
                                      corners[2]);
    const uint32_t good[3] = {2, 1, 0}, other[3] = {1, 2, 0};
    builder.SetAttributeValuesForFace(keys, draco::FaceIndex(0), key.data(), good, other);
    std::unique_ptr<draco::Mesh> built = builder.Finalize();
    auto metadata = std::make_unique<draco::GeometryMetadata>();
    metadata->AddEntryIntArray("holofuse_key_lattice", lattice);
    auto back = throughDraco(*built, std::move(metadata));
    return back.isOk() ? std::string("accepted") : back.status().message();
  };
  EXPECT_EQ(lying({0, 1, 2}, {4, 4}), "accepted");
  EXPECT_NE(lying({1, 1, 0}, {4, 4}).find("vertex 0's key (1, 1, 0) is not the middle of an edge"),
            std::string::npos)
      << lying({1, 1, 0}, {4, 4});
  EXPECT_NE(lying({2, 2, 2}, {4, 4}).find("(2, 2, 2) is not the middle"), std::string::npos);
  EXPECT_NE(lying({9, 0, 0}, {4, 4}).find("(9, 0, 0) is not the middle"), std::string::npos)
      << "x of 4 on a side of 4";
  EXPECT_NE(lying({1, 0, 0}, {0, 4}).find("its key lattice is not two sides"), std::string::npos);
  EXPECT_NE(lying({1, 0, 0}, {4}).find("its key lattice is not two sides"), std::string::npos);
}

// Since 1.13 a hull's vertex goes out as its key and its place along the
// key's edge: off-axis coordinates exact, the place within half a step of
// 2^-edge_bits of the spacing, and fewer bytes than 11-bit coordinates. A
// vertex off its edge (a refined mesh) sends coordinates; a lattice, a
// place or attributes that lie are refused by name.
TEST(MeshCodec, AHullsVerticesGoAsPlacesAlongTheirKeysEdges) {
  constexpr double kSpacing = 0.05;
  const auto grid = sampleGrid({-0.5, -0.5, -0.5}, kSpacing, 21, 21, 21,
                               [](const glm::dvec3& p) { return 0.4 - glm::length(p); });
  Mesh mesh = marchingCubes(grid);
  // Point (40, 30, 41) of a lattice of 103 a side is the grid's first.
  const std::array<double, 3> origin = {-0.5 - 40 * kSpacing, -0.5 - 30 * kSpacing,
                                        -0.5 - 41 * kSpacing};
  for (uint64_t& key : mesh.vertex_keys) {
    const uint64_t axis = key % 3, point = key / 3;
    const uint64_t x = point % 21 + 40, y = point / 21 % 21 + 30, z = point / 441 + 41;
    key = ((z * 103 + y) * 103 + x) * 3 + axis;
  }
  DracoOptions coordinates, places;
  coordinates.key_lattice = places.key_lattice = {103, 103};
  places.edge_origin = origin;
  places.edge_spacing = kSpacing;
  places.edge_bits = 6;
  auto as_coordinates = encodeDraco(mesh, coordinates);
  auto as_places = encodeDraco(mesh, places);
  ASSERT_TRUE(as_coordinates.isOk() && as_places.isOk());
  EXPECT_LT(as_places->size() * 4, as_coordinates->size() * 3)
      << "a quarter fewer bytes at least: " << as_places->size() << " against "
      << as_coordinates->size();
  auto back = decodeDraco(as_places->data(), as_places->size());
  ASSERT_TRUE(back.isOk()) << back.status().toString();
  ASSERT_EQ(back->vertexCount(), mesh.vertexCount());
  ASSERT_EQ(back->triangleCount(), mesh.triangleCount());
  std::map<uint64_t, size_t> by_key;
  for (size_t v = 0; v < mesh.vertexCount(); ++v) by_key[mesh.vertex_keys[v]] = v;
  const double half_step = kSpacing / 128;
  for (size_t v = 0; v < back->vertexCount(); ++v) {
    const uint64_t key = back->vertex_keys[v];
    ASSERT_EQ(by_key.count(key), 1u) << key;
    const glm::vec3 was = mesh.positions[by_key[key]], is = back->positions[v];
    for (int k = 0; k < 3; ++k) {
      const double bound = int(key % 3) == k ? half_step + 1e-6 : 1e-6;
      EXPECT_LE(std::abs(double(is[k]) - double(was[k])), bound) << "vertex " << v << " axis " << k;
    }
  }
  ASSERT_EQ(back->normals.size(), back->vertexCount()) << "normals recomputed";
  // One vertex a millimetre off its edge: the whole mesh goes as coordinates.
  Mesh refined = mesh;
  refined.positions[7] += glm::vec3(0.001f, 0.001f, 0.001f);
  auto moved = encodeDraco(refined, places), moved_coordinates = encodeDraco(refined, coordinates);
  ASSERT_TRUE(moved.isOk() && moved_coordinates.isOk());
  EXPECT_EQ(*moved, *moved_coordinates);
  // What no encoder of ours writes.
  auto lying = [](std::vector<double> edge, uint16_t place, bool lattice = true,
                  draco::DataType place_type = draco::DT_UINT16) {
    draco::TriangleSoupMeshBuilder builder;
    builder.Start(1);
    const int keys = builder.AddAttribute(draco::GeometryAttribute::POSITION, 3, draco::DT_UINT32);
    const int places = builder.AddAttribute(draco::GeometryAttribute::GENERIC, 1, place_type);
    const uint32_t a[3] = {1, 0, 0}, b[3] = {2, 1, 0}, c[3] = {0, 0, 1};
    builder.SetAttributeValuesForFace(keys, draco::FaceIndex(0), a, b, c);
    const uint16_t along[3] = {place, 0, 1};
    builder.SetAttributeValuesForFace(places, draco::FaceIndex(0), &along[0], &along[1], &along[2]);
    std::unique_ptr<draco::Mesh> built = builder.Finalize();
    auto metadata = std::make_unique<draco::GeometryMetadata>();
    if (lattice) metadata->AddEntryIntArray("holofuse_key_lattice", {4, 4});
    metadata->AddEntryDoubleArray("holofuse_edge_places", edge);
    auto back = throughDraco(*built, std::move(metadata));
    if (!back.isOk()) return back.status().message();
    // Vertex (1, 0, 0) in half steps, place 3 of 2^2: x at 0.1 * 7/8.
    for (size_t v = 0; v < back->vertexCount(); ++v)
      if (back->vertex_keys[v] == 0) return "x " + std::to_string(back->positions[v].x);
    return std::string("no vertex of key 0");
  };
  EXPECT_EQ(lying({0, 0, 0, 0.1, 2}, 3), "x " + std::to_string(0.1f * 7 / 8));
  EXPECT_NE(lying({0, 0, 0, 0.1, 2}, 4).find("'s place along its edge (4) is past its 4 steps"),
            std::string::npos)
      << lying({0, 0, 0, 0.1, 2}, 4);
  for (const auto& edge : std::vector<std::vector<double>>{{0, 0, 0, 0.1, 0},
                                                           {0, 0, 0, 0.1, 17},
                                                           {0, 0, 0, 0.1, 2.5},
                                                           {0, 0, 0, 0, 2},
                                                           {0, 0, 0, 0.1},
                                                           {0, std::nan(""), 0, 0.1, 2},
                                                           {0, 0, 1e300, 0.1, 2}}) {
    EXPECT_NE(lying(edge, 0).find("its edge lattice is not an origin"), std::string::npos)
        << lying(edge, 0);
  }
  EXPECT_NE(lying({0, 0, 0, 0.1, 2}, 0, false).find("positions on edges without keys"),
            std::string::npos);
  EXPECT_NE(lying({0, 0, 0, 0.1, 2}, 0, true, draco::DT_UINT8)
                .find("positions on edges without keys in half steps on a lattice and a 16-bit"),
            std::string::npos);
}

// The Holoportation coding (half floats through LZ4) on a keyed marching
// cubes sphere: the same vertices (by key) and the same triangles, in the
// vertex cache's order; positions within a half's step of their offset
// from the centre (2^-11 of 0.4 m: 0.2 mm), normals within a half's step.
// With an atlas's corner coordinates the triangles keep their order and
// each corner its coordinate, within 1/65535.
TEST(MeshCodec, Fp16Lz4RoundTripKeepsEveryVertexAndTriangle) {
  const auto grid = sampleGrid({0.5, 0.6, -0.7}, 0.05, 21, 21, 21, [](const glm::dvec3& p) {
    return 0.4 - glm::length(p - glm::dvec3(1.0, 1.1, -0.2));
  });
  const Mesh mesh = marchingCubes(grid);
  ASSERT_EQ(mesh.vertex_keys.size(), mesh.vertexCount());
  std::map<uint64_t, size_t> by_key;
  for (size_t v = 0; v < mesh.vertexCount(); ++v) by_key[mesh.vertex_keys[v]] = v;
  ASSERT_EQ(by_key.size(), mesh.vertexCount()) << "keys name vertices";
  // A triangle as its keys, from its smallest: the same however it is numbered.
  auto triangles = [](const Mesh& m) {
    std::multiset<std::array<uint64_t, 3>> set;
    for (size_t t = 0; t < m.triangleCount(); ++t) {
      std::array<uint64_t, 3> k = {m.vertex_keys[m.indices[3 * t]],
                                   m.vertex_keys[m.indices[3 * t + 1]],
                                   m.vertex_keys[m.indices[3 * t + 2]]};
      std::rotate(k.begin(), std::min_element(k.begin(), k.end()), k.end());
      set.insert(k);
    }
    return set;
  };
  auto bytes = encodeFp16Lz4(mesh);
  ASSERT_TRUE(bytes.isOk()) << bytes.status().toString();
  const auto counts = readFp16Lz4Counts(bytes->data(), bytes->size());
  ASSERT_TRUE(counts.isOk());
  EXPECT_EQ(counts->vertices, mesh.vertexCount());
  EXPECT_EQ(counts->faces, mesh.triangleCount());
  auto back = decodeFp16Lz4(bytes->data(), bytes->size());
  ASSERT_TRUE(back.isOk()) << back.status().toString();
  ASSERT_EQ(back->vertexCount(), mesh.vertexCount());
  EXPECT_NE(back->vertex_keys, mesh.vertex_keys) << "reordered for the vertex cache";
  EXPECT_EQ(triangles(*back), triangles(mesh));
  for (size_t v = 0; v < back->vertexCount(); ++v) {
    const size_t was = by_key.at(back->vertex_keys[v]);
    EXPECT_LT(glm::length(back->positions[v] - mesh.positions[was]), 0.4f / 2048 * 1.8f) << v;
    EXPECT_LT(glm::length(back->normals[v] - mesh.normals[was]), 2e-3f) << v;
  }
  Mesh atlas = mesh;
  for (size_t c = 0; c < atlas.indices.size(); ++c)
    atlas.corner_uvs.emplace_back((c % 97) / 96.0f, (c % 89) / 88.0f);
  bytes = encodeFp16Lz4(atlas);
  ASSERT_TRUE(bytes.isOk());
  back = decodeFp16Lz4(bytes->data(), bytes->size());
  ASSERT_TRUE(back.isOk());
  ASSERT_EQ(back->corner_uvs.size(), atlas.corner_uvs.size());
  for (size_t c = 0; c < atlas.indices.size(); ++c) {
    EXPECT_EQ(back->vertex_keys[back->indices[c]], atlas.vertex_keys[atlas.indices[c]]) << c;
    EXPECT_LE(glm::length(back->corner_uvs[c] - atlas.corner_uvs[c]), 1.0f / 65535) << c;
  }
  // Without normals they are computed from the faces, as Draco's decoder does.
  Mesh bare = mesh;
  bare.normals.clear();
  bytes = encodeFp16Lz4(bare);
  ASSERT_TRUE(bytes.isOk());
  back = decodeFp16Lz4(bytes->data(), bytes->size());
  ASSERT_TRUE(back.isOk());
  ASSERT_EQ(back->normals.size(), mesh.vertexCount());
  for (size_t v = 0; v < back->vertexCount(); ++v)
    EXPECT_GT(glm::dot(back->normals[v], mesh.normals[by_key.at(back->vertex_keys[v])]), 0.9f);
}

// Untrusted bytes, each refused by name before it can allocate or reach
// the renderer: short, not ours, counts past the caps, a raw size its
// counts do not make, a raw size no LZ4 payload of that length expands
// to, a corrupt block, a face past the vertices, a non-finite position.
TEST(MeshCodec, Fp16Lz4RefusesWhatIsNotAWholeMeshByName) {
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  mesh.indices = {0, 1, 2, 1, 3, 2};
  auto good = encodeFp16Lz4(mesh);
  ASSERT_TRUE(good.isOk());
  auto says = [](const StatusOr<Mesh>& decoded, const std::string& what) {
    ASSERT_FALSE(decoded.isOk()) << what;
    EXPECT_NE(decoded.status().toString().find(what), std::string::npos)
        << decoded.status().toString();
  };
  says(decodeFp16Lz4(good->data(), 20), "shorter than its 32-byte header");
  std::vector<uint8_t> bytes = *good;
  bytes[0] = 'X';
  says(decodeFp16Lz4(bytes.data(), bytes.size()), "no HF16 magic");
  DracoLimits tight;
  tight.max_faces = 1;
  says(decodeFp16Lz4(good->data(), good->size(), tight), "above the caps");
  auto patched = [&](size_t offset, uint32_t value) {
    std::vector<uint8_t> b = *good;
    std::memcpy(b.data() + offset, &value, 4);
    return b;
  };
  bytes = patched(12, 3);  // faces 2 -> 3, raw size unchanged
  says(decodeFp16Lz4(bytes.data(), bytes.size()), "raw bytes where its counts make");
  // A 32-byte header claiming a million vertices over a few bytes of payload.
  bytes = patched(8, 1000000);
  const uint32_t claimed = 1000000 * 6 + 2 * 12;
  std::memcpy(bytes.data() + 28, &claimed, 4);
  says(decodeFp16Lz4(bytes.data(), bytes.size()), "cannot hold");
  bytes = *good;
  for (size_t i = 32; i < bytes.size(); ++i) bytes[i] ^= 0xA5;
  says(decodeFp16Lz4(bytes.data(), bytes.size()), "LZ4");
  Mesh bad_face = mesh;
  bad_face.indices[4] = 7;
  auto encoded = encodeFp16Lz4(bad_face);
  ASSERT_TRUE(encoded.isOk());
  says(decodeFp16Lz4(encoded->data(), encoded->size()), "face 1 index 7 out of range");
  Mesh far = mesh;
  far.positions[3].z = 1e6f;  // past a half's range (65504) from the centre
  encoded = encodeFp16Lz4(far);
  ASSERT_TRUE(encoded.isOk());
  says(decodeFp16Lz4(encoded->data(), encoded->size()), "is not finite");
}

// Bytes from a faulty server: Draco carries unquantised floats and its
// sequential connectivity as given, so a NaN position and a face that
// names a vertex past the end both reach the decoder, which must refuse
// them by name rather than hand them to the renderer.
DracoOptions losslessSequential() {
  DracoOptions options;
  options.position_bits = 0;  // no quantisation: floats as they are
  options.normal_bits = 0;
  options.speed = 10;  // sequential encoding: indices as they are
  return options;
}

TEST(MeshCodec, DecodingRefusesNonFinitePositionsByVertex) {
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, std::nanf("")}};
  mesh.indices = {0, 1, 2, 1, 3, 2};
  auto bytes = encodeDraco(mesh, losslessSequential());
  ASSERT_TRUE(bytes.isOk()) << bytes.status().toString();
  auto back = decodeDraco(bytes->data(), bytes->size());
  ASSERT_FALSE(back.isOk());
  EXPECT_NE(back.status().toString().find("is not finite"), std::string::npos)
      << back.status().toString();
  mesh.positions[3].z = 0.5f;  // the same mesh, finite
  bytes = encodeDraco(mesh, losslessSequential());
  ASSERT_TRUE(bytes.isOk());
  EXPECT_TRUE(decodeDraco(bytes->data(), bytes->size()).isOk());
}

TEST(MeshCodec, DecodingRefusesIndicesOutOfRange) {
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  mesh.indices = {0, 1, 2, 0, 2, 7};
  auto bytes = encodeDraco(mesh, losslessSequential());
  ASSERT_TRUE(bytes.isOk()) << bytes.status().toString();
  auto back = decodeDraco(bytes->data(), bytes->size());
  ASSERT_FALSE(back.isOk()) << back->indices.size() << " indices decoded";
  EXPECT_NE(back.status().toString().find("draco mesh: face 1 index 7 out of range"),
            std::string::npos)
      << back.status().toString();
}

// The counts Draco would allocate for, read before it runs: they must be
// the mesh's own for both of the encoder's methods, and a forged header
// must be refused by the cap, not by running out of memory.
TEST(MeshCodec, CountsAreReadFromTheHeaderForBothEncoderMethods) {
  const auto grid = sampleGrid({-0.5, -0.5, -0.5}, 0.05, 21, 21, 21,
                               [](const glm::dvec3& p) { return 0.4 - glm::length(p); });
  const Mesh mesh = marchingCubes(grid);
  for (int speed : {7, 10}) {  // 7: edgebreaker, 10: sequential
    DracoOptions options;
    options.speed = speed;
    auto bytes = encodeDraco(mesh, options);
    ASSERT_TRUE(bytes.isOk());
    auto counts = readDracoCounts(bytes->data(), bytes->size());
    ASSERT_TRUE(counts.isOk()) << counts.status().toString();
    EXPECT_EQ(counts->faces, mesh.triangleCount()) << "speed " << speed;
    EXPECT_EQ(counts->vertices, mesh.vertexCount()) << "speed " << speed;

    DracoLimits tight;
    tight.max_faces = static_cast<uint32_t>(mesh.triangleCount()) - 1;
    auto refused = decodeDraco(bytes->data(), bytes->size(), tight);
    ASSERT_FALSE(refused.isOk());
    EXPECT_EQ(refused.status().code(), StatusCode::kTooLarge);
    EXPECT_NE(refused.status().message().find(std::to_string(mesh.triangleCount()) + " faces"),
              std::string::npos)
        << refused.status().toString();
    DracoLimits exact;
    exact.max_faces = static_cast<uint32_t>(mesh.triangleCount());
    exact.max_vertices = static_cast<uint32_t>(mesh.vertexCount());
    EXPECT_TRUE(decodeDraco(bytes->data(), bytes->size(), exact).isOk());
  }
}

TEST(MeshCodec, AForgedFaceCountIsRefusedBeforeDecoding) {
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  mesh.indices = {0, 1, 2};
  auto bytes = encodeDraco(mesh, losslessSequential());
  ASSERT_TRUE(bytes.isOk());
  // Sequential connectivity starts right after the 11-byte header with
  // num_faces as a varint; 1 face fits one byte. Claim 2^28 - 1 faces.
  std::vector<uint8_t> forged(bytes->begin(), bytes->begin() + 11);
  ASSERT_EQ((*bytes)[11], 1);
  for (uint8_t b : {0xFF, 0xFF, 0xFF, 0x7F}) forged.push_back(b);
  forged.insert(forged.end(), bytes->begin() + 12, bytes->end());
  auto refused = decodeDraco(forged.data(), forged.size());
  ASSERT_FALSE(refused.isOk());
  EXPECT_NE(refused.status().message().find("268435455 faces, above the caps"), std::string::npos)
      << refused.status().toString();

  auto truncated = decodeDraco(bytes->data(), 9);
  ASSERT_FALSE(truncated.isOk());
  EXPECT_NE(truncated.status().message().find("header truncated"), std::string::npos)
      << truncated.status().toString();
  std::vector<uint8_t> unsigned_bytes(bytes->begin(), bytes->end());
  unsigned_bytes[0] = 'd';
  EXPECT_NE(decodeDraco(unsigned_bytes.data(), unsigned_bytes.size())
                .status()
                .message()
                .find("no DRACO signature"),
            std::string::npos);
}

}  // namespace
}  // namespace holofuse

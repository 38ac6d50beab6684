// Camera model, marching cubes, image and mesh codecs.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <map>
#include <set>

#include "common/camera.h"
#include "common/image_codec.h"
#include "common/marching_cubes.h"
#include "common/mesh_codec.h"

namespace holofuse {
namespace {

TEST(Camera, ProjectsWhatItsRaysHit) {
  const Camera cam = lookAtCamera(0, {2, 1, 3}, {0, 0.8, 0}, {0, 1, 0}, 320, 240, 50);
  EXPECT_NEAR(glm::length(cam.center() - glm::dvec3(2, 1, 3)), 0.0, 1e-12);
  const glm::dvec3 dir = cam.rayDirection(100.5, 40.25);
  const auto p = cam.project(cam.center() + 2.5 * dir);
  ASSERT_TRUE(p);
  EXPECT_NEAR(p->x, 100.5, 1e-9);
  EXPECT_NEAR(p->y, 40.25, 1e-9);
  // The target projects to the image centre; points behind do not project.
  const auto centre = cam.project({0, 0.8, 0});
  EXPECT_NEAR(centre->x, 160, 1e-9);
  EXPECT_NEAR(centre->y, 120, 1e-9);
  EXPECT_FALSE(cam.project(cam.center() - cam.forward()));
  // Image y grows downwards: a point above the target projects higher.
  EXPECT_LT(cam.project({0, 1.2, 0})->y, 120);
}

TEST(Camera, CalibrationRoundTripIsExact) {
  Camera cam = lookAtCamera(5, {1, 2, 3}, {0, 1, 0}, {0, 1, 0}, 640, 480, 60);
  cam.skew = 0.5;
  cam.distortion = {0.1, 0.01, 0, 0, 0};
  const Camera back = fromCalibration(toCalibration(cam));
  EXPECT_EQ(back.id, 5u);
  EXPECT_EQ(back.rotation, cam.rotation);
  EXPECT_EQ(back.translation, cam.translation);
  EXPECT_EQ(back.skew, 0.5);
  EXPECT_EQ(back.distortion, cam.distortion);
}

// Every edge of a closed, consistently oriented surface is used exactly
// twice, once in each direction.
void expectClosedAndOriented(const Mesh& mesh) {
  std::map<std::pair<uint32_t, uint32_t>, int> directed;
  for (size_t t = 0; t < mesh.indices.size(); t += 3) {
    for (int k = 0; k < 3; ++k) directed[{mesh.indices[t + k], mesh.indices[t + (k + 1) % 3]}]++;
  }
  for (const auto& [edge, count] : directed) {
    ASSERT_EQ(count, 1) << "edge used twice in one direction";
    ASSERT_EQ(directed.count({edge.second, edge.first}), 1u) << "boundary edge";
  }
}

TEST(MarchingCubes, DerivedCaseTableIsComplementaryAndSized) {
  const auto& table = marchingCubesCaseTable();
  EXPECT_TRUE(table[0].empty());
  EXPECT_TRUE(table[255].empty());
  EXPECT_EQ(table[1].size(), 3u);  // one corner cut off: one triangle
  EXPECT_EQ(table[3].size(), 6u);  // one edge cut off: a quad
  for (int c = 1; c < 255; ++c) EXPECT_FALSE(table[c].empty()) << c;
}

TEST(MarchingCubes, SphereIsClosedOrientedOutwardAndAccurate) {
  const double r = 0.4;
  const auto grid = sampleGrid({-0.5, -0.5, -0.5}, 0.05, 21, 21, 21,
                               [&](const glm::dvec3& p) { return r - glm::length(p); });
  const Mesh mesh = marchingCubes(grid);
  ASSERT_GT(mesh.triangleCount(), 100u);
  expectClosedAndOriented(mesh);
  double max_error = 0;
  for (size_t v = 0; v < mesh.vertexCount(); ++v) {
    const glm::dvec3 p(mesh.positions[v]);
    max_error = std::max(max_error, std::abs(glm::length(p) - r));
    EXPECT_GT(glm::dot(glm::dvec3(mesh.normals[v]), glm::normalize(p)), 0.9);
  }
  EXPECT_LT(max_error, 0.01);  // linear placement on a 5 cm grid
  EXPECT_EQ(mesh.vertex_keys.size(), mesh.vertexCount());
}

TEST(MarchingCubes, AmbiguousCheckerFieldStillGivesAClosedSurface) {
  // A field whose sign alternates like a 3-D checkerboard exercises every
  // ambiguous face; the outer layer is outside so the result must close.
  const auto grid = sampleGrid({0, 0, 0}, 1.0, 8, 8, 8, [](const glm::dvec3& p) {
    if (p.x == 0 || p.y == 0 || p.z == 0 || p.x == 7 || p.y == 7 || p.z == 7) return -1.0;
    return ((static_cast<int>(p.x + p.y + p.z) & 1) ? 1.0 : -1.0) * (0.5 + 0.1 * p.x);
  });
  expectClosedAndOriented(marchingCubes(grid));
}

TEST(ImageCodec, EveryCodecRoundTripsExactly) {
  Image8 image(37, 23, 3);
  for (size_t i = 0; i < image.pixels.size(); ++i)
    image.pixels[i] = static_cast<uint8_t>((i * 7) ^ (i >> 3));
  for (auto codec :
       {protocol::Codec::kRaw, protocol::Codec::kLz4, protocol::Codec::kLz4PlanarDelta}) {
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

// One right triangle with legs 3 and 4 (edges 3, 4, 5) and one with legs 1
// and 1 (1, 1, sqrt 2): six edges in all.
TEST(Mesh, MeanEdgeLengthCountsEveryTrianglesEdges) {
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {3, 0, 0}, {0, 4, 0}, {10, 0, 0}, {11, 0, 0}, {10, 1, 0}};
  mesh.indices = {0, 1, 2, 3, 4, 5};
  EXPECT_NEAR(meanEdgeLength(mesh), (3 + 4 + 5 + 1 + 1 + std::sqrt(2.0)) / 6, 1e-6);
  EXPECT_EQ(meanEdgeLength(Mesh{}), 0.0);
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

}  // namespace
}  // namespace holofuse

namespace holofuse {
namespace {

TEST(ImageRects, ForegroundRectCropAndPlaceRoundTrip) {
  Image8 mask(40, 30, 1, 0);
  for (uint32_t y = 10; y < 14; ++y) {
    for (uint32_t x = 20; x < 25; ++x) *mask.at(x, y) = 255;
  }
  const PixelRect tight = foregroundRect(mask);
  EXPECT_EQ(tight.x, 20u);
  EXPECT_EQ(tight.y, 10u);
  EXPECT_EQ(tight.width, 5u);
  EXPECT_EQ(tight.height, 4u);
  const PixelRect grown = foregroundRect(mask, 30);  // clipped to the image
  EXPECT_EQ(grown.x, 0u);
  EXPECT_EQ(grown.width, 40u);
  EXPECT_EQ(grown.height, 30u);
  EXPECT_TRUE(foregroundRect(Image8(8, 8, 1, 0)).empty());
  Image8 colour(40, 30, 3);
  for (size_t i = 0; i < colour.pixels.size(); ++i) colour.pixels[i] = static_cast<uint8_t>(i * 7);
  const PixelRect r = foregroundRect(mask, 2);
  const Image8 back = placeInFrame(cropImage(colour, r), r.x, r.y, 40, 30);
  for (uint32_t y = 0; y < 30; ++y) {
    for (uint32_t x = 0; x < 40; ++x) {
      const bool in = x >= r.x && x < r.x + r.width && y >= r.y && y < r.y + r.height;
      for (int c = 0; c < 3; ++c)
        ASSERT_EQ(back.at(x, y)[c], in ? colour.at(x, y)[c] : 0) << x << "," << y;
    }
  }
  EXPECT_THROW(cropImage(colour, {38, 0, 5, 5}), std::invalid_argument);
  EXPECT_FALSE(cropFits(0xFFFFFFF0u, 0, 96, 72, 96, 72)) << "no 32-bit wrap-around";
  EXPECT_TRUE(cropFits(16, 8, 80, 64, 96, 72));
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

#include "codec/mesh_codec.h"

#include <draco/compression/decode.h>
#include <draco/compression/encode.h>
#include <draco/mesh/mesh.h>
#include <draco/metadata/geometry_metadata.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <memory>
#include <numeric>
#include <optional>
#include <span>
#include <string>

#include "protocol/wire.h"

namespace holofuse {

namespace {

// Adds a per-vertex attribute. With corners (a mesh with an atlas), the
// points are the triangles' corners and each maps to its vertex's value, so
// the vertices stay shared: Draco's edgebreaker finds the connectivity from
// the position values and codes the texture coordinates' seams apart.
int addVertexAttribute(draco::Mesh& dm, draco::GeometryAttribute::Type type, int components,
                       draco::DataType data_type, size_t value_size, size_t count,
                       const void* values, const std::vector<uint32_t>* corners) {
  draco::GeometryAttribute attribute;
  attribute.Init(type, nullptr, static_cast<int8_t>(components), data_type, false,
                 static_cast<int64_t>(value_size), 0);
  const int id = dm.AddAttribute(attribute, corners == nullptr, static_cast<uint32_t>(count));
  draco::PointAttribute* added = dm.attribute(id);
  const auto* bytes = static_cast<const uint8_t*>(values);
  for (size_t i = 0; i < count; ++i) {
    added->SetAttributeValue(draco::AttributeValueIndex(static_cast<uint32_t>(i)),
                             bytes + i * value_size);
  }
  if (corners != nullptr) {
    for (size_t c = 0; c < corners->size(); ++c) {
      added->SetPointMapEntry(draco::PointIndex(static_cast<uint32_t>(c)),
                              draco::AttributeValueIndex((*corners)[c]));
    }
  }
  return id;
}

// One metadata element and its sub-elements (Draco bitstream
// specification 4.4-4.6), passed over.
void skipMetadataElement(protocol::WireReader& in, int depth) {
  if (depth > 32) {
    in.failValue("a metadata element", StatusCode::kMalformed, "nested more than 32 deep");
    return;
  }
  const uint32_t entries = in.varint32("a metadata entry count");
  for (uint32_t i = 0; i < entries && in.ok(); ++i) {
    in.raw("a metadata key", in.u8("a metadata key's length"));
    in.raw("a metadata value", in.u8("a metadata value's length"));
  }
  const uint32_t subs = in.varint32("a sub-metadata count");
  for (uint32_t i = 0; i < subs && in.ok(); ++i) {
    in.raw("a sub-metadata key", in.u8("a sub-metadata key's length"));
    skipMetadataElement(in, depth + 1);
  }
}

}  // namespace

StatusOr<DracoCounts> readDracoCounts(const uint8_t* data, size_t size) {
  // Draco bitstream specification 2.2: the header (section 3.2), optional
  // metadata (4) and the connectivity header (6.1 sequential, 7.1
  // edgebreaker), which states the counts the decoder allocates for.
  protocol::WireReader in(std::span<const uint8_t>(data, size));
  auto unreadable = [&in] {
    const bool short_buffer = in.status().code() == StatusCode::kTruncated;
    return Status(StatusCode::kMalformed, std::string("draco mesh: header ") +
                                              (short_buffer ? "truncated" : "malformed") + " (" +
                                              in.status().message() + ")");
  };
  const auto magic = in.raw("the DRACO signature", 5);
  if (!in.ok()) return unreadable();
  if (std::string(magic.begin(), magic.end()) != "DRACO")
    return Status(StatusCode::kMalformed, "draco mesh: no DRACO signature");
  const uint8_t major = in.u8("the major version"), minor = in.u8("the minor version");
  const uint8_t type = in.u8("the encoder type"), method = in.u8("the encoder method");
  const uint16_t flags = in.u16("the flags");
  if (!in.ok()) return unreadable();
  if (major != 2 || minor != 2) {
    return Status(StatusCode::kMalformed,
                  "draco mesh: bitstream " + std::to_string(major) + "." + std::to_string(minor) +
                      "; only 2.2 (what Draco 1.4 and later write) is read");
  }
  if (type != 1) return Status(StatusCode::kMalformed, "draco mesh: not a triangle mesh");
  if (flags & 0x8000) {
    const uint32_t attribute_metadata = in.varint32("the attribute metadata count");
    for (uint32_t i = 0; i < attribute_metadata && in.ok(); ++i) {
      in.varint32("an attribute metadata id");
      skipMetadataElement(in, 0);
    }
    skipMetadataElement(in, 0);
  }
  DracoCounts counts;
  if (method == 0) {
    counts.faces = in.varint32("the face count");
    counts.vertices = in.varint32("the vertex count");
  } else if (method == 1) {
    in.u8("the traversal decoder");
    counts.vertices = in.varint32("the vertex count");
    counts.faces = in.varint32("the face count");
  } else {
    return Status(StatusCode::kMalformed,
                  "draco mesh: unknown encoder method " + std::to_string(method));
  }
  if (!in.ok()) return unreadable();
  return counts;
}

namespace {

constexpr char kKeyLatticeEntry[] = "holofuse_key_lattice";
constexpr uint64_t kMaxKeyLatticeSide = uint64_t{1} << 21;

// A key on a lattice of sides x, y (and any z) as its edge's middle in
// half steps: the edge's start doubled, plus one along its axis.
std::array<uint32_t, 3> keyAsHalfSteps(uint64_t key, const std::array<uint64_t, 2>& lattice) {
  const uint64_t axis = key % 3, point = key / 3;
  const uint64_t at[3] = {point % lattice[0], (point / lattice[0]) % lattice[1],
                          point / (lattice[0] * lattice[1])};
  std::array<uint32_t, 3> half{};
  for (int k = 0; k < 3; ++k) half[k] = static_cast<uint32_t>(2 * at[k] + (axis == uint64_t(k)));
  return half;
}

// The inverse, for untrusted values: nullopt unless exactly one is odd and
// the edge lies on the lattice.
std::optional<uint64_t> keyOfHalfSteps(const uint32_t half[3],
                                       const std::array<uint64_t, 2>& lattice) {
  int axis = -1;
  for (int k = 0; k < 3; ++k) {
    if (half[k] % 2 == 0) continue;
    if (axis >= 0) return std::nullopt;
    axis = k;
  }
  const uint64_t x = half[0] / 2, y = half[1] / 2, z = half[2] / 2;
  if (axis < 0 || x >= lattice[0] || y >= lattice[1] || z >= kMaxKeyLatticeSide)
    return std::nullopt;
  return ((z * lattice[1] + y) * lattice[0] + x) * 3 + static_cast<uint64_t>(axis);
}

bool onLattice(const std::array<uint64_t, 2>& lattice) {
  return lattice[0] > 0 && lattice[1] > 0 && lattice[0] <= kMaxKeyLatticeSide &&
         lattice[1] <= kMaxKeyLatticeSide;
}

// DracoOptions::edge_bits: the lattice's first point, its spacing and the
// bits of a place along an edge, as five doubles.
constexpr char kEdgePlacesEntry[] = "holofuse_edge_places";
constexpr int kMaxEdgeBits = 16;

int edgeAxis(const std::array<uint32_t, 3>& half) { return half[0] % 2 ? 0 : half[1] % 2 ? 1 : 2; }

// Each vertex's place along the edge its key names, in edge_bits bits (the
// step it falls in); nullopt where the options name no edge lattice or a
// vertex lies off its edge.
std::optional<std::vector<uint16_t>> placesOnEdges(const Mesh& mesh,
                                                   const std::vector<uint32_t>& halves,
                                                   const DracoOptions& options) {
  const int bits = options.edge_bits;
  const double s = options.edge_spacing;
  if (bits < 1 || bits > kMaxEdgeBits || !(s > 0) || !std::isfinite(s)) return std::nullopt;
  const double steps = static_cast<double>(1u << bits);
  // A float32 coordinate of a few metres rounds by micrometres; a vertex
  // further than this from its edge was moved off it (a refined mesh).
  const double slack = 1e-3 * s;
  std::vector<uint16_t> places(mesh.positions.size());
  for (size_t i = 0; i < places.size(); ++i) {
    const std::array<uint32_t, 3> half = {halves[3 * i], halves[3 * i + 1], halves[3 * i + 2]};
    const int axis = edgeAxis(half);
    for (int k = 0; k < 3; ++k) {
      const double off = static_cast<double>(mesh.positions[i][k]) -
                         (options.edge_origin[k] + s * static_cast<double>(half[k] / 2));
      if (k != axis) {
        if (!(std::abs(off) <= slack)) return std::nullopt;
        continue;
      }
      if (!(off >= -slack && off <= s + slack)) return std::nullopt;
      places[i] = static_cast<uint16_t>(std::clamp(std::floor(off / s * steps), 0.0, steps - 1));
    }
  }
  return places;
}

}  // namespace

StatusOr<std::vector<uint8_t>> encodeDraco(const Mesh& mesh, const DracoOptions& options) {
  const size_t n = mesh.positions.size();
  const bool atlas = !mesh.corner_uvs.empty();
  if (atlas && mesh.corner_uvs.size() != mesh.indices.size()) {
    return Status(StatusCode::kMalformed,
                  "draco encode: " + std::to_string(mesh.corner_uvs.size()) +
                      " texture coordinates for " + std::to_string(mesh.indices.size()) +
                      " triangle corners");
  }
  draco::Mesh dm;
  dm.set_num_points(static_cast<uint32_t>(atlas ? mesh.indices.size() : n));
  const std::vector<uint32_t>* corners = atlas ? &mesh.indices : nullptr;
  const bool half_steps =
      mesh.vertex_keys.size() == n && onLattice(options.key_lattice) &&
      std::all_of(mesh.vertex_keys.begin(), mesh.vertex_keys.end(), [&](uint64_t key) {
        const auto half = keyAsHalfSteps(key, options.key_lattice);
        return half[2] / 2 < kMaxKeyLatticeSide;
      });
  std::vector<uint32_t> halves;
  if (half_steps) {
    halves.resize(3 * n);
    for (size_t i = 0; i < n; ++i) {
      const auto half = keyAsHalfSteps(mesh.vertex_keys[i], options.key_lattice);
      std::copy(half.begin(), half.end(), halves.begin() + 3 * i);
    }
  }
  const std::optional<std::vector<uint16_t>> places =
      half_steps ? placesOnEdges(mesh, halves, options) : std::nullopt;
  auto metadata = std::make_unique<draco::GeometryMetadata>();
  if (half_steps) {
    metadata->AddEntryIntArray(kKeyLatticeEntry, {static_cast<int32_t>(options.key_lattice[0]),
                                                  static_cast<int32_t>(options.key_lattice[1])});
  }
  if (places) {
    // The key is the position: its half steps take the POSITION attribute
    // (Draco predicts them from the neighbours), the place along the edge
    // a one-component attribute of its own.
    addVertexAttribute(dm, draco::GeometryAttribute::POSITION, 3, draco::DT_UINT32,
                       3 * sizeof(uint32_t), n, halves.data(), corners);
    addVertexAttribute(dm, draco::GeometryAttribute::GENERIC, 1, draco::DT_UINT16, sizeof(uint16_t),
                       n, places->data(), corners);
    metadata->AddEntryDoubleArray(
        kEdgePlacesEntry, {options.edge_origin[0], options.edge_origin[1], options.edge_origin[2],
                           options.edge_spacing, static_cast<double>(options.edge_bits)});
  } else {
    addVertexAttribute(dm, draco::GeometryAttribute::POSITION, 3, draco::DT_FLOAT32,
                       sizeof(glm::vec3), n, mesh.positions.data(), corners);
  }
  if (options.normals && mesh.normals.size() == n) {
    addVertexAttribute(dm, draco::GeometryAttribute::NORMAL, 3, draco::DT_FLOAT32,
                       sizeof(glm::vec3), n, mesh.normals.data(), corners);
  }
  if (half_steps && !places) {
    addVertexAttribute(dm, draco::GeometryAttribute::GENERIC, 3, draco::DT_UINT32,
                       3 * sizeof(uint32_t), n, halves.data(), corners);
  } else if (!half_steps && mesh.vertex_keys.size() == n) {
    // Two 32-bit halves, low first: Draco has no 64-bit integer attribute.
    std::vector<uint32_t> key_halves(2 * n);
    for (size_t i = 0; i < n; ++i) {
      key_halves[2 * i] = static_cast<uint32_t>(mesh.vertex_keys[i]);
      key_halves[2 * i + 1] = static_cast<uint32_t>(mesh.vertex_keys[i] >> 32);
    }
    addVertexAttribute(dm, draco::GeometryAttribute::GENERIC, 2, draco::DT_UINT32,
                       2 * sizeof(uint32_t), n, key_halves.data(), corners);
  }
  if (half_steps) dm.AddMetadata(std::move(metadata));
  if (atlas) {
    addVertexAttribute(dm, draco::GeometryAttribute::TEX_COORD, 2, draco::DT_FLOAT32,
                       sizeof(glm::vec2), mesh.corner_uvs.size(), mesh.corner_uvs.data(), nullptr);
  }
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    if (atlas) {
      dm.AddFace({draco::PointIndex(static_cast<uint32_t>(t)),
                  draco::PointIndex(static_cast<uint32_t>(t + 1)),
                  draco::PointIndex(static_cast<uint32_t>(t + 2))});
    } else {
      dm.AddFace({draco::PointIndex(mesh.indices[t]), draco::PointIndex(mesh.indices[t + 1]),
                  draco::PointIndex(mesh.indices[t + 2])});
    }
  }
  draco::Encoder encoder;
  encoder.SetAttributeQuantization(draco::GeometryAttribute::POSITION, options.position_bits);
  encoder.SetAttributeQuantization(draco::GeometryAttribute::NORMAL, options.normal_bits);
  encoder.SetAttributeQuantization(draco::GeometryAttribute::TEX_COORD, options.uv_bits);
  encoder.SetSpeedOptions(options.speed, options.speed);
  draco::EncoderBuffer buffer;
  const draco::Status status = encoder.EncodeMeshToBuffer(dm, &buffer);
  if (!status.ok()) {
    return Status(StatusCode::kMalformed,
                  std::string("draco encode failed: ") + status.error_msg());
  }
  return std::vector<uint8_t>(buffer.data(), buffer.data() + buffer.size());
}

StatusOr<Mesh> decodeDraco(const uint8_t* data, size_t size, const DracoLimits& limits) {
  auto counts = readDracoCounts(data, size);
  if (!counts.isOk()) return counts.status();
  if (counts->vertices > limits.max_vertices || counts->faces > limits.max_faces) {
    return Status(StatusCode::kTooLarge, "draco mesh: " + std::to_string(counts->vertices) +
                                             " vertices and " + std::to_string(counts->faces) +
                                             " faces, above the caps of " +
                                             std::to_string(limits.max_vertices) + " and " +
                                             std::to_string(limits.max_faces));
  }
  draco::DecoderBuffer buffer;
  buffer.Init(reinterpret_cast<const char*>(data), size);
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
  if (!decoded.ok()) {
    return Status(StatusCode::kMalformed,
                  std::string("draco mesh: ") + decoded.status().error_msg());
  }
  const std::unique_ptr<draco::Mesh>& dm = decoded.value();
  // Where texture coordinates have seams Draco decodes one position per
  // corner; equal values are one vertex again (the encoder shared them).
  if (dm->GetNamedAttribute(draco::GeometryAttribute::TEX_COORD) != nullptr &&
      !dm->DeduplicateAttributeValues()) {
    return Status(StatusCode::kMalformed, "draco mesh: its attribute values cannot be merged");
  }
  const draco::PointAttribute* positions =
      dm->GetNamedAttribute(draco::GeometryAttribute::POSITION);
  if (positions == nullptr || positions->num_components() != 3) {
    return Status(StatusCode::kMalformed, "draco mesh: no 3-component position attribute");
  }
  const draco::PointAttribute* normals = dm->GetNamedAttribute(draco::GeometryAttribute::NORMAL);
  const draco::PointAttribute* uvs = dm->GetNamedAttribute(draco::GeometryAttribute::TEX_COORD);
  const bool atlas = uvs != nullptr && uvs->num_components() == 2;
  // Since 1.11 a key may come as three half steps on the lattice the
  // metadata names (DracoOptions::key_lattice).
  std::array<uint64_t, 2> key_lattice{0, 0};
  std::vector<int32_t> sides;
  if (dm->GetMetadata() != nullptr &&
      dm->GetMetadata()->GetEntryIntArray(kKeyLatticeEntry, &sides)) {
    if (sides.size() != 2 || sides[0] <= 0 || sides[1] <= 0 ||
        !onLattice({uint64_t(sides[0]), uint64_t(sides[1])}))
      return Status(StatusCode::kMalformed, "draco mesh: its key lattice is not two sides in 1.." +
                                                std::to_string(kMaxKeyLatticeSide));
    key_lattice = {uint64_t(sides[0]), uint64_t(sides[1])};
  }
  // Since 1.13 a position may be its key and a place along the key's edge
  // (DracoOptions::edge_bits): the keys are then the POSITION attribute.
  std::vector<double> edge;
  const bool edge_places = dm->GetMetadata() != nullptr &&
                           dm->GetMetadata()->GetEntryDoubleArray(kEdgePlacesEntry, &edge);
  const draco::PointAttribute* places = nullptr;
  if (edge_places) {
    places = dm->GetNamedAttribute(draco::GeometryAttribute::GENERIC);
    const bool lattice_ok =
        edge.size() == 5 &&
        std::all_of(edge.begin(), edge.end(),
                    [](double v) { return std::isfinite(v) && std::abs(v) < 1e6; }) &&
        edge[3] > 0 && edge[4] >= 1 && edge[4] <= kMaxEdgeBits && edge[4] == std::floor(edge[4]);
    if (!lattice_ok)
      return Status(StatusCode::kMalformed,
                    "draco mesh: its edge lattice is not an origin, a spacing above 0 and 1.." +
                        std::to_string(kMaxEdgeBits) + " bits");
    if (key_lattice[0] == 0 || positions->data_type() != draco::DT_UINT32 || places == nullptr ||
        places->num_components() != 1 || places->data_type() != draco::DT_UINT16)
      return Status(StatusCode::kMalformed,
                    "draco mesh: positions on edges without keys in half steps on a lattice and "
                    "a 16-bit place along each edge");
  }
  const draco::PointAttribute* keys =
      edge_places ? positions : dm->GetNamedAttribute(draco::GeometryAttribute::GENERIC);
  const bool half_steps = keys != nullptr && key_lattice[0] > 0 && keys->num_components() == 3 &&
                          keys->data_type() == draco::DT_UINT32;
  const bool keyed = half_steps || (keys != nullptr && keys->num_components() == 2 &&
                                    keys->data_type() == draco::DT_UINT32);
  const bool has_normals = normals != nullptr && normals->num_components() == 3;
  // With an atlas the points are triangle corners: a vertex is the corners
  // that agree on every attribute but the texture coordinates (values made
  // unique above). The key, where there is one, keeps apart two vertices
  // that quantisation put in one place.
  std::vector<uint32_t> vertex_of_point(dm->num_points());
  uint32_t n = dm->num_points();
  if (atlas) {
    std::map<std::array<uint32_t, 3>, uint32_t> vertex_of;
    for (uint32_t p = 0; p < dm->num_points(); ++p) {
      const draco::PointIndex point(p);
      const std::array<uint32_t, 3> identity = {
          positions->mapped_index(point).value(),
          has_normals ? normals->mapped_index(point).value() : 0u,
          edge_places ? places->mapped_index(point).value()
          : keyed     ? keys->mapped_index(point).value()
                      : 0u};
      vertex_of_point[p] =
          vertex_of.emplace(identity, static_cast<uint32_t>(vertex_of.size())).first->second;
    }
    n = static_cast<uint32_t>(vertex_of.size());
  } else {
    std::iota(vertex_of_point.begin(), vertex_of_point.end(), 0u);
  }
  if (n > limits.max_vertices) {
    return Status(StatusCode::kTooLarge, "draco mesh: " + std::to_string(n) +
                                             " vertices, above the cap of " +
                                             std::to_string(limits.max_vertices));
  }
  auto vertexOf = [&](draco::PointIndex point) { return vertex_of_point[point.value()]; };
  Mesh mesh;
  mesh.positions.resize(n);
  std::vector<bool> seen(n, false);
  for (uint32_t p = 0; p < dm->num_points(); ++p) {
    const uint32_t v = vertexOf(draco::PointIndex(p));
    if (seen[v] || edge_places) continue;  // edge places: from the keys, below
    seen[v] = true;
    float value[3] = {0, 0, 0};
    positions->ConvertValue<float, 3>(positions->mapped_index(draco::PointIndex(p)), value);
    if (!std::isfinite(value[0]) || !std::isfinite(value[1]) || !std::isfinite(value[2])) {
      return Status(StatusCode::kMalformed,
                    "draco mesh: vertex " + std::to_string(v) + " is not finite");
    }
    mesh.positions[v] = glm::vec3(value[0], value[1], value[2]);
  }
  mesh.indices.reserve(static_cast<size_t>(dm->num_faces()) * 3);
  if (atlas) mesh.corner_uvs.reserve(static_cast<size_t>(dm->num_faces()) * 3);
  for (uint32_t f = 0; f < dm->num_faces(); ++f) {
    const auto& face = dm->face(draco::FaceIndex(f));
    for (int k = 0; k < 3; ++k) {
      if (face[k].value() >= dm->num_points()) {
        return Status(StatusCode::kMalformed, "draco mesh: face " + std::to_string(f) + " index " +
                                                  std::to_string(face[k].value()) +
                                                  " out of range");
      }
      mesh.indices.push_back(vertexOf(face[k]));
      if (atlas) {
        float uv[2] = {0, 0};
        uvs->ConvertValue<float, 2>(uvs->mapped_index(face[k]), uv);
        // Outside [0,1] (or not finite) it would sample another triangle's
        // texels or none: refused, never clamped into someone else's.
        if (!(uv[0] >= 0.0f && uv[0] <= 1.0f && uv[1] >= 0.0f && uv[1] <= 1.0f)) {
          return Status(StatusCode::kMalformed, "draco mesh: face " + std::to_string(f) +
                                                    " has a texture coordinate outside [0,1]");
        }
        mesh.corner_uvs.emplace_back(uv[0], uv[1]);
      }
    }
  }
  if (keyed) {
    mesh.vertex_keys.resize(n);
    for (uint32_t p = 0; p < dm->num_points(); ++p) {
      const draco::AttributeValueIndex value = keys->mapped_index(draco::PointIndex(p));
      uint64_t& key = mesh.vertex_keys[vertexOf(draco::PointIndex(p))];
      if (half_steps) {
        uint32_t half[3] = {0, 0, 0};
        keys->ConvertValue<uint32_t, 3>(value, half);
        const std::optional<uint64_t> on = keyOfHalfSteps(half, key_lattice);
        if (!on)
          return Status(StatusCode::kMalformed,
                        "draco mesh: vertex " + std::to_string(vertexOf(draco::PointIndex(p))) +
                            "'s key (" + std::to_string(half[0]) + ", " + std::to_string(half[1]) +
                            ", " + std::to_string(half[2]) +
                            ") is not the middle of an edge of its lattice");
        key = *on;
      } else {
        uint32_t halves[2] = {0, 0};
        keys->ConvertValue<uint32_t, 2>(value, halves);
        key = (uint64_t{halves[1]} << 32) | halves[0];
      }
    }
  }
  if (edge_places) {
    const uint32_t steps = 1u << static_cast<int>(edge[4]);
    for (uint32_t p = 0; p < dm->num_points(); ++p) {
      const uint32_t v = vertexOf(draco::PointIndex(p));
      std::array<uint32_t, 3> half{};
      positions->ConvertValue<uint32_t, 3>(positions->mapped_index(draco::PointIndex(p)),
                                           half.data());
      uint16_t place = 0;
      places->ConvertValue<uint16_t, 1>(places->mapped_index(draco::PointIndex(p)), &place);
      if (place >= steps)
        return Status(StatusCode::kMalformed, "draco mesh: vertex " + std::to_string(v) +
                                                  "'s place along its edge (" +
                                                  std::to_string(place) + ") is past its " +
                                                  std::to_string(steps) + " steps");
      // The middle of its step: never an end of the edge, so no triangle
      // collapses.
      const int axis = edgeAxis(half);
      for (int k = 0; k < 3; ++k) {
        const double along = k == axis ? (place + 0.5) / steps : 0.0;
        mesh.positions[v][k] =
            static_cast<float>(edge[k] + edge[3] * (static_cast<double>(half[k] / 2) + along));
      }
    }
  }
  if (has_normals) {
    mesh.normals.assign(n, glm::vec3(0.0f));
    for (uint32_t p = 0; p < dm->num_points(); ++p) {
      float v[3] = {0, 0, 0};
      normals->ConvertValue<float, 3>(normals->mapped_index(draco::PointIndex(p)), v);
      glm::vec3 nv(v[0], v[1], v[2]);
      const float len = glm::length(nv);
      mesh.normals[vertexOf(draco::PointIndex(p))] =
          (std::isfinite(len) && len > 0) ? nv / len : glm::vec3(0.0f);
    }
  } else {
    computeVertexNormals(mesh);
  }
  return mesh;
}

std::vector<std::string> meshCodecNames() { return {"draco", "fp16-lz4"}; }

std::string meshCodecName(protocol::MeshCodec codec) {
  return codec == protocol::MeshCodec::kFp16Lz4 ? "fp16-lz4" : "draco";
}

std::optional<protocol::MeshCodec> meshCodecFromName(const std::string& name) {
  if (name == "draco") return protocol::MeshCodec::kDraco;
  if (name == "fp16-lz4") return protocol::MeshCodec::kFp16Lz4;
  return std::nullopt;
}

StatusOr<std::vector<uint8_t>> encodeMesh(protocol::MeshCodec codec, const Mesh& mesh,
                                          const DracoOptions& draco) {
  return codec == protocol::MeshCodec::kFp16Lz4 ? encodeFp16Lz4(mesh, draco.normals)
                                                : encodeDraco(mesh, draco);
}

StatusOr<DracoCounts> readMeshCounts(protocol::MeshCodec codec, const uint8_t* data, size_t size) {
  return codec == protocol::MeshCodec::kFp16Lz4 ? readFp16Lz4Counts(data, size)
                                                : readDracoCounts(data, size);
}

StatusOr<Mesh> decodeMesh(protocol::MeshCodec codec, const uint8_t* data, size_t size,
                          const DracoLimits& limits) {
  return codec == protocol::MeshCodec::kFp16Lz4 ? decodeFp16Lz4(data, size, limits)
                                                : decodeDraco(data, size, limits);
}

}  // namespace holofuse

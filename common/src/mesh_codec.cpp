#include "common/mesh_codec.h"

#include <draco/compression/decode.h>
#include <draco/compression/encode.h>
#include <draco/mesh/mesh.h>

#include <cmath>
#include <string>

namespace holofuse {

namespace {

int addFloat3Attribute(draco::Mesh& dm, draco::GeometryAttribute::Type type,
                       const std::vector<glm::vec3>& values) {
  draco::GeometryAttribute attribute;
  attribute.Init(type, nullptr, 3, draco::DT_FLOAT32, false, sizeof(float) * 3, 0);
  const int id = dm.AddAttribute(attribute, true, static_cast<uint32_t>(values.size()));
  for (size_t i = 0; i < values.size(); ++i) {
    dm.attribute(id)->SetAttributeValue(draco::AttributeValueIndex(static_cast<uint32_t>(i)),
                                        &values[i][0]);
  }
  return id;
}

// A reader over the Draco bitstream's first bytes, failing (not reading
// past the end) on a short buffer.
class DracoHeaderReader {
 public:
  DracoHeaderReader(const uint8_t* data, size_t size) : data_(data), size_(size) {}
  bool byte(uint8_t& out) {
    if (at_ >= size_) return false;
    out = data_[at_++];
    return true;
  }
  bool skip(size_t n) {
    if (size_ - at_ < n) return false;
    at_ += n;
    return true;
  }
  // LEB128, at most 5 bytes for 32 bits (the spec's varUI32).
  bool varint(uint32_t& out) {
    uint64_t value = 0;
    for (int shift = 0; shift < 35; shift += 7) {
      uint8_t b = 0;
      if (!byte(b)) return false;
      value |= uint64_t{b & 0x7Fu} << shift;
      if ((b & 0x80) == 0) {
        if (value > UINT32_MAX) return false;
        out = static_cast<uint32_t>(value);
        return true;
      }
    }
    return false;
  }
  // One metadata element and its sub-elements (spec 4.4-4.6), skipped.
  bool skipMetadataElement(int depth) {
    if (depth > 32) return false;
    uint32_t entries = 0;
    if (!varint(entries)) return false;
    for (uint32_t i = 0; i < entries; ++i) {
      uint8_t n = 0;
      if (!byte(n) || !skip(n) || !byte(n) || !skip(n)) return false;
    }
    uint32_t subs = 0;
    if (!varint(subs)) return false;
    for (uint32_t i = 0; i < subs; ++i) {
      uint8_t n = 0;
      if (!byte(n) || !skip(n) || !skipMetadataElement(depth + 1)) return false;
    }
    return true;
  }

 private:
  const uint8_t* data_;
  size_t size_;
  size_t at_ = 0;
};

}  // namespace

StatusOr<DracoCounts> readDracoCounts(const uint8_t* data, size_t size) {
  // Draco bitstream specification 2.2: the header (section 3.2), optional
  // metadata (4) and the connectivity header (6.1 sequential, 7.1
  // edgebreaker), which states the counts the decoder allocates for.
  DracoHeaderReader in(data, size);
  const Status truncated(StatusCode::kMalformed, "draco mesh: header truncated");
  uint8_t magic[5] = {};
  for (uint8_t& b : magic)
    if (!in.byte(b)) return truncated;
  if (std::string(magic, magic + 5) != "DRACO")
    return Status(StatusCode::kMalformed, "draco mesh: no DRACO signature");
  uint8_t major = 0, minor = 0, type = 0, method = 0, flags_lo = 0, flags_hi = 0;
  if (!in.byte(major) || !in.byte(minor) || !in.byte(type) || !in.byte(method) ||
      !in.byte(flags_lo) || !in.byte(flags_hi))
    return truncated;
  if (major != 2 || minor != 2) {
    return Status(StatusCode::kMalformed,
                  "draco mesh: bitstream " + std::to_string(major) + "." + std::to_string(minor) +
                      "; only 2.2 (what Draco 1.4 and later write) is read");
  }
  if (type != 1) return Status(StatusCode::kMalformed, "draco mesh: not a triangle mesh");
  const uint16_t flags = static_cast<uint16_t>(flags_lo | (flags_hi << 8));
  if (flags & 0x8000) {
    uint32_t attribute_metadata = 0;
    if (!in.varint(attribute_metadata)) return truncated;
    for (uint32_t i = 0; i < attribute_metadata; ++i) {
      uint32_t id = 0;
      if (!in.varint(id) || !in.skipMetadataElement(0)) return truncated;
    }
    if (!in.skipMetadataElement(0)) return truncated;
  }
  DracoCounts counts;
  if (method == 0) {
    if (!in.varint(counts.faces) || !in.varint(counts.vertices)) return truncated;
  } else if (method == 1) {
    uint8_t traversal = 0;
    if (!in.byte(traversal) || !in.varint(counts.vertices) || !in.varint(counts.faces))
      return truncated;
  } else {
    return Status(StatusCode::kMalformed,
                  "draco mesh: unknown encoder method " + std::to_string(method));
  }
  return counts;
}

StatusOr<std::vector<uint8_t>> encodeDraco(const Mesh& mesh, const DracoOptions& options) {
  draco::Mesh dm;
  dm.set_num_points(static_cast<uint32_t>(mesh.positions.size()));
  addFloat3Attribute(dm, draco::GeometryAttribute::POSITION, mesh.positions);
  if (mesh.normals.size() == mesh.positions.size()) {
    addFloat3Attribute(dm, draco::GeometryAttribute::NORMAL, mesh.normals);
  }
  if (mesh.vertex_keys.size() == mesh.positions.size()) {
    // Vertex identity: two 32-bit halves of the key, integers (Draco keeps
    // them exactly; quantisation applies to float attributes only).
    draco::GeometryAttribute attribute;
    attribute.Init(draco::GeometryAttribute::GENERIC, nullptr, 2, draco::DT_UINT32, false,
                   sizeof(uint32_t) * 2, 0);
    const int id = dm.AddAttribute(attribute, true, static_cast<uint32_t>(mesh.positions.size()));
    for (size_t i = 0; i < mesh.vertex_keys.size(); ++i) {
      const uint32_t halves[2] = {static_cast<uint32_t>(mesh.vertex_keys[i]),
                                  static_cast<uint32_t>(mesh.vertex_keys[i] >> 32)};
      dm.attribute(id)->SetAttributeValue(draco::AttributeValueIndex(static_cast<uint32_t>(i)),
                                          halves);
    }
  }
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    dm.AddFace({draco::PointIndex(mesh.indices[t]), draco::PointIndex(mesh.indices[t + 1]),
                draco::PointIndex(mesh.indices[t + 2])});
  }
  draco::Encoder encoder;
  encoder.SetAttributeQuantization(draco::GeometryAttribute::POSITION, options.position_bits);
  encoder.SetAttributeQuantization(draco::GeometryAttribute::NORMAL, options.normal_bits);
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
  const draco::PointAttribute* positions =
      dm->GetNamedAttribute(draco::GeometryAttribute::POSITION);
  if (positions == nullptr || positions->num_components() != 3) {
    return Status(StatusCode::kMalformed, "draco mesh: no 3-component position attribute");
  }
  const draco::PointAttribute* normals = dm->GetNamedAttribute(draco::GeometryAttribute::NORMAL);
  Mesh mesh;
  const uint32_t n = dm->num_points();
  mesh.positions.resize(n);
  for (uint32_t i = 0; i < n; ++i) {
    float v[3] = {0, 0, 0};
    positions->ConvertValue<float, 3>(positions->mapped_index(draco::PointIndex(i)), v);
    if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2])) {
      return Status(StatusCode::kMalformed,
                    "draco mesh: vertex " + std::to_string(i) + " is not finite");
    }
    mesh.positions[i] = glm::vec3(v[0], v[1], v[2]);
  }
  mesh.indices.reserve(static_cast<size_t>(dm->num_faces()) * 3);
  for (uint32_t f = 0; f < dm->num_faces(); ++f) {
    const auto& face = dm->face(draco::FaceIndex(f));
    for (int k = 0; k < 3; ++k) {
      const uint32_t index = face[k].value();
      if (index >= n) {
        return Status(StatusCode::kMalformed, "draco mesh: face " + std::to_string(f) + " index " +
                                                  std::to_string(index) + " out of range");
      }
      mesh.indices.push_back(index);
    }
  }
  const draco::PointAttribute* keys = dm->GetNamedAttribute(draco::GeometryAttribute::GENERIC);
  if (keys != nullptr && keys->num_components() == 2 && keys->data_type() == draco::DT_UINT32) {
    mesh.vertex_keys.resize(n);
    for (uint32_t i = 0; i < n; ++i) {
      uint32_t halves[2] = {0, 0};
      keys->ConvertValue<uint32_t, 2>(keys->mapped_index(draco::PointIndex(i)), halves);
      mesh.vertex_keys[i] = (uint64_t{halves[1]} << 32) | halves[0];
    }
  }
  if (normals != nullptr && normals->num_components() == 3) {
    mesh.normals.resize(n);
    for (uint32_t i = 0; i < n; ++i) {
      float v[3] = {0, 0, 0};
      normals->ConvertValue<float, 3>(normals->mapped_index(draco::PointIndex(i)), v);
      glm::vec3 nv(v[0], v[1], v[2]);
      const float len = glm::length(nv);
      mesh.normals[i] = (std::isfinite(len) && len > 0) ? nv / len : glm::vec3(0.0f);
    }
  } else {
    computeVertexNormals(mesh);
  }
  return mesh;
}

}  // namespace holofuse

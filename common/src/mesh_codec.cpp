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

}  // namespace

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

StatusOr<Mesh> decodeDraco(const uint8_t* data, size_t size) {
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

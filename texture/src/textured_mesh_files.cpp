#include "texture/textured_mesh_files.h"

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "image/image_io.h"

namespace holofuse {

namespace {

Status checkTexturedMesh(const std::string& path, const Mesh& mesh, const Image8& texture) {
  auto refuse = [&](const std::string& what) {
    return Status(StatusCode::kMalformed, path + ": " + what);
  };
  if (mesh.triangleCount() == 0) return refuse("the mesh has no triangles; nothing to write");
  if (mesh.corner_uvs.size() != mesh.indices.size())
    return refuse("the mesh has no atlas (" + std::to_string(mesh.corner_uvs.size()) +
                  " texture coordinates for " + std::to_string(mesh.indices.size()) + " corners)");
  if (texture.empty() || texture.channels < 3) return refuse("the texture is not RGB");
  for (const uint32_t index : mesh.indices)
    if (index >= mesh.vertexCount()) return refuse("an index past the last vertex");
  return Status::ok();
}

Image8 rgbOf(const Image8& texture) {
  if (texture.channels == 3) return texture;
  Image8 rgb(texture.width, texture.height, 3);
  for (size_t i = 0, n = size_t{texture.width} * texture.height; i < n; ++i)
    std::memcpy(&rgb.pixels[3 * i], &texture.pixels[texture.channels * i], 3);
  return rgb;
}

glm::vec3 normalOf(const Mesh& mesh, uint32_t vertex) {
  return mesh.normals.size() == mesh.vertexCount() ? mesh.normals[vertex] : glm::vec3(0, 0, 1);
}

// glTF's binary container: a 12-byte header, then chunks of a 4-aligned
// length, a type, and the bytes (glTF 2.0 specification, section 4.4).
class GlbWriter {
 public:
  // Appends bytes to the binary chunk, 4-aligned; returns their offset.
  size_t add(const void* data, size_t size) {
    const size_t offset = bin_.size();
    bin_.insert(bin_.end(), static_cast<const uint8_t*>(data),
                static_cast<const uint8_t*>(data) + size);
    while (bin_.size() % 4 != 0) bin_.push_back(0);
    return offset;
  }
  size_t binSize() const { return bin_.size(); }

  Status write(const std::string& path, const nlohmann::json& gltf) const {
    std::string json = gltf.dump();
    while (json.size() % 4 != 0) json.push_back(' ');
    const uint32_t total = static_cast<uint32_t>(12 + 8 + json.size() + 8 + bin_.size());
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    auto word = [&](uint32_t value) {
      const uint8_t bytes[4] = {static_cast<uint8_t>(value), static_cast<uint8_t>(value >> 8),
                                static_cast<uint8_t>(value >> 16),
                                static_cast<uint8_t>(value >> 24)};
      out.write(reinterpret_cast<const char*>(bytes), 4);
    };
    word(0x46546C67u);  // "glTF"
    word(2);
    word(total);
    word(static_cast<uint32_t>(json.size()));
    word(0x4E4F534Au);  // "JSON"
    out.write(json.data(), static_cast<std::streamsize>(json.size()));
    word(static_cast<uint32_t>(bin_.size()));
    word(0x004E4942u);  // "BIN"
    out.write(reinterpret_cast<const char*>(bin_.data()),
              static_cast<std::streamsize>(bin_.size()));
    out.close();
    if (!out) return Status(StatusCode::kIoError, path + ": cannot write");
    return Status::ok();
  }

 private:
  std::vector<uint8_t> bin_;
};

}  // namespace

Status writeTexturedGlb(const std::string& path, const Mesh& mesh, const Image8& texture) {
  HOLOFUSE_RETURN_IF_ERROR(checkTexturedMesh(path, mesh, texture));
  auto png = encodePng(rgbOf(texture));
  if (!png.isOk()) return png.status();
  // glTF has one index per vertex for every attribute: a vertex per corner,
  // since in an atlas a vertex's triangles lie apart.
  const size_t corners = mesh.indices.size();
  std::vector<glm::vec3> positions(corners), normals(corners);
  std::vector<uint32_t> indices(corners);
  glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
  for (size_t c = 0; c < corners; ++c) {
    positions[c] = mesh.positions[mesh.indices[c]];
    normals[c] = normalOf(mesh, mesh.indices[c]);
    indices[c] = static_cast<uint32_t>(c);
    lo = glm::min(lo, positions[c]);
    hi = glm::max(hi, positions[c]);
  }
  GlbWriter glb;
  nlohmann::json views = nlohmann::json::array(), accessors = nlohmann::json::array();
  auto addView = [&](const void* data, size_t size, int target) {
    nlohmann::json view = {
        {"buffer", 0}, {"byteOffset", glb.add(data, size)}, {"byteLength", size}};
    if (target != 0) view["target"] = target;
    views.push_back(view);
    return views.size() - 1;
  };
  auto addAccessor = [&](size_t view, int component, const char* type, size_t count) {
    accessors.push_back(
        {{"bufferView", view}, {"componentType", component}, {"count", count}, {"type", type}});
    return accessors.size() - 1;
  };
  constexpr int kFloat = 5126, kUnsignedInt = 5125, kArrayBuffer = 34962, kElementArray = 34963;
  const size_t position =
      addAccessor(addView(positions.data(), corners * sizeof(glm::vec3), kArrayBuffer), kFloat,
                  "VEC3", corners);
  accessors[position]["min"] = {lo.x, lo.y, lo.z};  // required of POSITION
  accessors[position]["max"] = {hi.x, hi.y, hi.z};
  const size_t normal = addAccessor(
      addView(normals.data(), corners * sizeof(glm::vec3), kArrayBuffer), kFloat, "VEC3", corners);
  const size_t uv =
      addAccessor(addView(mesh.corner_uvs.data(), corners * sizeof(glm::vec2), kArrayBuffer),
                  kFloat, "VEC2", corners);
  const size_t index =
      addAccessor(addView(indices.data(), corners * sizeof(uint32_t), kElementArray), kUnsignedInt,
                  "SCALAR", corners);
  const size_t image_view = addView(png->data(), png->size(), 0);
  constexpr int kLinear = 9729, kClampToEdge = 33071;
  nlohmann::json gltf = {
      {"asset", {{"version", "2.0"}, {"generator", "holofuse"}}},
      {"extensionsUsed", {"KHR_materials_unlit"}},
      {"scene", 0},
      {"scenes", {{{"nodes", {0}}}}},
      {"nodes", {{{"mesh", 0}, {"name", "holofuse"}}}},
      {"meshes",
       {{{"primitives",
          {{{"attributes", {{"POSITION", position}, {"NORMAL", normal}, {"TEXCOORD_0", uv}}},
            {"indices", index},
            {"material", 0}}}}}}},
      {"materials",
       {{{"pbrMetallicRoughness",
          {{"baseColorTexture", {{"index", 0}}},
           {"metallicFactor", 0.0},
           {"roughnessFactor", 1.0}}},
         {"extensions", {{"KHR_materials_unlit", nlohmann::json::object()}}}}}},
      // Linear, no mipmaps, clamped: a smaller level would mix triangles
      // that lie side by side only in the atlas.
      {"samplers",
       {{{"magFilter", kLinear},
         {"minFilter", kLinear},
         {"wrapS", kClampToEdge},
         {"wrapT", kClampToEdge}}}},
      {"textures", {{{"source", 0}, {"sampler", 0}}}},
      {"images", {{{"bufferView", image_view}, {"mimeType", "image/png"}}}},
      {"accessors", accessors},
      {"bufferViews", views},
      {"buffers", {{{"byteLength", glb.binSize()}}}},
  };
  return glb.write(path, gltf);
}

StatusOr<std::vector<std::string>> writeTexturedObj(const std::string& path, const Mesh& mesh,
                                                    const Image8& texture) {
  HOLOFUSE_RETURN_IF_ERROR(checkTexturedMesh(path, mesh, texture));
  const std::filesystem::path obj(path);
  const std::filesystem::path stem = std::filesystem::path(obj).replace_extension();
  const std::string name = stem.filename().string();
  const std::string mtl = stem.string() + ".mtl", png = stem.string() + ".png";
  HOLOFUSE_RETURN_IF_ERROR(writeImage(png, rgbOf(texture)));
  {
    std::ofstream out(mtl, std::ios::trunc);
    out << "# holofuse: the fused frame's atlas, unlit\nnewmtl holofuse\nKa 1 1 1\nKd 1 1 1\n"
           "Ks 0 0 0\nillum 0\nmap_Kd "
        << name << ".png\n";
    if (!out) return Status(StatusCode::kIoError, mtl + ": cannot write");
  }
  std::FILE* out = std::fopen(obj.c_str(), "w");
  if (out == nullptr) return Status(StatusCode::kIoError, path + ": cannot write");
  std::fprintf(out, "# holofuse: %zu vertices, %zu triangles\nmtllib %s.mtl\no holofuse\n",
               mesh.vertexCount(), mesh.triangleCount(), name.c_str());
  for (const glm::vec3& p : mesh.positions) std::fprintf(out, "v %.7g %.7g %.7g\n", p.x, p.y, p.z);
  for (uint32_t v = 0; v < mesh.vertexCount(); ++v) {
    const glm::vec3 n = normalOf(mesh, v);
    std::fprintf(out, "vn %.5g %.5g %.5g\n", n.x, n.y, n.z);
  }
  for (const glm::vec2& t : mesh.corner_uvs) std::fprintf(out, "vt %.7g %.7g\n", t.x, 1.0f - t.y);
  std::fprintf(out, "usemtl holofuse\n");
  for (size_t t = 0; t < mesh.triangleCount(); ++t) {
    std::fprintf(out, "f");
    for (size_t k = 0; k < 3; ++k) {
      const size_t corner = 3 * t + k;  // OBJ counts from 1
      std::fprintf(out, " %u/%zu/%u", mesh.indices[corner] + 1, corner + 1,
                   mesh.indices[corner] + 1);
    }
    std::fprintf(out, "\n");
  }
  const bool failed = std::ferror(out) != 0;
  if (std::fclose(out) != 0 || failed) return Status(StatusCode::kIoError, path + ": cannot write");
  return std::vector<std::string>{obj.string(), mtl, png};
}

}  // namespace holofuse

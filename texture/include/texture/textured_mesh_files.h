// Textured meshes a person opens in Blender or MeshLab: glTF 2.0 binary
// (.glb: mesh, atlas texture and material in one file) and Wavefront OBJ
// with its MTL and PNG beside it. The mesh carries an atlas
// (mesh.corner_uvs, texture/texture_atlas.h); the texture is its colour.
#pragma once

#include <string>
#include <vector>

#include "base/status.h"
#include "geometry/mesh.h"
#include "image/image.h"

namespace holofuse {

// A .glb with one unlit textured primitive (KHR_materials_unlit: the
// colours are the cameras' and already lit). glTF texture coordinates run
// from the image's top-left, as the atlas's do. texture: RGB or RGBA
// (alpha dropped: in a layer it names cameras).
Status writeTexturedGlb(const std::string& path, const Mesh& mesh, const Image8& texture);

// PATH.obj, PATH.mtl and PATH.png (PATH is path without its extension);
// vertices stay shared, each corner with its own texture coordinate (OBJ
// counts v from the image's bottom-left). Returns the files written.
StatusOr<std::vector<std::string>> writeTexturedObj(const std::string& path, const Mesh& mesh,
                                                    const Image8& texture);

}  // namespace holofuse

// Internal to importers/: KHR_draco_mesh_compression, decoded by the radbake-draco-decode helper.
#pragma once

#include <string>

#include <tiny_gltf.h>

namespace radbake {

// Decodes every Draco-compressed primitive of `model` in place: the decoded attributes and indices
// go into a new buffer, the primitive's accessors point at them, and the extension is removed, so
// the rest of radbake (and the written output) sees plain glTF. Returns "" or one line naming the
// mesh and primitive that could not be decoded.
std::string decodeDracoPrimitives(tinygltf::Model& model);

}  // namespace radbake

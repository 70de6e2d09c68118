// The parsed source glTF, shared by importers/ (which reads it) and exporters/ (which writes it back
// with the bake added). Only these two stages include tinygltf.
#pragma once

#include <tiny_gltf.h>

namespace radbake {

struct SourceDocument {
  tinygltf::Model model;
  bool binary = false;  // read from .glb
};

}  // namespace radbake

namespace radbake {

// Accessor `index` as doubles (count × components; normalized integers mapped to [0,1] or [-1,1];
// sparse substitution applied). The importer has already checked every byte range it covers.
std::vector<double> readAccessorValues(const tinygltf::Model& model, int index);

// Sets the accessor's min and max to the per-component bounds of `values` (count × components
// floats): what glTF requires on POSITION, and exact for the data a writer has just stored.
void setAccessorBounds(tinygltf::Accessor& accessor, const std::vector<float>& values, int components);

}  // namespace radbake

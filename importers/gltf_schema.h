// Internal to importers/: JSON-level type check of a glTF document.
#pragma once

#include <string>
#include <vector>

#include "importers/importers.h"

namespace radbake {

// Returns "" when the document's properties have the types the glTF 2.0 schema gives them, else one
// line "/json/pointer: expected X, got Y" naming the first offending property.
std::string checkGltfSchema(const std::string& jsonText);

// What the JSON alone says: object counts and required extensions. Used for `radbake info` on files
// whose geometry radbake cannot decode (an unsupported required extension such as Draco).
struct JsonSummary {
  SceneCounts counts;
  std::vector<std::string> extensionsUsed;
  std::vector<std::string> extensionsRequired;
};
JsonSummary summarizeGltfJson(const std::string& jsonText);  // after checkGltfSchema passed

// tinygltf 2.7 (built without Draco) rejects a primitive whose indices accessor has no buffer
// view, which is how KHR_draco_mesh_compression primitives look. Returns the JSON with "indices"
// removed from such primitives (the Draco decoder writes new ones), or "" when none has it.
std::string withoutDracoIndices(const std::string& jsonText);

}  // namespace radbake

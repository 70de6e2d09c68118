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

}  // namespace radbake

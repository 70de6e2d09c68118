// Internal to importers/: JSON-level type check of a glTF document.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "importers/importers.h"

namespace radbake {

// Arrays and objects nested deeper than this are refused before any JSON parser sees them: the
// parsers below tinygltf recurse, and 20,000 levels overflow the stack. glTF itself needs about
// ten; extras rarely more than a few.
constexpr int kMaxJsonDepth = 128;

// "" or "JSON arrays and objects nested deeper than N levels (at byte B)". A scan, no recursion.
std::string checkJsonNesting(const std::string& jsonText, int maxDepth = kMaxJsonDepth);

// A buffer or image stored in a file beside the asset (not a data URI, not the GLB's BIN chunk).
struct ExternalUri {
  std::string element;  // "buffer 0", "image 3"
  std::string uri;      // as written (percent-encoded)
  uint64_t byteLength;  // buffers: the declared length; images: 0
  bool isBuffer;
};

// What the glTF spec makes strict and tinygltf lets through, or reports without naming the element
// (after checkGltfSchema passed): every mesh has primitives, modes 0..6, a scene lists a root once,
// byteStride a multiple of 4 in 4..252 and at least its accessor's element, component types and types, buffers with a uri or the GLB's
// BIN chunk, data URIs in strict base64 of the declared length, no empty URIs. Returns "" or one
// line naming the element, and lists the files the document points at in `external`.
std::string checkGltfStructure(const std::string& jsonText, bool binary, uint64_t binChunkBytes,
                               std::vector<ExternalUri>& external);

// Returns "" when the document's properties have the types the glTF 2.0 schema gives them, else one
// line "mesh 0 primitive 1: mode: expected X, got Y" naming the element and the first offending property.
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

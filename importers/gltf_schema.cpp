// Type check of the glTF JSON against the core schema, before tinygltf sees it.
//
// Why: tinygltf is lenient; it silently skips a property of the wrong type ("scale": "x", a texture
// index of -1, "primitives" as an object), and a bake would then run on a scene the author did not
// write. The validator calls these errors, so radbake stops with one line naming the property.
#include "importers/gltf_schema.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <string>
#include <vector>

namespace radbake {
namespace {

using nlohmann::json;

enum class Kind {
  kAny, kString, kNumber, kUint, kBool, kObject,
  kNumberArray, kUintArray, kStringArray,
  kUintMap,      // object whose values are non-negative integers (attributes)
  kUintMapArray, // array of kUintMap (morph targets)
};

struct Prop;
struct Schema {
  std::vector<Prop> props;
};
struct Prop {
  const char* name;
  Kind kind;
  const Schema* child = nullptr;  // for kObject, or for arrays of objects with kind kAny+child
  bool arrayOfChild = false;      // the property is an array of `child` objects
};

const char* typeName(const json& v) {
  switch (v.type()) {
    case json::value_t::null: return "null";
    case json::value_t::boolean: return "boolean";
    case json::value_t::string: return "string";
    case json::value_t::array: return "array";
    case json::value_t::object: return "object";
    case json::value_t::number_integer:
    case json::value_t::number_unsigned:
    case json::value_t::number_float: return "number";
    default: return "value";
  }
}

bool isUint(const json& v) {
  if (v.is_number_unsigned()) return true;
  if (v.is_number_integer()) return v.get<long long>() >= 0;
  if (v.is_number_float()) {
    // A whole number within 2^53 (where doubles count exactly); larger ones are no index or
    // length a file could hold, and casting them to an integer would be undefined (found by fuzzing).
    const double d = v.get<double>();
    return d >= 0 && d <= 9007199254740992.0 && d == std::floor(d);
  }
  return false;
}

std::string shortValue(const json& v) {
  std::string s = v.dump();
  if (s.size() > 40) s = s.substr(0, 37) + "...";
  return s;
}

struct Checker {
  std::string* error;

  bool fail(const std::string& path, const char* expected, const json& v) {
    *error = path + ": expected " + expected + ", got " + typeName(v) + " " + shortValue(v);
    return false;
  }

  bool checkKind(const std::string& path, Kind kind, const json& v) {
    switch (kind) {
      case Kind::kAny: return true;
      case Kind::kString: return v.is_string() || fail(path, "a string", v);
      case Kind::kNumber: return v.is_number() || fail(path, "a number", v);
      case Kind::kUint: return isUint(v) || fail(path, "a non-negative integer", v);
      case Kind::kBool: return v.is_boolean() || fail(path, "a boolean", v);
      case Kind::kObject: return v.is_object() || fail(path, "an object", v);
      case Kind::kNumberArray:
        if (!v.is_array()) return fail(path, "an array of numbers", v);
        for (size_t i = 0; i < v.size(); ++i)
          if (!v[i].is_number()) return fail(path + "/" + std::to_string(i), "a number", v[i]);
        return true;
      case Kind::kUintArray:
        if (!v.is_array()) return fail(path, "an array of indices", v);
        for (size_t i = 0; i < v.size(); ++i)
          if (!isUint(v[i])) return fail(path + "/" + std::to_string(i), "a non-negative integer", v[i]);
        return true;
      case Kind::kStringArray:
        if (!v.is_array()) return fail(path, "an array of strings", v);
        for (size_t i = 0; i < v.size(); ++i)
          if (!v[i].is_string()) return fail(path + "/" + std::to_string(i), "a string", v[i]);
        return true;
      case Kind::kUintMap:
        if (!v.is_object()) return fail(path, "an object", v);
        for (const auto& [key, value] : v.items())
          if (!isUint(value)) return fail(path + "/" + key, "a non-negative integer", value);
        return true;
      case Kind::kUintMapArray:
        if (!v.is_array()) return fail(path, "an array", v);
        for (size_t i = 0; i < v.size(); ++i)
          if (!checkKind(path + "/" + std::to_string(i), Kind::kUintMap, v[i])) return false;
        return true;
    }
    return true;
  }

  // Every glTF object may carry name, extensions (an object of objects) and extras (anything).
  bool checkCommon(const std::string& path, const json& v) {
    if (auto it = v.find("name"); it != v.end() && !it->is_string()) return fail(path + "/name", "a string", *it);
    if (auto it = v.find("extensions"); it != v.end()) {
      if (!it->is_object()) return fail(path + "/extensions", "an object", *it);
      for (const auto& [key, value] : it->items())
        if (!value.is_object()) return fail(path + "/extensions/" + key, "an object", value);
    }
    return true;
  }

  bool checkObject(const std::string& path, const Schema& schema, const json& v) {
    if (!v.is_object()) return fail(path, "an object", v);
    if (!checkCommon(path, v)) return false;
    for (const Prop& prop : schema.props) {
      auto it = v.find(prop.name);
      if (it == v.end()) continue;
      const std::string sub = path + "/" + prop.name;
      if (prop.arrayOfChild) {
        if (!it->is_array()) return fail(sub, "an array", *it);
        for (size_t i = 0; i < it->size(); ++i)
          if (!checkObject(sub + "/" + std::to_string(i), *prop.child, (*it)[i])) return false;
      } else if (prop.child) {
        if (!checkObject(sub, *prop.child, *it)) return false;
      } else if (!checkKind(sub, prop.kind, *it)) {
        return false;
      }
    }
    return true;
  }
};

// The core glTF 2.0 schema, the properties whose type matters to a reader.
const Schema kTextureInfo{{{"index", Kind::kUint}, {"texCoord", Kind::kUint}, {"scale", Kind::kNumber},
                           {"strength", Kind::kNumber}}};
const Schema kPbr{{{"baseColorFactor", Kind::kNumberArray}, {"baseColorTexture", Kind::kObject, &kTextureInfo},
                   {"metallicFactor", Kind::kNumber}, {"roughnessFactor", Kind::kNumber},
                   {"metallicRoughnessTexture", Kind::kObject, &kTextureInfo}}};
const Schema kMaterial{{{"pbrMetallicRoughness", Kind::kObject, &kPbr},
                        {"normalTexture", Kind::kObject, &kTextureInfo},
                        {"occlusionTexture", Kind::kObject, &kTextureInfo},
                        {"emissiveTexture", Kind::kObject, &kTextureInfo},
                        {"emissiveFactor", Kind::kNumberArray}, {"alphaMode", Kind::kString},
                        {"alphaCutoff", Kind::kNumber}, {"doubleSided", Kind::kBool}}};
const Schema kPrimitive{{{"attributes", Kind::kUintMap}, {"indices", Kind::kUint}, {"material", Kind::kUint},
                         {"mode", Kind::kUint}, {"targets", Kind::kUintMapArray}}};
const Schema kMesh{{{"primitives", Kind::kAny, &kPrimitive, true}, {"weights", Kind::kNumberArray}}};
const Schema kNode{{{"camera", Kind::kUint}, {"children", Kind::kUintArray}, {"skin", Kind::kUint},
                    {"matrix", Kind::kNumberArray}, {"mesh", Kind::kUint}, {"rotation", Kind::kNumberArray},
                    {"scale", Kind::kNumberArray}, {"translation", Kind::kNumberArray},
                    {"weights", Kind::kNumberArray}}};
const Schema kScene{{{"nodes", Kind::kUintArray}}};
const Schema kSparseIndices{{{"bufferView", Kind::kUint}, {"byteOffset", Kind::kUint}, {"componentType", Kind::kUint}}};
const Schema kSparseValues{{{"bufferView", Kind::kUint}, {"byteOffset", Kind::kUint}}};
const Schema kSparse{{{"count", Kind::kUint}, {"indices", Kind::kObject, &kSparseIndices},
                      {"values", Kind::kObject, &kSparseValues}}};
const Schema kAccessor{{{"bufferView", Kind::kUint}, {"byteOffset", Kind::kUint}, {"componentType", Kind::kUint},
                        {"normalized", Kind::kBool}, {"count", Kind::kUint}, {"type", Kind::kString},
                        {"max", Kind::kNumberArray}, {"min", Kind::kNumberArray},
                        {"sparse", Kind::kObject, &kSparse}}};
const Schema kBufferView{{{"buffer", Kind::kUint}, {"byteOffset", Kind::kUint}, {"byteLength", Kind::kUint},
                          {"byteStride", Kind::kUint}, {"target", Kind::kUint}}};
const Schema kBuffer{{{"uri", Kind::kString}, {"byteLength", Kind::kUint}}};
const Schema kImage{{{"uri", Kind::kString}, {"mimeType", Kind::kString}, {"bufferView", Kind::kUint}}};
const Schema kTexture{{{"sampler", Kind::kUint}, {"source", Kind::kUint}}};
const Schema kSampler{{{"magFilter", Kind::kUint}, {"minFilter", Kind::kUint}, {"wrapS", Kind::kUint},
                       {"wrapT", Kind::kUint}}};
const Schema kSkin{{{"inverseBindMatrices", Kind::kUint}, {"skeleton", Kind::kUint}, {"joints", Kind::kUintArray}}};
const Schema kCamera{{{"type", Kind::kString}}};
const Schema kAsset{{{"version", Kind::kString}, {"minVersion", Kind::kString}, {"generator", Kind::kString},
                     {"copyright", Kind::kString}}};
const Schema kAnimation{{}};
const Schema kRoot{{{"asset", Kind::kObject, &kAsset}, {"scene", Kind::kUint},
                    {"extensionsUsed", Kind::kStringArray}, {"extensionsRequired", Kind::kStringArray},
                    {"scenes", Kind::kAny, &kScene, true}, {"nodes", Kind::kAny, &kNode, true},
                    {"meshes", Kind::kAny, &kMesh, true}, {"materials", Kind::kAny, &kMaterial, true},
                    {"accessors", Kind::kAny, &kAccessor, true}, {"bufferViews", Kind::kAny, &kBufferView, true},
                    {"buffers", Kind::kAny, &kBuffer, true}, {"images", Kind::kAny, &kImage, true},
                    {"textures", Kind::kAny, &kTexture, true}, {"samplers", Kind::kAny, &kSampler, true},
                    {"skins", Kind::kAny, &kSkin, true}, {"cameras", Kind::kAny, &kCamera, true},
                    {"animations", Kind::kAny, &kAnimation, true}}};

// Byte ranges tinygltf trusts while parsing (it hands an image's buffer view to the image loader
// without checking it against the buffer; found by fuzzing): every buffer view inside its buffer's
// declared byteLength, every image's buffer view existing.
std::string checkByteRanges(const json& doc) {
  const json buffers = doc.value("buffers", json::array());
  const json views = doc.value("bufferViews", json::array());
  for (size_t i = 0; i < views.size(); ++i) {
    const json& v = views[i];
    const std::string where = "/bufferViews/" + std::to_string(i);
    if (!v.contains("buffer") || !v.contains("byteLength")) return where + ": buffer and byteLength are required";
    const uint64_t buffer = v["buffer"].get<uint64_t>();
    if (buffer >= buffers.size()) return where + "/buffer: buffer " + std::to_string(buffer) + " does not exist";
    const uint64_t end = v.value("byteOffset", uint64_t(0)) + v["byteLength"].get<uint64_t>();
    const uint64_t size = buffers[buffer].value("byteLength", uint64_t(0));
    if (end > size)
      return where + ": bytes up to " + std::to_string(end) + " exceed buffer " + std::to_string(buffer) + " byteLength " +
             std::to_string(size);
  }
  const json images = doc.value("images", json::array());
  for (size_t i = 0; i < images.size(); ++i)
    if (images[i].contains("bufferView") && images[i]["bufferView"].get<uint64_t>() >= views.size())
      return "/images/" + std::to_string(i) + "/bufferView: buffer view " +
             std::to_string(images[i]["bufferView"].get<uint64_t>()) + " does not exist";
  return "";
}

}  // namespace

std::string checkGltfSchema(const std::string& jsonText) {
  json doc = json::parse(jsonText, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded()) return "not valid JSON";
  if (!doc.is_object()) return "the top level is not a JSON object";
  if (!doc.contains("asset")) return "/asset: missing (required by glTF 2.0)";
  std::string error;
  Checker checker{&error};
  if (!checker.checkObject("", kRoot, doc)) return error;
  return checkByteRanges(doc);
}

std::string withoutDracoIndices(const std::string& jsonText) {
  json doc = json::parse(jsonText);
  bool changed = false;
  if (auto meshes = doc.find("meshes"); meshes != doc.end())
    for (auto& mesh : *meshes)
      if (auto prims = mesh.find("primitives"); prims != mesh.end())
        for (auto& prim : *prims)
          if (prim.contains("extensions") && prim["extensions"].contains("KHR_draco_mesh_compression") && prim.contains("indices")) {
            prim.erase("indices");
            changed = true;
          }
  return changed ? doc.dump() : "";
}

JsonSummary summarizeGltfJson(const std::string& jsonText) {
  const json doc = json::parse(jsonText);
  JsonSummary out;
  auto size = [&](const char* key) { return doc.contains(key) ? int(doc[key].size()) : 0; };
  SceneCounts& c = out.counts;
  c.scenes = size("scenes");
  c.nodes = size("nodes");
  c.meshes = size("meshes");
  c.materials = size("materials");
  c.textures = size("textures");
  c.images = size("images");
  c.cameras = size("cameras");
  c.skins = size("skins");
  c.animations = size("animations");
  for (const auto& mesh : doc.value("meshes", json::array()))
    for (const auto& prim : mesh.value("primitives", json::array())) {
      ++c.primitives;
      const auto& attributes = prim.value("attributes", json::object());
      if (attributes.contains("POSITION")) {
        const size_t accessor = attributes["POSITION"].get<size_t>();
        if (doc.contains("accessors") && accessor < doc["accessors"].size())
          c.vertices += doc["accessors"][accessor].value("count", 0ll);
      }
    }
  out.extensionsUsed = doc.value("extensionsUsed", std::vector<std::string>{});
  out.extensionsRequired = doc.value("extensionsRequired", std::vector<std::string>{});
  return out;
}

}  // namespace radbake

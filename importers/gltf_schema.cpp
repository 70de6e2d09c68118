// Type check of the glTF JSON against the core schema, before tinygltf sees it.
//
// Why: tinygltf is lenient; it silently skips a property of the wrong type ("scale": "x", a texture
// index of -1, "primitives" as an object), and a bake would then run on a scene the author did not
// write. The validator calls these errors, so radbake stops with one line naming the property.
#include "importers/gltf_schema.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
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

std::string indexName(const char* what, size_t i) { return std::string(what) + " " + std::to_string(i); }

// The byte a message may show: printable as is, else as \xNN.
std::string showByte(unsigned char c) {
  if (c >= 0x20 && c < 0x7f) return std::string("'") + char(c) + "'";
  char hex[8];
  std::snprintf(hex, sizeof hex, "\\x%02X", c);
  return hex;
}

// Strict base64 (RFC 4648, the encoding of glTF data URIs): the alphabet only, "=" padding only at
// the end. Returns the decoded length, or a problem naming the first bad character.
std::string checkBase64(const std::string& text, size_t from, uint64_t& decoded) {
  size_t padding = 0, symbols = 0;
  for (size_t i = from; i < text.size(); ++i) {
    const unsigned char c = text[i];
    const bool alphabet = std::isalnum(c) || c == '+' || c == '/';
    if (c == '=' && padding < 2) {
      ++padding;
    } else if (!alphabet || padding > 0) {
      return "data URI: invalid base64 " + showByte(c) + " at character " + std::to_string(i - from) +
             (padding > 0 && alphabet ? " (after the padding)" : "");
    } else {
      ++symbols;
    }
  }
  const size_t total = symbols + padding;
  if (total % 4 == 1 || (padding > 0 && total % 4 != 0)) return "data URI: base64 of " + std::to_string(total) + " characters is truncated";
  decoded = symbols / 4 * 3 + (symbols % 4 == 0 ? 0 : symbols % 4 - 1);
  return "";
}

// A data URI's payload: "data:[<media type>][;base64],<data>"; glTF requires base64.
std::string checkDataUri(const std::string& uri, uint64_t& decoded) {
  const size_t comma = uri.find(',');
  if (comma == std::string::npos) return "data URI without a comma";
  if (uri.compare(0, 5, "data:") != 0 || comma < 12 || uri.compare(comma - 7, 7, ";base64") != 0)
    return "data URI is not base64 (glTF requires \";base64,\")";
  return checkBase64(uri, comma + 1, decoded);
}

bool isDataUri(const std::string& uri) { return uri.compare(0, 5, "data:") == 0; }

}  // namespace

std::string checkGltfSchemaPointers(const std::string& jsonText);

std::string checkJsonNesting(const std::string& jsonText, int maxDepth) {
  int depth = 0;
  bool inString = false, escaped = false;
  for (size_t i = 0; i < jsonText.size(); ++i) {
    const char c = jsonText[i];
    if (inString) {
      if (escaped) escaped = false;
      else if (c == '\\') escaped = true;
      else if (c == '"') inString = false;
    } else if (c == '"') {
      inString = true;
    } else if (c == '[' || c == '{') {
      if (++depth > maxDepth)
        return "JSON arrays and objects nested deeper than " + std::to_string(maxDepth) + " levels (at byte " +
               std::to_string(i) + ")";
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  return "";
}

std::string checkGltfStructure(const std::string& jsonText, bool binary, uint64_t binChunkBytes,
                               std::vector<ExternalUri>& external) {
  const json doc = json::parse(jsonText);
  const json none = json::array();
  const json& meshes = doc.contains("meshes") ? doc["meshes"] : none;
  for (size_t i = 0; i < meshes.size(); ++i) {
    const json& prims = meshes[i].contains("primitives") ? meshes[i]["primitives"] : none;
    if (prims.empty()) return indexName("mesh", i) + ": has no primitives (glTF requires at least one)";
    for (size_t p = 0; p < prims.size(); ++p)
      if (const uint64_t mode = prims[p].value("mode", uint64_t(4)); mode > 6)
        return indexName("mesh", i) + " primitive " + std::to_string(p) + ": mode " + std::to_string(mode) +
               " is not a glTF primitive mode (0 to 6)";
  }
  const json& scenes = doc.contains("scenes") ? doc["scenes"] : none;
  for (size_t s = 0; s < scenes.size(); ++s) {
    std::set<uint64_t> roots;
    for (const json& n : scenes[s].value("nodes", json::array()))
      if (!roots.insert(n.get<uint64_t>()).second)
        return indexName("scene", s) + ": lists node " + std::to_string(n.get<uint64_t>()) + " twice";
  }
  const json& views = doc.contains("bufferViews") ? doc["bufferViews"] : none;
  for (size_t i = 0; i < views.size(); ++i)
    if (views[i].contains("byteStride")) {
      const uint64_t stride = views[i]["byteStride"].get<uint64_t>();
      if (stride < 4 || stride > 252 || stride % 4 != 0)
        return indexName("buffer view", i) + ": byteStride " + std::to_string(stride) +
               " must be a multiple of 4 from 4 to 252";
    }
  const json& accessors = doc.contains("accessors") ? doc["accessors"] : none;
  static const std::map<std::string, int> kComponents{{"SCALAR", 1}, {"VEC2", 2}, {"VEC3", 3}, {"VEC4", 4},
                                                      {"MAT2", 4},   {"MAT3", 9}, {"MAT4", 16}};
  for (size_t i = 0; i < accessors.size(); ++i) {
    const json& a = accessors[i];
    const std::string name = indexName("accessor", i);
    const uint64_t componentType = a.value("componentType", uint64_t(0));
    const int size = componentType == 5120 || componentType == 5121 ? 1
                     : componentType == 5122 || componentType == 5123 ? 2
                     : componentType == 5125 || componentType == 5126 ? 4 : 0;
    if (size == 0) return name + ": componentType " + std::to_string(componentType) + " is not a glTF component type";
    const auto type = kComponents.find(a.value("type", std::string()));
    if (type == kComponents.end()) return name + ": type \"" + a.value("type", std::string()) + "\" is not a glTF accessor type";
    if (!a.contains("count") || a["count"].get<uint64_t>() < 1) return name + ": count must be at least 1";
    const uint64_t offset = a.value("byteOffset", uint64_t(0));
    if (offset % size != 0) return name + ": byteOffset " + std::to_string(offset) + " is not a multiple of its component size";
    if (!a.contains("bufferView")) continue;
    const uint64_t v = a["bufferView"].get<uint64_t>();
    if (v >= views.size()) return name + ": buffer view " + std::to_string(v) + " does not exist";
    const uint64_t element = uint64_t(size) * type->second;
    const uint64_t stride = views[v].value("byteStride", element);
    if (stride < element)
      return name + ": its " + std::to_string(element) + "-byte elements do not fit buffer view " + std::to_string(v) +
             "'s byteStride " + std::to_string(stride);
    if (stride % size != 0)
      return name + ": buffer view " + std::to_string(v) + "'s byteStride " + std::to_string(stride) +
             " is not a multiple of its component size";
    // The range itself is checked where the accessor is read, naming its use (importer).
  }
  // A buffer's or image's uri: not empty; a data URI in strict base64 (its length in `decoded`), or
  // a file, listed in `external` for the resolver.
  auto checkUri = [&](const std::string& name, const std::string& uri, uint64_t byteLength, bool isBuffer,
                      uint64_t& decoded) -> std::string {
    if (uri.empty()) return name + ": uri is empty";
    if (!isDataUri(uri)) {
      external.push_back({name, uri, byteLength, isBuffer});
      return "";
    }
    const std::string problem = checkDataUri(uri, decoded);
    return problem.empty() ? "" : name + ": " + problem;
  };
  const json& buffers = doc.contains("buffers") ? doc["buffers"] : none;
  for (size_t i = 0; i < buffers.size(); ++i) {
    const json& b = buffers[i];
    const std::string name = indexName("buffer", i);
    const uint64_t byteLength = b.value("byteLength", uint64_t(0));
    if (!b.contains("byteLength")) return name + ": byteLength is required";
    if (!b.contains("uri")) {
      if (!binary || i != 0) return name + ": has no uri (only a GLB's first buffer may use its BIN chunk)";
      if (binChunkBytes == 0) return name + ": has no uri and the GLB has no BIN chunk";
      if (byteLength > binChunkBytes)
        return name + ": byteLength " + std::to_string(byteLength) + " exceeds the GLB's BIN chunk of " +
               std::to_string(binChunkBytes) + " bytes";
      continue;
    }
    uint64_t decoded = 0;
    if (std::string problem = checkUri(name, b["uri"].get<std::string>(), byteLength, true, decoded); !problem.empty())
      return problem;
    if (isDataUri(b["uri"].get<std::string>()) && decoded != byteLength)
      return name + ": byteLength " + std::to_string(byteLength) + ", but its data URI holds " + std::to_string(decoded) + " bytes";
  }
  const json& images = doc.contains("images") ? doc["images"] : none;
  for (size_t i = 0; i < images.size(); ++i) {
    const json& im = images[i];
    const std::string name = indexName("image", i);
    if (!im.contains("uri")) {
      if (!im.contains("bufferView")) return name + ": has neither a uri nor a bufferView";
      continue;
    }
    uint64_t decoded = 0;
    if (std::string problem = checkUri(name, im["uri"].get<std::string>(), 0, false, decoded); !problem.empty()) return problem;
  }
  return "";
}

// "/meshes/0/primitives/2/mode: expected ..." → "mesh 0 primitive 2: mode: expected ...": messages name
// glTF elements the way the rest of radbake does.
std::string withElementNames(const std::string& message) {
  static const std::map<std::string, std::string> kSingular{
      {"scenes", "scene"},       {"nodes", "node"},     {"meshes", "mesh"},         {"materials", "material"},
      {"accessors", "accessor"}, {"bufferViews", "buffer view"}, {"buffers", "buffer"}, {"images", "image"},
      {"textures", "texture"},   {"samplers", "sampler"}, {"skins", "skin"},        {"cameras", "camera"},
      {"animations", "animation"}, {"primitives", "primitive"}};
  const size_t colon = message.find(": ");
  if (message.empty() || message[0] != '/' || colon == std::string::npos) return message;
  std::vector<std::string> parts;
  for (size_t start = 1; start <= colon;) {
    const size_t end = std::min(message.find('/', start), colon);
    parts.push_back(message.substr(start, end - start));
    start = end + 1;
  }
  std::string element, rest;
  size_t i = 0;
  while (i + 1 < parts.size() && kSingular.count(parts[i]) && !parts[i + 1].empty() &&
         std::all_of(parts[i + 1].begin(), parts[i + 1].end(), ::isdigit)) {
    element += (element.empty() ? "" : " ") + kSingular.at(parts[i]) + " " + parts[i + 1];
    i += 2;
  }
  for (; i < parts.size(); ++i) rest += (rest.empty() ? "" : "/") + parts[i];
  if (element.empty()) return rest + message.substr(colon);
  return element + (rest.empty() ? "" : ": " + rest) + message.substr(colon);
}

std::string checkGltfSchema(const std::string& jsonText) {
  return withElementNames(checkGltfSchemaPointers(jsonText));
}

std::string checkGltfSchemaPointers(const std::string& jsonText) {
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

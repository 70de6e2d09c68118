// glTF 2.0 (.gltf with external or data-URI buffers, .glb) → Scene.
//
// Order of checks: container (GLB header and chunks), JSON types (gltf_schema), tinygltf parse,
// then every reference and byte range radbake will touch, so that the solver never reads past a
// buffer or trusts a NaN. Every failure is one line "FILE: element: problem".
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include "core/core.h"
#include "importers/gltf_document.h"
#include "importers/gltf_schema.h"
#include "importers/importers.h"
#include "importers/bpt_importer.h"
#include "importers/draco.h"
#include "importers/asset_files.h"
#include "importers/extensions.h"
#include "importers/meshopt.h"
#include "importers/texture.h"

namespace radbake {
namespace {

constexpr Matrix4 kIdentity{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
// What a bake holds per instanced vertex and triangle, from import to solve (positions, normals,
// patches, the ray-tracing structure, the solver's state; measured in docs/results.md "Hostile
// input"): the estimate --max-memory compares a scene against before reading its geometry.
constexpr double kBytesPerVertex = 256;
constexpr double kBytesPerTriangle = 1024;

// The brightest emission or punctual light accepted: the Sun's disc is about 1.6e9 nits, so 1e20
// leaves eleven orders of magnitude, and every product the solver forms stays finite in double and
// the written radiance within float32.
constexpr double kMaxEmission = 1e20;

// A NORMAL this far from unit length is repaired (flat normal) with a warning.
constexpr double kNormalLengthTolerance = 1e-3;

// KHR_mesh_quantization stores normals as normalized bytes or shorts: each component is rounded
// to a step of 1/127 or 1/32767, so a unit normal's length may be off by √3 half steps (0.0068 for
// bytes; gltfpack writes 8-bit normals by default). That much is no broken normal.
double normalLengthTolerance(const tinygltf::Accessor& acc) {
  if (!acc.normalized) return kNormalLengthTolerance;
  if (acc.componentType == TINYGLTF_COMPONENT_TYPE_BYTE) return kNormalLengthTolerance + std::sqrt(3.0) * 0.5 / 127;
  if (acc.componentType == TINYGLTF_COMPONENT_TYPE_SHORT) return kNormalLengthTolerance + std::sqrt(3.0) * 0.5 / 32767;
  return kNormalLengthTolerance;
}

struct Context {
  std::string file;  // the name printed in messages
  std::vector<std::string>* warnings;
  uint64_t maxBytes = UINT64_MAX;  // the memory budget (--max-memory)

  [[noreturn]] void fail(ExitCode code, const std::string& message) const {
    throw Error(code, file + ": " + message);
  }
  [[noreturn]] void invalid(const std::string& message) const { fail(ExitCode::kInvalidInput, message); }
  void warn(const std::string& message) const { warnings->push_back(file + ": " + message); }
  // Refuses (exit 3) an allocation of `bytes` that `what` would need past the memory budget.
  void budget(double bytes, const std::string& what) const {
    if (bytes > double(maxBytes))
      fail(ExitCode::kUnsupported, what + " needs about " + formatBytes(bytes) + ", past the memory budget of " +
                                       formatBytes(double(maxBytes)) + " (--max-memory)");
  }
};

std::string firstLine(const std::string& text) {
  std::string line = text.substr(0, text.find('\n'));
  while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
  return line;
}

uint32_t readU32(const unsigned char* p) {
  return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}

// GLB container: 12-byte header, a JSON chunk, an optional BIN chunk. Returns the JSON text and
// the BIN chunk's length in `binBytes` (0 without one).
std::string glbJson(const Context& ctx, const std::vector<unsigned char>& bytes, uint64_t& binBytes) {
  if (bytes.size() < 20) ctx.invalid("truncated GLB: " + std::to_string(bytes.size()) + " bytes, the header alone needs 20");
  const uint32_t version = readU32(&bytes[4]);
  const uint32_t length = readU32(&bytes[8]);
  if (version != 2) ctx.fail(ExitCode::kUnsupported, "GLB version " + std::to_string(version) + " (only glTF 2.0 is supported)");
  if (length > bytes.size())
    ctx.invalid("truncated GLB: header says " + std::to_string(length) + " bytes, file has " + std::to_string(bytes.size()));
  const uint32_t jsonLength = readU32(&bytes[12]);
  const uint32_t jsonType = readU32(&bytes[16]);
  if (jsonType != 0x4E4F534A) ctx.invalid("GLB chunk 0 is not JSON");
  if (20ull + jsonLength > length)
    ctx.invalid("truncated GLB: JSON chunk of " + std::to_string(jsonLength) + " bytes exceeds the file length " + std::to_string(length));
  const uint64_t binStart = 20ull + jsonLength;
  binBytes = 0;
  if (binStart + 8 <= length) {
    const uint32_t binLength = readU32(&bytes[binStart]);
    if (binStart + 8 + binLength > length)
      ctx.invalid("truncated GLB: BIN chunk of " + std::to_string(binLength) + " bytes exceeds the file length " + std::to_string(length));
    if (readU32(&bytes[binStart + 4]) == 0x004E4942) binBytes = binLength;  // "BIN\0"; others are ignored
  }
  return std::string(reinterpret_cast<const char*>(&bytes[20]), jsonLength);
}

// The same GLB with another JSON chunk (the BIN chunk, if any, unchanged).
std::vector<unsigned char> repackGlb(const std::vector<unsigned char>& bytes, std::string json) {
  while (json.size() % 4) json.push_back(' ');
  const uint32_t oldJson = readU32(&bytes[12]);
  const size_t rest = std::min<size_t>(readU32(&bytes[8]), bytes.size()) - (20 + oldJson);
  std::vector<unsigned char> out(20 + json.size() + rest);
  const uint32_t header[5] = {0x46546C67, 2, uint32_t(out.size()), uint32_t(json.size()), 0x4E4F534A};  // glTF, version, length, JSON
  std::memcpy(out.data(), header, sizeof header);
  std::memcpy(out.data() + 20, json.data(), json.size());
  std::memcpy(out.data() + 20 + json.size(), bytes.data() + 20 + oldJson, rest);
  return out;
}

// Images are kept encoded, exactly as read: radbake writes them back unchanged and decodes only
// what it samples. (This also keeps tinygltf from needing stb_image.)
bool keepImageBytes(tinygltf::Image* image, const int, std::string*, std::string*, int, int,
                    const unsigned char* bytes, int size, void*) {
  image->image.assign(bytes, bytes + size);
  image->as_is = true;
  return true;
}

const char* modeName(int mode) {
  switch (mode) {
    case TINYGLTF_MODE_POINTS: return "POINTS";
    case TINYGLTF_MODE_LINE: return "LINES";
    case TINYGLTF_MODE_LINE_LOOP: return "LINE_LOOP";
    case TINYGLTF_MODE_LINE_STRIP: return "LINE_STRIP";
    default: return "unknown";
  }
}

int componentSize(int componentType) {
  switch (componentType) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
    default: return 0;
  }
}

int componentCount(int type) {
  switch (type) {
    case TINYGLTF_TYPE_SCALAR: return 1;
    case TINYGLTF_TYPE_VEC2: return 2;
    case TINYGLTF_TYPE_VEC3: return 3;
    case TINYGLTF_TYPE_VEC4: return 4;
    case TINYGLTF_TYPE_MAT2: return 4;
    case TINYGLTF_TYPE_MAT3: return 9;
    case TINYGLTF_TYPE_MAT4: return 16;
    default: return 0;
  }
}

// One component as a double, normalized integers mapped as the glTF spec says.
double readComponent(const unsigned char* p, int componentType, bool normalized) {
  switch (componentType) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: {
      int8_t v; std::memcpy(&v, p, 1);
      return normalized ? std::max(v / 127.0, -1.0) : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return normalized ? *p / 255.0 : *p;
    case TINYGLTF_COMPONENT_TYPE_SHORT: {
      int16_t v; std::memcpy(&v, p, 2);
      return normalized ? std::max(v / 32767.0, -1.0) : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
      uint16_t v; std::memcpy(&v, p, 2);
      return normalized ? v / 65535.0 : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
      uint32_t v; std::memcpy(&v, p, 4);
      return normalized ? v / 4294967295.0 : v;
    }
    case TINYGLTF_COMPONENT_TYPE_FLOAT: {
      float v; std::memcpy(&v, p, 4);
      return v;
    }
  }
  return 0;
}

// Checks that a buffer view's bytes lie inside its buffer.
void checkBufferView(const Context& ctx, const tinygltf::Model& m, int index) {
  const auto& view = m.bufferViews[index];
  const std::string name = "buffer view " + std::to_string(index);
  if (view.buffer < 0 || view.buffer >= int(m.buffers.size()))
    ctx.invalid(name + ": buffer " + std::to_string(view.buffer) + " does not exist");
  const auto& buffer = m.buffers[view.buffer];
  if (uint64_t(view.byteOffset) + view.byteLength > buffer.data.size())
    ctx.invalid(name + ": bytes " + std::to_string(view.byteOffset) + ".." +
                std::to_string(uint64_t(view.byteOffset) + view.byteLength) + " exceed buffer " +
                std::to_string(view.buffer) + " length " + std::to_string(buffer.data.size()));
}

// Checks that accessor `index` (which exists) lies inside its buffer view, before anything is read
// or estimated from its count. `what` names the element using it.
void checkAccessorRange(const Context& ctx, const tinygltf::Model& m, int index, const std::string& what) {
  const auto& acc = m.accessors[index];
  if (acc.bufferView < 0) return;
  const std::string name = what + ": accessor " + std::to_string(index);
  if (acc.bufferView >= int(m.bufferViews.size()))
    ctx.invalid(name + ": buffer view " + std::to_string(acc.bufferView) + " does not exist");
  checkBufferView(ctx, m, acc.bufferView);
  const auto& view = m.bufferViews[acc.bufferView];
  const size_t elementSize = size_t(componentSize(acc.componentType)) * componentCount(acc.type);
  const size_t stride = view.byteStride ? view.byteStride : elementSize;
  // 128-bit: a hostile count must not wrap the end of the range around to a small number.
  if (acc.count > 0 && (unsigned __int128)acc.byteOffset + (unsigned __int128)stride * (acc.count - 1) + elementSize > view.byteLength)
    ctx.invalid(name + ": count " + std::to_string(acc.count) + " exceeds buffer view " + std::to_string(acc.bufferView) +
                " length " + std::to_string(view.byteLength));
}

// Reads accessor `index` into doubles (count × components), with stride, normalization and sparse
// substitution. `what` names the element using it, for messages.
std::vector<double> readAccessor(const Context& ctx, const tinygltf::Model& m, int index, const std::string& what) {
  if (index < 0 || index >= int(m.accessors.size()))
    ctx.invalid(what + ": accessor " + std::to_string(index) + " does not exist");
  const auto& acc = m.accessors[index];
  const std::string name = what + ": accessor " + std::to_string(index);
  const int csize = componentSize(acc.componentType);
  const int ccount = componentCount(acc.type);
  if (csize == 0) ctx.invalid(name + ": invalid componentType " + std::to_string(acc.componentType));
  if (ccount == 0) ctx.invalid(name + ": invalid type");
  checkAccessorRange(ctx, m, index, what);
  // An accessor without a buffer view is all zeros (then sparse values): its count is bounded by
  // nothing in the file, only by the budget.
  ctx.budget(double(acc.count) * ccount * sizeof(double), name);
  std::vector<double> out(acc.count * ccount, 0.0);
  if (acc.bufferView >= 0) {
    const auto& view = m.bufferViews[acc.bufferView];
    const size_t elementSize = size_t(csize) * ccount;
    const size_t stride = view.byteStride ? view.byteStride : elementSize;
    const unsigned char* base = m.buffers[view.buffer].data.data() + view.byteOffset + acc.byteOffset;
    for (size_t i = 0; i < acc.count; ++i)
      for (int c = 0; c < ccount; ++c)
        out[i * ccount + c] = readComponent(base + i * stride + c * csize, acc.componentType, acc.normalized);
  }
  if (acc.sparse.isSparse) {
    const auto& sp = acc.sparse;
    auto slice = [&](int viewIndex, size_t offset, size_t bytes, const char* part) -> const unsigned char* {
      if (viewIndex < 0 || viewIndex >= int(m.bufferViews.size()))
        ctx.invalid(name + ": sparse " + part + " buffer view " + std::to_string(viewIndex) + " does not exist");
      checkBufferView(ctx, m, viewIndex);
      const auto& view = m.bufferViews[viewIndex];
      if ((unsigned __int128)offset + bytes > view.byteLength) ctx.invalid(name + ": sparse " + part + " exceed buffer view " + std::to_string(viewIndex));
      return m.buffers[view.buffer].data.data() + view.byteOffset + offset;
    };
    const int isize = componentSize(sp.indices.componentType);
    if (isize == 0) ctx.invalid(name + ": sparse indices have an invalid componentType");
    if (sp.count < 1 || size_t(sp.count) > acc.count)
      ctx.invalid(name + ": sparse count " + std::to_string(sp.count) + " must be from 1 to the accessor's count");
    const unsigned char* idx = slice(sp.indices.bufferView, sp.indices.byteOffset, size_t(sp.count) * isize, "indices");
    const unsigned char* val = slice(sp.values.bufferView, sp.values.byteOffset, size_t(sp.count) * csize * ccount, "values");
    for (int i = 0; i < sp.count; ++i) {
      const double target = readComponent(idx + size_t(i) * isize, sp.indices.componentType, false);
      if (target >= double(acc.count)) ctx.invalid(name + ": sparse index " + std::to_string(size_t(target)) + " out of range");
      for (int c = 0; c < ccount; ++c)
        out[size_t(target) * ccount + c] = readComponent(val + (size_t(i) * ccount + c) * csize, acc.componentType, acc.normalized);
    }
  }
  return out;
}

Matrix4 multiply(const Matrix4& a, const Matrix4& b) {
  Matrix4 r{};
  for (int c = 0; c < 4; ++c)
    for (int row = 0; row < 4; ++row) {
      double s = 0;
      for (int k = 0; k < 4; ++k) s += a[k * 4 + row] * b[c * 4 + k];
      r[c * 4 + row] = s;
    }
  return r;
}

Matrix4 localMatrix(const tinygltf::Node& node) {
  if (node.matrix.size() == 16) {
    Matrix4 m;
    std::copy(node.matrix.begin(), node.matrix.end(), m.begin());
    return m;
  }
  const double tx = node.translation.size() == 3 ? node.translation[0] : 0;
  const double ty = node.translation.size() == 3 ? node.translation[1] : 0;
  const double tz = node.translation.size() == 3 ? node.translation[2] : 0;
  double qx = 0, qy = 0, qz = 0, qw = 1;
  if (node.rotation.size() == 4) { qx = node.rotation[0]; qy = node.rotation[1]; qz = node.rotation[2]; qw = node.rotation[3]; }
  const double qn = std::sqrt(qx * qx + qy * qy + qz * qz + qw * qw);
  if (qn > 0) { qx /= qn; qy /= qn; qz /= qn; qw /= qn; }
  const double sx = node.scale.size() == 3 ? node.scale[0] : 1;
  const double sy = node.scale.size() == 3 ? node.scale[1] : 1;
  const double sz = node.scale.size() == 3 ? node.scale[2] : 1;
  // T * R * S, column-major.
  const double r00 = 1 - 2 * (qy * qy + qz * qz), r01 = 2 * (qx * qy - qz * qw), r02 = 2 * (qx * qz + qy * qw);
  const double r10 = 2 * (qx * qy + qz * qw), r11 = 1 - 2 * (qx * qx + qz * qz), r12 = 2 * (qy * qz - qx * qw);
  const double r20 = 2 * (qx * qz - qy * qw), r21 = 2 * (qy * qz + qx * qw), r22 = 1 - 2 * (qx * qx + qy * qy);
  return {r00 * sx, r10 * sx, r20 * sx, 0, r01 * sy, r11 * sy, r21 * sy, 0,
          r02 * sz, r12 * sz, r22 * sz, 0, tx, ty, tz, 1};
}

// Normals transform by the inverse transpose of the upper 3×3 (its cofactor matrix, up to the
// positive or negative scale that normalization removes; the sign is fixed by the determinant).
struct NormalMatrix {
  std::array<double, 9> c;  // row-major cofactor matrix of the upper 3×3, sign-corrected
  double determinant;
};

NormalMatrix normalMatrix(const Matrix4& m) {
  const double a = m[0], b = m[4], c = m[8], d = m[1], e = m[5], f = m[9], g = m[2], h = m[6], i = m[10];
  const double det = determinant3(m);
  std::array<double, 9> cof{e * i - f * h, -(d * i - f * g), d * h - e * g,
                            -(b * i - c * h), a * i - c * g, -(a * h - b * g),
                            b * f - c * e, -(a * f - c * d), a * e - b * d};
  // The cofactor matrix C (C_ij = signed minor of M_ij) is det·(M⁻¹)ᵀ; dividing by sign(det) keeps
  // the normal's orientation for mirroring transforms, and normalization removes |det|.
  const double s = det < 0 ? -1.0 : 1.0;
  for (double& v : cof) v *= s;
  return {cof, det};
}

Vec3 transformNormal(const NormalMatrix& n, const Vec3& v) {
  const auto& c = n.c;
  return normalize(Vec3{c[0] * v.x + c[1] * v.y + c[2] * v.z, c[3] * v.x + c[4] * v.y + c[5] * v.z,
                        c[6] * v.x + c[7] * v.y + c[8] * v.z});
}

// The first extension the file cannot be baked with: one it requires that radbake cannot honour
// (importers/extensions.cpp), or one radbake cannot load even when it is only used. "" if none.
std::string extensionRefused(const JsonSummary& summary) {
  for (const std::string& ext : summary.extensionsRequired)
    if (!acceptedWhenRequired(ext)) return "requires extension " + ext + ", which radbake does not support";
  for (const std::string& ext : summary.extensionsUsed)
    if (const KnownExtension* known = findExtension(ext); known && known->use == ExtensionUse::kRefused)
      return "uses extension " + ext + ", which radbake cannot load: " + known->note;
  return "";
}

void checkIndex(const Context& ctx, int index, size_t size, const std::string& what, const char* target) {
  if (index >= 0 && size_t(index) >= size)
    ctx.invalid(what + ": " + target + " " + std::to_string(index) + " does not exist (the file has " +
                std::to_string(size) + ")");
}

// References between top-level objects: all must resolve before anything is read.
void checkReferences(const Context& ctx, const tinygltf::Model& m) {
  for (size_t i = 0; i < m.scenes.size(); ++i)
    for (int n : m.scenes[i].nodes) checkIndex(ctx, n, m.nodes.size(), "scene " + std::to_string(i), "node");
  for (size_t i = 0; i < m.nodes.size(); ++i) {
    const auto& node = m.nodes[i];
    const std::string what = "node " + std::to_string(i);
    checkIndex(ctx, node.mesh, m.meshes.size(), what, "mesh");
    checkIndex(ctx, node.camera, m.cameras.size(), what, "camera");
    checkIndex(ctx, node.skin, m.skins.size(), what, "skin");
    for (int c : node.children) checkIndex(ctx, c, m.nodes.size(), what, "child node");
    if (!node.matrix.empty() && node.matrix.size() != 16) ctx.invalid(what + ": matrix must have 16 numbers");
    for (double v : node.matrix)
      if (!std::isfinite(v)) ctx.invalid(what + ": matrix is not finite");
    for (const auto* arr : {&node.translation, &node.rotation, &node.scale})
      for (double v : *arr)
        if (!std::isfinite(v)) ctx.invalid(what + ": translation/rotation/scale is not finite");
  }
  for (size_t i = 0; i < m.meshes.size(); ++i)
    for (size_t p = 0; p < m.meshes[i].primitives.size(); ++p) {
      const auto& prim = m.meshes[i].primitives[p];
      const std::string what = "mesh " + std::to_string(i) + " primitive " + std::to_string(p);
      checkIndex(ctx, prim.material, m.materials.size(), what, "material");
      checkIndex(ctx, prim.indices, m.accessors.size(), what, "indices accessor");
      for (const auto& [semantic, acc] : prim.attributes)
        checkIndex(ctx, acc, m.accessors.size(), what + " " + semantic, "accessor");
    }
  for (size_t i = 0; i < m.bufferViews.size(); ++i) checkBufferView(ctx, m, int(i));
  for (size_t i = 0; i < m.accessors.size(); ++i)
    checkIndex(ctx, m.accessors[i].bufferView, m.bufferViews.size(), "accessor " + std::to_string(i), "buffer view");
  for (size_t i = 0; i < m.textures.size(); ++i) {
    checkIndex(ctx, m.textures[i].source, m.images.size(), "texture " + std::to_string(i), "image");
    checkIndex(ctx, m.textures[i].sampler, m.samplers.size(), "texture " + std::to_string(i), "sampler");
  }
  for (size_t i = 0; i < m.images.size(); ++i)
    checkIndex(ctx, m.images[i].bufferView, m.bufferViews.size(), "image " + std::to_string(i), "buffer view");
  auto checkTexture = [&](const std::string& what, int index) {
    if (index < 0 && index != -1) ctx.invalid(what + ": texture index must be non-negative");
    checkIndex(ctx, index, m.textures.size(), what, "texture");
  };
  for (size_t i = 0; i < m.materials.size(); ++i) {
    const auto& mat = m.materials[i];
    const std::string what = "material " + std::to_string(i);
    checkTexture(what + " baseColorTexture", mat.pbrMetallicRoughness.baseColorTexture.index);
    checkTexture(what + " metallicRoughnessTexture", mat.pbrMetallicRoughness.metallicRoughnessTexture.index);
    checkTexture(what + " normalTexture", mat.normalTexture.index);
    checkTexture(what + " occlusionTexture", mat.occlusionTexture.index);
    checkTexture(what + " emissiveTexture", mat.emissiveTexture.index);
  }
  // The node graph must be a forest: no node with two parents, no cycle.
  std::vector<int> parent(m.nodes.size(), -1);
  for (size_t i = 0; i < m.nodes.size(); ++i)
    for (int c : m.nodes[i].children) {
      if (parent[c] != -1)
        ctx.invalid("node " + std::to_string(c) + ": has two parents (nodes " + std::to_string(parent[c]) + " and " +
                    std::to_string(i) + ")");
      parent[c] = int(i);
    }
  for (size_t i = 0; i < m.nodes.size(); ++i) {
    size_t steps = 0;
    for (int n = int(i); n != -1; n = parent[n])
      if (++steps > m.nodes.size()) ctx.invalid("node " + std::to_string(i) + ": is part of a node cycle");
  }
  for (size_t s = 0; s < m.scenes.size(); ++s)
    for (int n : m.scenes[s].nodes)
      if (parent[n] != -1) ctx.invalid("scene " + std::to_string(s) + ": node " + std::to_string(n) + " is not a root node");
}

// A material's texture slot with its KHR_texture_transform; `texture` is still the glTF index.
TextureRef readTextureRef(int index, int texCoord, const tinygltf::ExtensionMap& extensions) {
  TextureRef ref;
  ref.texture = index;
  ref.texCoord = texCoord;
  if (auto it = extensions.find("KHR_texture_transform"); it != extensions.end()) {
    const tinygltf::Value& t = it->second;
    auto number = [](const tinygltf::Value& v, double fallback) { return v.IsNumber() || v.IsInt() ? v.GetNumberAsDouble() : fallback; };
    if (t.Get("offset").IsArray() && t.Get("offset").ArrayLen() == 2)
      for (int k = 0; k < 2; ++k) ref.offset[k] = number(t.Get("offset").Get(k), 0);
    if (t.Get("scale").IsArray() && t.Get("scale").ArrayLen() == 2)
      for (int k = 0; k < 2; ++k) ref.scale[k] = number(t.Get("scale").Get(k), 1);
    ref.rotation = number(t.Get("rotation"), 0);
    if (t.Has("texCoord")) ref.texCoord = int(number(t.Get("texCoord"), texCoord));
  }
  return ref;
}

// Physical inputs (docs/radiosity.md "Physical inputs"): a reflectance outside [0, 1] or a negative
// emission is clamped with a warning (exporters write such factors, and the intent is clear); a
// value that is not finite, or an emission past kMaxEmission, is refused: no clamp can guess it.
Vec3 clampedWithWarning(const Context& ctx, const Vec3& v, double lo, double hi, const std::string& what) {
  const Vec3 c{std::clamp(v.x, lo, hi), std::clamp(v.y, lo, hi), std::clamp(v.z, lo, hi)};
  if (c.x != v.x || c.y != v.y || c.z != v.z) {
    std::ostringstream text;
    text << what << " (" << v.x << ", " << v.y << ", " << v.z << ") is outside [" << lo << ", "
         << (std::isinf(hi) ? std::string("inf") : std::to_string(int(hi))) << "]; clamped to (" << c.x << ", " << c.y << ", " << c.z << ")";
    ctx.warn(text.str());
  }
  return c;
}

Material readMaterial(const Context& ctx, const tinygltf::Material& mat, int index) {
  Material out;
  out.name = mat.name.empty() ? "material " + std::to_string(index) : mat.name;
  out.gltfIndex = index;
  const std::string what = "material " + std::to_string(index);
  const auto& pbr = mat.pbrMetallicRoughness;
  const double metallic = std::clamp(pbr.metallicFactor, 0.0, 1.0);
  if (pbr.baseColorFactor.size() >= 3) {
    const Vec3 base{pbr.baseColorFactor[0], pbr.baseColorFactor[1], pbr.baseColorFactor[2]};
    if (!isFinite(base)) ctx.invalid(what + ": baseColorFactor is not finite");
    // Metals reflect no diffuse light; partial metalness scales the diffuse part as the glTF BRDF does.
    out.reflectance = clampedWithWarning(ctx, base, 0, 1, what + " baseColorFactor") * (1 - metallic);
  }
  double strength = 1;
  if (auto it = mat.extensions.find("KHR_materials_emissive_strength"); it != mat.extensions.end()) {
    const auto& v = it->second.Get("emissiveStrength");
    if (v.IsNumber() || v.IsInt()) strength = v.GetNumberAsDouble();
  }
  if (mat.emissiveFactor.size() >= 3) {
    const Vec3 emission = Vec3{mat.emissiveFactor[0], mat.emissiveFactor[1], mat.emissiveFactor[2]} * strength;
    if (!isFinite(emission) || std::max({emission.x, emission.y, emission.z}) > kMaxEmission)
      ctx.invalid(what + ": emission (emissiveFactor x emissiveStrength) is not finite or above 1e20 nits; no physical light is that bright");
    out.emission = clampedWithWarning(ctx, emission, 0, std::numeric_limits<double>::infinity(), what + " emission");
  }
  out.doubleSided = mat.doubleSided;
  out.alphaMask = mat.alphaMode == "MASK";
  out.alphaCutoff = mat.alphaCutoff;
  if (pbr.baseColorFactor.size() == 4) out.baseAlpha = pbr.baseColorFactor[3];
  out.baseColorTexture = readTextureRef(pbr.baseColorTexture.index, pbr.baseColorTexture.texCoord, pbr.baseColorTexture.extensions);
  out.emissiveTexture = readTextureRef(mat.emissiveTexture.index, mat.emissiveTexture.texCoord, mat.emissiveTexture.extensions);
  return out;
}

// Triangle list from the primitive's mode; indices already range-checked.
std::vector<std::array<uint32_t, 3>> triangulate(int mode, const std::vector<uint32_t>& idx) {
  std::vector<std::array<uint32_t, 3>> tris;
  if (mode == TINYGLTF_MODE_TRIANGLES) {
    for (size_t i = 0; i + 2 < idx.size(); i += 3) tris.push_back({idx[i], idx[i + 1], idx[i + 2]});
  } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
    // glTF: triangle i is (i, i+1, i+2) for even i and (i+1, i, i+2) for odd i (keeps the winding).
    for (size_t i = 0; i + 2 < idx.size(); ++i)
      tris.push_back(i % 2 == 0 ? std::array<uint32_t, 3>{idx[i], idx[i + 1], idx[i + 2]}
                                : std::array<uint32_t, 3>{idx[i + 1], idx[i], idx[i + 2]});
  } else if (mode == TINYGLTF_MODE_TRIANGLE_FAN) {
    for (size_t i = 1; i + 1 < idx.size(); ++i) tris.push_back({idx[i], idx[i + 1], idx[0]});
  }
  return tris;
}

// Decodes the textures that light depends on (base color and emissive) and points the materials'
// references at Scene::textures. An image that cannot be decoded is a warning: the factor alone
// is used.
void decodeTextures(const Context& ctx, const tinygltf::Model& m, Scene& scene) {
  std::map<int, int> decoded;  // glTF texture → Scene texture (-1: failed)
  double textureBytes = 0;     // decoded so far, against the memory budget
  auto resolve = [&](TextureRef& ref) {
    if (ref.texture < 0) return;
    auto [it, isNew] = decoded.try_emplace(ref.texture, -1);
    if (isNew) {
      const tinygltf::Texture& gt = m.textures[ref.texture];
      Texture texture;
      std::string error = "no image";
      int width = 0, height = 0;
      bool plausible = gt.source >= 0;
      if (plausible && imageDimensions(m.images[gt.source].image, width, height)) {
        error = implausibleImage(m.images[gt.source].image, width, height);
        plausible = error.empty();
        textureBytes += double(width) * height * kDecodedBytesPerTexel;
        if (plausible)
          ctx.budget(textureBytes, "image " + std::to_string(gt.source) + " (" + std::to_string(width) + "x" +
                                       std::to_string(height) + " pixels, with the textures before it)");
      }
      if (plausible && decodeColorTexture(m.images[gt.source].image, texture, error)) {
        if (gt.sampler >= 0) {
          texture.wrapS = m.samplers[gt.sampler].wrapS;
          texture.wrapT = m.samplers[gt.sampler].wrapT;
        }
        scene.textures.push_back(std::move(texture));
        it->second = int(scene.textures.size()) - 1;
      } else {
        ctx.warn("texture " + std::to_string(ref.texture) + " (image " + std::to_string(gt.source) +
                 "): cannot decode (" + error + "); its material's factor is used alone");
      }
    }
    ref.texture = it->second;
  };
  for (Material& mat : scene.materials) {
    resolve(mat.baseColorTexture);
    resolve(mat.emissiveTexture);
  }
}

struct Importer {
  Context ctx;
  const tinygltf::Model& m;
  Scene& scene;
  std::set<std::pair<int, int>> skippedModes;
  double instancedVertices = 0, instancedTriangles = 0;

  void addPrimitive(int nodeIndex, int meshIndex, int primIndex, const Matrix4& world) {
    const auto& prim = m.meshes[meshIndex].primitives[primIndex];
    const std::string what = "mesh " + std::to_string(meshIndex) + " primitive " + std::to_string(primIndex);
    if (prim.mode != TINYGLTF_MODE_TRIANGLES && prim.mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
        prim.mode != TINYGLTF_MODE_TRIANGLE_FAN) {
      if (skippedModes.insert({meshIndex, primIndex}).second)
        ctx.warn(what + ": mode " + modeName(prim.mode) + " has no surface to light; skipped");
      return;
    }
    auto posIt = prim.attributes.find("POSITION");
    if (posIt == prim.attributes.end()) {
      ctx.warn(what + ": no POSITION attribute; skipped");
      return;
    }
    const auto& posAcc = m.accessors[posIt->second];
    if (posAcc.type != TINYGLTF_TYPE_VEC3) ctx.invalid(what + ": POSITION accessor " + std::to_string(posIt->second) + " is not VEC3");
    const std::vector<double> pos = readAccessor(ctx, m, posIt->second, what + " POSITION");
    const size_t count = posAcc.count;
    for (size_t i = 0; i < pos.size(); ++i)
      if (!std::isfinite(pos[i]))
        ctx.invalid(what + ": POSITION accessor " + std::to_string(posIt->second) + " element " + std::to_string(i / 3) +
                    " is not finite (" + std::to_string(pos[i]) + ")");

    std::vector<uint32_t> idx;
    if (prim.indices >= 0) {
      const auto& ia = m.accessors[prim.indices];
      if (ia.type != TINYGLTF_TYPE_SCALAR) ctx.invalid(what + ": indices accessor " + std::to_string(prim.indices) + " is not SCALAR");
      if (ia.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE && ia.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
          ia.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
        ctx.invalid(what + ": indices accessor " + std::to_string(prim.indices) + " must have an unsigned integer componentType");
      if (ia.normalized) ctx.invalid(what + ": indices accessor " + std::to_string(prim.indices) + " must not be normalized");
      const std::vector<double> raw = readAccessor(ctx, m, prim.indices, what + " indices");
      idx.reserve(raw.size());
      for (size_t i = 0; i < raw.size(); ++i) {
        if (raw[i] >= double(count))
          ctx.invalid(what + ": indices accessor " + std::to_string(prim.indices) + " element " + std::to_string(i) + " is " +
                      std::to_string(uint64_t(raw[i])) + ", past the " + std::to_string(count) + " vertices");
        idx.push_back(uint32_t(raw[i]));
      }
    } else {
      idx.resize(count);
      for (size_t i = 0; i < count; ++i) idx[i] = uint32_t(i);
    }
    const bool isTriangleList = prim.mode == TINYGLTF_MODE_TRIANGLES;
    if (isTriangleList && idx.size() % 3 != 0)
      ctx.invalid(what + ": " + std::to_string(idx.size()) + " vertices do not make whole triangles");

    Primitive out;
    out.node = nodeIndex;
    out.mesh = meshIndex;
    out.primitive = primIndex;
    out.material = prim.material >= 0 ? prim.material : int(scene.materials.size()) - 1;
    out.world = world;
    out.subdivision = subdivisionScheme(m.nodes[nodeIndex].extras, "node " + std::to_string(nodeIndex));
    if (out.subdivision == SubdivisionScheme::kNone)
      out.subdivision = subdivisionScheme(m.meshes[meshIndex].extras, "mesh " + std::to_string(meshIndex));
    out.positions.resize(count);
    for (size_t i = 0; i < count; ++i) out.positions[i] = transformPoint(world, {pos[3 * i], pos[3 * i + 1], pos[3 * i + 2]});
    const NormalMatrix nm = normalMatrix(world);
    const bool mirrored = nm.determinant < 0;
    out.triangles = triangulate(prim.mode, idx);
    if (mirrored)  // glTF: a negative determinant flips the front face to clockwise
      for (auto& t : out.triangles) std::swap(t[1], t[2]);

    // Zero-area triangles carry no light; drop them and say how many.
    size_t dropped = 0;
    std::erase_if(out.triangles, [&](const std::array<uint32_t, 3>& t) {
      const Vec3 n = cross(out.positions[t[1]] - out.positions[t[0]], out.positions[t[2]] - out.positions[t[0]]);
      const bool degenerate = !(length(n) > 0);
      dropped += degenerate;
      return degenerate;
    });
    if (dropped)
      ctx.warn(what + ": " + std::to_string(dropped) + " zero-area triangle" + (dropped > 1 ? "s" : "") + " dropped");

    out.normals.assign(count, Vec3{});
    auto nIt = prim.attributes.find("NORMAL");
    bool repaired = false;
    if (nIt != prim.attributes.end() && m.accessors[nIt->second].count == count &&
        m.accessors[nIt->second].type == TINYGLTF_TYPE_VEC3) {
      const std::vector<double> nrm = readAccessor(ctx, m, nIt->second, what + " NORMAL");
      const double tolerance = normalLengthTolerance(m.accessors[nIt->second]);
      out.hasNormals = true;
      for (size_t i = 0; i < count; ++i) {
        const Vec3 n{nrm[3 * i], nrm[3 * i + 1], nrm[3 * i + 2]};
        const double len = length(n);
        if (!isFinite(n) || std::abs(len - 1) > tolerance) {
          repaired = true;
          out.hasNormals = false;
          break;
        }
        out.normals[i] = transformNormal(nm, n);
      }
      if (repaired)
        ctx.warn(what + ": NORMAL accessor " + std::to_string(nIt->second) +
                 " has non-unit or non-finite normals; replaced by flat normals from the winding");
    } else if (nIt != prim.attributes.end()) {
      ctx.invalid(what + ": NORMAL accessor " + std::to_string(nIt->second) + " does not match POSITION (count or type)");
    }
    if (!out.hasNormals) {
      // glTF: without NORMAL, use flat normals. Area-weighted face normals per vertex; a vertex
      // shared by non-coplanar triangles is split by the tessellator, which uses face normals.
      std::fill(out.normals.begin(), out.normals.end(), Vec3{});
      for (const auto& t : out.triangles) {
        const Vec3 n = cross(out.positions[t[1]] - out.positions[t[0]], out.positions[t[2]] - out.positions[t[0]]);
        for (uint32_t v : t) out.normals[v] += n;
      }
      for (auto& n : out.normals) n = normalize(n);
    }
    checkTexcoords(prim, what);
    readTexcoords(prim, what, out);
    scene.primitives.push_back(std::move(out));
  }

  // "extras": {"subdivision": {"scheme": "catmull-clark" | "loop"}} marks a subdivision surface.
  SubdivisionScheme subdivisionScheme(const tinygltf::Value& extras, const std::string& what) {
    if (!extras.IsObject() || !extras.Has("subdivision")) return SubdivisionScheme::kNone;
    const tinygltf::Value& scheme = extras.Get("subdivision").Get("scheme");
    const std::string name = scheme.IsString() ? scheme.Get<std::string>() : "";
    if (name == "catmull-clark") return SubdivisionScheme::kCatmullClark;
    if (name == "loop") return SubdivisionScheme::kLoop;
    ctx.invalid(what + ": extras.subdivision.scheme must be \"catmull-clark\" or \"loop\"");
  }

  // The TEXCOORD_n sets the material's light textures use.
  void readTexcoords(const tinygltf::Primitive& prim, const std::string& what, Primitive& out) {
    const Material& mat = scene.materials[out.material];
    for (const TextureRef* ref : {&mat.baseColorTexture, &mat.emissiveTexture}) {
      if (ref->texture < 0 || ref->texCoord < 0 || ref->texCoord > 7) continue;
      if (int(out.texcoords.size()) > ref->texCoord && !out.texcoords[ref->texCoord].empty()) continue;
      auto it = prim.attributes.find("TEXCOORD_" + std::to_string(ref->texCoord));
      if (it == prim.attributes.end()) continue;  // checkTexcoords reports the glTF's own slots
      const auto& acc = m.accessors[it->second];
      if (acc.type != TINYGLTF_TYPE_VEC2 || acc.count != out.positions.size())
        ctx.invalid(what + ": TEXCOORD_" + std::to_string(ref->texCoord) + " accessor " + std::to_string(it->second) +
                    " is not VEC2 with one value per vertex");
      const std::vector<double> uv = readAccessor(ctx, m, it->second, what + " TEXCOORD_" + std::to_string(ref->texCoord));
      out.texcoords.resize(std::max<size_t>(out.texcoords.size(), ref->texCoord + 1));
      auto& set = out.texcoords[ref->texCoord];
      set.resize(acc.count);
      for (size_t i = 0; i < acc.count; ++i) {
        if (!std::isfinite(uv[2 * i]) || !std::isfinite(uv[2 * i + 1]))
          ctx.invalid(what + ": TEXCOORD_" + std::to_string(ref->texCoord) + " element " + std::to_string(i) + " is not finite");
        set[i] = {uv[2 * i], uv[2 * i + 1]};
      }
    }
  }

  // Every texture a material uses must find its TEXCOORD_n on the primitive.
  void checkTexcoords(const tinygltf::Primitive& prim, const std::string& what) {
    if (prim.material < 0) return;
    const auto& mat = m.materials[prim.material];
    const std::pair<const char*, std::pair<int, int>> uses[] = {
        {"baseColorTexture", {mat.pbrMetallicRoughness.baseColorTexture.index, mat.pbrMetallicRoughness.baseColorTexture.texCoord}},
        {"metallicRoughnessTexture", {mat.pbrMetallicRoughness.metallicRoughnessTexture.index, mat.pbrMetallicRoughness.metallicRoughnessTexture.texCoord}},
        {"normalTexture", {mat.normalTexture.index, mat.normalTexture.texCoord}},
        {"occlusionTexture", {mat.occlusionTexture.index, mat.occlusionTexture.texCoord}},
        {"emissiveTexture", {mat.emissiveTexture.index, mat.emissiveTexture.texCoord}}};
    for (const auto& [slot, use] : uses) {
      if (use.first < 0) continue;
      const std::string semantic = "TEXCOORD_" + std::to_string(use.second);
      if (!prim.attributes.count(semantic))
        ctx.invalid(what + ": material " + std::to_string(prim.material) + " " + slot + " needs " + semantic +
                    ", which the primitive does not have");
    }
  }

  // The node tree below `root`, depth first in document order. Iterative: a chain of 30,000 nodes is
  // valid glTF and must not overflow the stack.
  void visit(int root, const Matrix4& rootParent) {
    std::vector<std::pair<int, Matrix4>> stack{{root, rootParent}};  // node, its parent's world
    while (!stack.empty()) {
      const auto [nodeIndex, parentWorld] = stack.back();
      stack.pop_back();
      const auto& node = m.nodes[nodeIndex];
      const Matrix4 world = multiply(parentWorld, localMatrix(node));
      if (node.mesh >= 0) {
        countInstance(nodeIndex, node.mesh);
        for (size_t p = 0; p < m.meshes[node.mesh].primitives.size(); ++p) addPrimitive(nodeIndex, node.mesh, int(p), world);
      }
      if (auto it = node.extensions.find("KHR_lights_punctual"); it != node.extensions.end()) addLight(nodeIndex, it->second, world);
      for (auto child = node.children.rbegin(); child != node.children.rend(); ++child) stack.push_back({*child, world});
    }
  }

  // Instancing multiplies a mesh by the nodes that place it: 20k triangles on 50,000 nodes are a
  // billion. The scene's size is estimated from the accessor counts before anything is read.
  void countInstance(int nodeIndex, int meshIndex) {
    for (size_t p = 0; p < m.meshes[meshIndex].primitives.size(); ++p) {
      const auto& prim = m.meshes[meshIndex].primitives[p];
      auto pos = prim.attributes.find("POSITION");
      if (pos == prim.attributes.end()) continue;
      const std::string what = "mesh " + std::to_string(meshIndex) + " primitive " + std::to_string(p);
      checkAccessorRange(ctx, m, pos->second, what + " POSITION");
      if (prim.indices >= 0) checkAccessorRange(ctx, m, prim.indices, what + " indices");
      const double vertices = double(m.accessors[pos->second].count);
      const double indices = prim.indices >= 0 ? double(m.accessors[prim.indices].count) : vertices;
      instancedVertices += vertices;
      instancedTriangles += prim.mode == TINYGLTF_MODE_TRIANGLES ? indices / 3 : std::max(0.0, indices - 2);
    }
    ctx.budget(instancedVertices * kBytesPerVertex + instancedTriangles * kBytesPerTriangle,
               "node " + std::to_string(nodeIndex) + ": the scene with this instance of mesh " + std::to_string(meshIndex) +
                   " (" + std::to_string(uint64_t(instancedTriangles)) + " triangles in all)");
  }

  void addLight(int nodeIndex, const tinygltf::Value& ext, const Matrix4& world) {
    const std::string what = "node " + std::to_string(nodeIndex) + " KHR_lights_punctual";
    const tinygltf::Value& index = ext.Get("light");
    if (!index.IsNumber() && !index.IsInt()) ctx.invalid(what + ": \"light\" must be an index");
    const int li = index.IsInt() ? index.Get<int>() : int(index.GetNumberAsDouble());
    if (li < 0 || li >= int(m.lights.size()))
      ctx.invalid(what + ": light " + std::to_string(li) + " does not exist (the file has " + std::to_string(m.lights.size()) + ")");
    const tinygltf::Light& light = m.lights[li];
    PunctualLight out;
    out.name = light.name.empty() ? "light " + std::to_string(li) : light.name;
    out.node = nodeIndex;
    if (light.type == "point") out.type = PunctualLight::Type::kPoint;
    else if (light.type == "spot") out.type = PunctualLight::Type::kSpot;
    else if (light.type == "directional") out.type = PunctualLight::Type::kDirectional;
    else ctx.invalid("light " + std::to_string(li) + ": unknown type \"" + light.type + "\"");
    Vec3 color{1, 1, 1};
    if (light.color.size() == 3) color = {light.color[0], light.color[1], light.color[2]};
    if (!isFinite(color) || !std::isfinite(light.intensity) || light.intensity < 0 || color.x < 0 || color.y < 0 || color.z < 0)
      ctx.invalid("light " + std::to_string(li) + ": color and intensity must be finite and non-negative");
    if (light.intensity * std::max({color.x, color.y, color.z}) > kMaxEmission)
      ctx.invalid("light " + std::to_string(li) + ": intensity above 1e20; no physical light is that bright");
    out.intensity = color * light.intensity;
    out.range = light.range > 0 && std::isfinite(light.range) ? light.range : 0;
    out.innerCone = light.spot.innerConeAngle;
    out.outerCone = light.spot.outerConeAngle;
    out.position = transformPoint(world, {0, 0, 0});
    // The light shines down its local −z; directions transform by the upper 3×3.
    out.direction = normalize(Vec3{-world[8], -world[9], -world[10]});
    scene.lights.push_back(out);
  }
};

}  // namespace

bool Scene::hasEmitter() const {
  for (const PunctualLight& light : lights)
    if (light.intensity.x > 0 || light.intensity.y > 0 || light.intensity.z > 0) return true;
  for (const Primitive& p : primitives) {
    const Vec3& e = materials[p.material].emission;
    if (!p.triangles.empty() && (e.x > 0 || e.y > 0 || e.z > 0)) return true;
  }
  return false;
}

Scene importScene(const std::string& path, const ImportOptions& options) {
  if (lowerExtension(path) == ".bpt") return importBezierPatches(path, options.maxMemoryBytes);
  std::string name = std::filesystem::path(path).filename().string();
  const std::vector<unsigned char> bytes = readRegularFile(path, name.empty() ? path : name, options.maxMemoryBytes);
  return importGltfBytes(bytes, path, options);
}

Scene importGltfBytes(const std::vector<unsigned char>& bytes, const std::string& path, const ImportOptions& options) {
  Scene scene;
  scene.path = path;
  Context ctx{std::filesystem::path(path).filename().string(), &scene.warnings, options.maxMemoryBytes};
  if (ctx.file.empty()) ctx.file = path;

  const bool binary = bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0;
  std::string jsonText;
  uint64_t binBytes = 0;
  if (binary) {
    jsonText = glbJson(ctx, bytes, binBytes);
  } else {
    size_t first = 0;
    while (first < bytes.size() && std::isspace(bytes[first])) ++first;
    if (first == bytes.size() || bytes[first] != '{')
      ctx.invalid(bytes.empty() ? "not a glTF file (empty)" : "not a glTF file (neither GLB nor JSON)");
    jsonText.assign(bytes.begin(), bytes.end());
  }
  if (std::string problem = checkJsonNesting(jsonText); !problem.empty()) ctx.invalid(problem);
  if (std::string problem = checkGltfSchema(jsonText); !problem.empty()) ctx.invalid(problem);
  const JsonSummary summary = summarizeGltfJson(jsonText);
  if (std::string message = extensionRefused(summary); !message.empty()) {
    if (options.requireSupportedExtensions) ctx.fail(ExitCode::kUnsupported, message);
    ctx.warn(message + "; its geometry is not read");
    scene.counts = summary.counts;
    scene.extensionsUsed = summary.extensionsUsed;
    return scene;
  }

  for (const std::string& ext : summary.extensionsUsed)
    if (const KnownExtension* known = findExtension(ext); known && known->use == ExtensionUse::kApproximated)
      ctx.warn(ext + " is approximated: " + known->note);

  std::vector<unsigned char> glb;  // the GLB again, when its JSON had to change for tinygltf
  bool changed = false;
  for (auto fix : {withoutDracoIndices, withMeshoptFallbacksStubbed})
    if (std::string fixed = fix(jsonText); !fixed.empty()) {
      jsonText = std::move(fixed);
      changed = true;
    }
  if (changed && binary) glb = repackGlb(bytes, jsonText);

  // Every file the document points at, through the one resolver, before tinygltf opens any.
  std::vector<ExternalUri> external;
  if (std::string problem = checkGltfStructure(jsonText, binary, binBytes, external); !problem.empty()) ctx.invalid(problem);
  const AssetFolder folder = assetFolderOf(path, options.allowOutsidePaths, options.maxMemoryBytes);
  double externalBytes = double(bytes.size());
  for (const ExternalUri& uri : external) {
    std::string file;
    bool outside = false;
    if (std::string problem = resolveAssetUri(folder, uri.uri, file, outside); !problem.empty()) ctx.invalid(uri.element + ": " + problem);
    if (outside) ctx.warn(uri.element + ": reads " + file + ", outside the asset's folder (--allow-outside-paths)");
    std::error_code ec;
    const uint64_t size = std::filesystem::file_size(file, ec);
    if (uri.isBuffer && !ec && size != uri.byteLength)
      ctx.invalid(uri.element + ": byteLength " + std::to_string(uri.byteLength) + ", but " + oneLine(uri.uri, 80) + " holds " +
                  std::to_string(size) + " bytes");
    externalBytes += double(size);
    ctx.budget(externalBytes, uri.element + " (with the files before it)");
  }

  auto document = std::make_shared<SourceDocument>();
  document->binary = binary;
  tinygltf::TinyGLTF loader;
  loader.SetImageLoader(keepImageBytes, nullptr);
  readAssetFilesThrough(loader, &folder);
  loader.SetStoreOriginalJSONForExtrasAndExtensions(false);
  std::string err, warn;
  const std::string baseDir = folder.folder.string();
  const std::vector<unsigned char>& container = glb.empty() ? bytes : glb;
  bool ok = binary ? loader.LoadBinaryFromMemory(&document->model, &err, &warn, container.data(), unsigned(container.size()), baseDir)
                   : loader.LoadASCIIFromString(&document->model, &err, &warn, jsonText.data(), unsigned(jsonText.size()), baseDir);
  if (!ok) ctx.invalid(firstLine(err.empty() ? std::string("could not be parsed as glTF") : err));
  tinygltf::Model& m = document->model;
  // Meshopt first: it decodes buffer views, which a Draco stream could in principle sit in.
  if (std::string problem = decodeMeshoptBufferViews(m); !problem.empty()) ctx.invalid(problem);
  if (std::string problem = decodeDracoPrimitives(m); !problem.empty()) ctx.invalid(problem);
  if (m.asset.version.rfind("2.", 0) != 0)
    ctx.fail(ExitCode::kUnsupported, "asset version \"" + m.asset.version + "\" (only glTF 2.0 is supported)");
  for (size_t i = 0; i < m.images.size(); ++i)
    if (m.images[i].bufferView < 0 && m.images[i].image.empty())
      ctx.invalid("image " + std::to_string(i) + ": cannot read \"" + m.images[i].uri + "\"");

  checkReferences(ctx, m);
  if (m.defaultScene >= int(m.scenes.size()))
    ctx.invalid("scene " + std::to_string(m.defaultScene) + " does not exist (the file has " + std::to_string(m.scenes.size()) + " scenes)");

  for (size_t i = 0; i < m.materials.size(); ++i) scene.materials.push_back(readMaterial(ctx, m.materials[i], int(i)));
  scene.materials.push_back(readMaterial(ctx, tinygltf::Material{}, -1));
  scene.materials.back().name = "default material";
  decodeTextures(ctx, m, scene);

  Importer importer{ctx, m, scene, {}};
  int sceneIndex = m.defaultScene >= 0 ? m.defaultScene : (m.scenes.empty() ? -1 : 0);
  if (options.scene >= 0) {
    if (options.scene >= int(m.scenes.size()))
      ctx.fail(ExitCode::kUsage, "--scene " + std::to_string(options.scene) + ": the file has " + std::to_string(m.scenes.size()) + " scenes");
    sceneIndex = options.scene;
  }
  if (sceneIndex >= 0)
    for (int root : m.scenes[sceneIndex].nodes) importer.visit(root, kIdentity);
  if (!m.skins.empty()) ctx.warn("skins are baked at rest pose (" + std::to_string(m.skins.size()) + " skin(s))");
  for (size_t i = 0; i < m.meshes.size(); ++i)
    for (const auto& prim : m.meshes[i].primitives)
      if (!prim.targets.empty()) {
        ctx.warn("mesh " + std::to_string(i) + ": morph targets are baked at rest pose (weights ignored)");
        break;
      }

  SceneCounts& c = scene.counts;
  c.nodes = int(m.nodes.size());
  c.meshes = int(m.meshes.size());
  for (const auto& mesh : m.meshes) c.primitives += int(mesh.primitives.size());
  c.materials = int(m.materials.size());
  c.textures = int(m.textures.size());
  c.images = int(m.images.size());
  c.cameras = int(m.cameras.size());
  c.lights = int(m.lights.size());
  c.skins = int(m.skins.size());
  c.animations = int(m.animations.size());
  c.scenes = int(m.scenes.size());
  for (const auto& mesh : m.meshes)
    for (const auto& prim : mesh.primitives)
      if (auto it = prim.attributes.find("POSITION"); it != prim.attributes.end()) c.vertices += m.accessors[it->second].count;
  scene.extensionsUsed = summary.extensionsUsed;  // as the file lists them (decoding drops some from the model)
  scene.document = std::move(document);
  // A mesh placed by several nodes would repeat its warnings: each is said once, in order.
  std::set<std::string> said;
  std::erase_if(scene.warnings, [&](const std::string& w) { return !said.insert(w).second; });
  return scene;
}

}  // namespace radbake

namespace radbake {

std::vector<double> readAccessorValues(const tinygltf::Model& model, int index) {
  std::vector<std::string> unused;
  return readAccessor(Context{"", &unused}, model, index, "accessor");
}

void setAccessorBounds(tinygltf::Accessor& accessor, const std::vector<float>& values, int components) {
  accessor.minValues.assign(components, std::numeric_limits<double>::infinity());
  accessor.maxValues.assign(components, -std::numeric_limits<double>::infinity());
  for (size_t i = 0; i < values.size(); ++i) {
    accessor.minValues[i % components] = std::min<double>(accessor.minValues[i % components], values[i]);
    accessor.maxValues[i % components] = std::max<double>(accessor.maxValues[i % components], values[i]);
  }
}

}  // namespace radbake

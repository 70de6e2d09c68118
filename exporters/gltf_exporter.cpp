#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "exporters/exporters.h"
#include "importers/gltf_document.h"

namespace radbake {
namespace {

constexpr int kArrayBuffer = 34962;
constexpr int kElementArrayBuffer = 34963;

std::string lowerExtension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext;
}

std::string mimeTypeOf(const tinygltf::Image& image) {
  if (!image.mimeType.empty()) return image.mimeType;
  const std::string& uri = image.uri;
  if (uri.rfind("data:", 0) == 0) return uri.substr(5, uri.find(';') - 5);
  const std::string ext = lowerExtension(uri);
  if (ext == ".jpg" || ext == ".jpeg") return "image/jpeg";
  if (ext == ".ktx2") return "image/ktx2";
  if (ext == ".webp") return "image/webp";
  return "image/png";
}

// Appends bytes to the single output buffer, 4-byte aligned (accessor components need it).
int appendView(tinygltf::Model& m, const void* data, size_t size, int target) {
  auto& bin = m.buffers[0].data;
  bin.resize((bin.size() + 3) & ~size_t(3), 0);
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = bin.size();
  view.byteLength = size;
  view.target = target;
  const auto* bytes = static_cast<const unsigned char*>(data);
  bin.insert(bin.end(), bytes, bytes + size);
  m.bufferViews.push_back(view);
  return int(m.bufferViews.size()) - 1;
}

int appendFloatAccessor(tinygltf::Model& m, const std::vector<float>& values, int type, int components,
                        bool withBounds) {
  tinygltf::Accessor acc;
  acc.bufferView = appendView(m, values.data(), values.size() * sizeof(float), kArrayBuffer);
  acc.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
  acc.type = type;
  acc.count = values.size() / components;
  if (withBounds && acc.count > 0) {
    acc.minValues.assign(components, std::numeric_limits<double>::infinity());
    acc.maxValues.assign(components, -std::numeric_limits<double>::infinity());
    for (size_t i = 0; i < values.size(); ++i) {
      acc.minValues[i % components] = std::min<double>(acc.minValues[i % components], values[i]);
      acc.maxValues[i % components] = std::max<double>(acc.maxValues[i % components], values[i]);
    }
  }
  m.accessors.push_back(acc);
  return int(m.accessors.size()) - 1;
}

// A 32-bit index accessor for a triangle list.
int appendIndexAccessor(tinygltf::Model& m, const std::vector<std::array<uint32_t, 3>>& triangles) {
  std::vector<uint32_t> indices;
  indices.reserve(triangles.size() * 3);
  for (const auto& t : triangles) indices.insert(indices.end(), t.begin(), t.end());
  tinygltf::Accessor ia;
  ia.bufferView = appendView(m, indices.data(), indices.size() * 4, kElementArrayBuffer);
  ia.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
  ia.type = TINYGLTF_TYPE_SCALAR;
  ia.count = indices.size();
  m.accessors.push_back(ia);
  return int(m.accessors.size()) - 1;
}

// One buffer holding every byte: GLB allows a single binary chunk, and a .gltf output should not
// depend on files beside the input. Buffer views keep their alignment (buffers start 8-aligned).
void consolidateBuffers(tinygltf::Model& m) {
  std::vector<unsigned char> bin;
  std::vector<size_t> offset(m.buffers.size());
  for (size_t i = 0; i < m.buffers.size(); ++i) {
    bin.resize((bin.size() + 7) & ~size_t(7), 0);
    offset[i] = bin.size();
    bin.insert(bin.end(), m.buffers[i].data.begin(), m.buffers[i].data.end());
  }
  for (auto& view : m.bufferViews) {
    view.byteOffset += offset[view.buffer];
    view.buffer = 0;
  }
  tinygltf::Buffer merged;
  if (!m.buffers.empty()) {
    merged.name = m.buffers[0].name;
    merged.extras = m.buffers[0].extras;
  }
  merged.data = std::move(bin);
  m.buffers.assign(1, std::move(merged));
  // Images referenced by URI (external files, data URIs) move into the buffer, byte for byte.
  for (auto& image : m.images) {
    if (image.bufferView >= 0) continue;
    image.mimeType = mimeTypeOf(image);
    image.bufferView = appendView(m, image.image.data(), image.image.size(), 0);
    m.bufferViews.back().target = 0;  // image data is no vertex or index data
    image.uri.clear();
  }
}

std::vector<float> radianceFloats(const std::vector<Vec3>& values) {
  std::vector<float> out;
  out.reserve(values.size() * 3);
  for (const Vec3& v : values) {
    out.push_back(float(v.x));
    out.push_back(float(v.y));
    out.push_back(float(v.z));
  }
  return out;
}

// glTF COLOR_n must stay contiguous from 0: the bake becomes COLOR_0, existing sets move up by one.
void addBakeAttributes(tinygltf::Model& m, tinygltf::Primitive& prim, const std::vector<Vec3>& radiance,
                       const std::vector<Vec3>& colors) {
  std::map<std::string, int> shifted;
  for (auto& [semantic, accessor] : prim.attributes) {
    if (semantic.rfind("COLOR_", 0) == 0) {
      std::string name = "COLOR_";
      name += std::to_string(std::stoi(semantic.substr(6)) + 1);
      shifted[name] = accessor;
    }
  }
  std::erase_if(prim.attributes, [](const auto& kv) { return kv.first.rfind("COLOR_", 0) == 0; });
  prim.attributes.insert(shifted.begin(), shifted.end());
  prim.attributes["_RADIANCE"] = appendFloatAccessor(m, radianceFloats(radiance), TINYGLTF_TYPE_VEC3, 3, false);
  prim.attributes["COLOR_0"] = appendFloatAccessor(m, radianceFloats(colors), TINYGLTF_TYPE_VEC3, 3, false);
}

// The base color texture (linear) at each output vertex of a baked primitive: an unlit viewer
// shows texture × COLOR_0, so COLOR_0 is the display value divided by it. (1, 1, 1) without one.
std::vector<Vec3> textureAtVertices(const Scene& scene, const Primitive& prim, const PrimitivePatches& patches) {
  const TextureRef& ref = scene.materials[prim.material].baseColorTexture;
  const size_t count = patches.patchVertex.size();
  std::vector<Vec3> out(count, Vec3{1, 1, 1});
  if (ref.texture < 0 || ref.texCoord >= int(prim.texcoords.size())) return out;
  const auto& uv = prim.texcoords[ref.texCoord];
  if (uv.size() != prim.positions.size()) return out;
  for (size_t v = 0; v < count; ++v) {
    std::array<double, 2> at = {0, 0};
    if (patches.keepsSourceVertices) {
      at = uv[v];
    } else {
      const SurfacePoint& sp = patches.source[v];
      const auto& t = prim.triangles[sp.triangle];
      const double w[3] = {1 - sp.w1 - sp.w2, sp.w1, sp.w2};
      for (int k = 0; k < 3; ++k) {
        at[0] += w[k] * uv[t[k]][0];
        at[1] += w[k] * uv[t[k]][1];
      }
    }
    out[v] = sampleTexture(scene, ref, at[0], at[1]);
  }
  return out;
}

// Unlit materials show base color × COLOR_0 and nothing else, so the base color factor becomes
// white (alpha kept) and the original factor is kept in extras.radbake for whoever re-bakes.
void makeUnlit(tinygltf::Material& material) {
  auto& factor = material.pbrMetallicRoughness.baseColorFactor;
  tinygltf::Value::Object radbake;
  tinygltf::Value::Array original;
  for (double c : factor) original.emplace_back(c);
  radbake["baseColorFactor"] = tinygltf::Value(original);
  tinygltf::Value::Object extras = material.extras.IsObject() ? material.extras.Get<tinygltf::Value::Object>()
                                                              : tinygltf::Value::Object{};
  extras["radbake"] = tinygltf::Value(radbake);
  material.extras = tinygltf::Value(extras);
  factor = {1, 1, 1, factor.size() == 4 ? factor[3] : 1.0};
  material.extensions["KHR_materials_unlit"] = tinygltf::Value(tinygltf::Value::Object{});
}

// Inverse of an affine column-major 4×4 matrix (node to world), by the 3×3 adjugate.
std::array<double, 16> invertAffine(const std::array<double, 16>& m) {
  const double a = m[0], b = m[4], c = m[8], d = m[1], e = m[5], f = m[9], g = m[2], h = m[6], i = m[10];
  const double det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g);
  const double r[9] = {(e * i - f * h) / det, (c * h - b * i) / det, (b * f - c * e) / det,
                       (f * g - d * i) / det, (a * i - c * g) / det, (c * d - a * f) / det,
                       (d * h - e * g) / det, (b * g - a * h) / det, (a * e - b * d) / det};  // row-major
  std::array<double, 16> out{r[0], r[3], r[6], 0, r[1], r[4], r[7], 0, r[2], r[5], r[8], 0, 0, 0, 0, 1};
  const double tx = m[12], ty = m[13], tz = m[14];
  out[12] = -(r[0] * tx + r[1] * ty + r[2] * tz);
  out[13] = -(r[3] * tx + r[4] * ty + r[5] * tz);
  out[14] = -(r[6] * tx + r[7] * ty + r[8] * tz);
  return out;
}

Vec3 applyAffine(const std::array<double, 16>& m, const Vec3& p) {
  return {m[0] * p.x + m[4] * p.y + m[8] * p.z + m[12], m[1] * p.x + m[5] * p.y + m[9] * p.z + m[13],
          m[2] * p.x + m[6] * p.y + m[10] * p.z + m[14]};
}

// The tessellated primitive: every attribute of the source interpolated at the new vertices
// (barycentric on the source triangle; integer sets such as JOINTS_n from the nearest corner).
tinygltf::Primitive tessellatedPrimitive(tinygltf::Model& m, const tinygltf::Primitive& source, const Primitive& prim,
                                         const PrimitivePatches& patches) {
  tinygltf::Primitive out = source;
  out.attributes.clear();
  out.targets.clear();
  out.mode = TINYGLTF_MODE_TRIANGLES;

  // Source triangles in glTF vertex indices, as the importer built them (winding may be flipped
  // for mirrored nodes, which does not change the weights' meaning).
  auto interpolate = [&](int accessorIndex, bool nearest, bool renormalize3) {
    const auto& acc = m.accessors[accessorIndex];
    const int comps = int(tinygltf::GetNumComponentsInType(acc.type));
    const std::vector<double> values = readAccessorValues(m, accessorIndex);
    std::vector<float> result;
    result.reserve(patches.source.size() * comps);
    for (const SurfacePoint& sp : patches.source) {
      const auto& t = prim.triangles[sp.triangle];
      const double w[3] = {1 - sp.w1 - sp.w2, sp.w1, sp.w2};
      int best = int(std::max_element(w, w + 3) - w);
      double v[16] = {};
      for (int c = 0; c < comps; ++c)
        v[c] = nearest ? values[size_t(t[best]) * comps + c]
                       : w[0] * values[size_t(t[0]) * comps + c] + w[1] * values[size_t(t[1]) * comps + c] +
                             w[2] * values[size_t(t[2]) * comps + c];
      if (renormalize3) {
        const double len = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        if (len > 0) for (int c = 0; c < 3; ++c) v[c] /= len;
        if (comps == 4) v[3] = values[size_t(t[best]) * comps + 3];  // tangent handedness
      }
      for (int c = 0; c < comps; ++c) result.push_back(float(v[c]));
    }
    return std::pair{result, comps};
  };

  if (!patches.positions.empty()) {
    // A subdivision surface: positions and normals come from the limit surface (world space),
    // brought back to the node's space; the other attributes are interpolated from the cage.
    const auto inverse = invertAffine(prim.world);
    std::vector<float> positions, normals;
    for (size_t v = 0; v < patches.positions.size(); ++v) {
      const Vec3 p = applyAffine(inverse, patches.positions[v]);
      // Normals go back by the transpose of the world matrix (the inverse of its inverse transpose).
      const auto& w = prim.world;
      const Vec3& n = patches.normals[v];
      const Vec3 local = normalize(Vec3{w[0] * n.x + w[1] * n.y + w[2] * n.z, w[4] * n.x + w[5] * n.y + w[6] * n.z,
                                        w[8] * n.x + w[9] * n.y + w[10] * n.z});
      positions.insert(positions.end(), {float(p.x), float(p.y), float(p.z)});
      normals.insert(normals.end(), {float(local.x), float(local.y), float(local.z)});
    }
    out.attributes["POSITION"] = appendFloatAccessor(m, positions, TINYGLTF_TYPE_VEC3, 3, true);
    out.attributes["NORMAL"] = appendFloatAccessor(m, normals, TINYGLTF_TYPE_VEC3, 3, false);
  }
  for (const auto& [semantic, accessor] : source.attributes) {
    if (!patches.positions.empty() && (semantic == "POSITION" || semantic == "NORMAL")) continue;
    const auto& acc = m.accessors[accessor];
    const bool integerSet = semantic.rfind("JOINTS_", 0) == 0;
    const bool direction = semantic == "NORMAL" || semantic == "TANGENT";
    auto [values, comps] = interpolate(accessor, integerSet, direction);
    if (integerSet) {
      // JOINTS stay unsigned integers of the source's width.
      std::vector<uint16_t> joints(values.begin(), values.end());
      tinygltf::Accessor ja;
      ja.bufferView = appendView(m, joints.data(), joints.size() * 2, kArrayBuffer);
      ja.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
      ja.type = acc.type;
      ja.count = joints.size() / comps;
      m.accessors.push_back(ja);
      out.attributes[semantic] = int(m.accessors.size()) - 1;
    } else {
      out.attributes[semantic] = appendFloatAccessor(m, values, acc.type, comps, semantic == "POSITION");
    }
  }
  out.indices = appendIndexAccessor(m, patches.triangles);
  return out;
}

// Curved input without a glTF primitive (a .bpt): a new node, mesh and material carry it.
void addGeneratedSurface(tinygltf::Model& m, const Scene& scene, const PatchMesh& mesh, const GeneratedSurface& surface,
                         const std::vector<Vec3>& radiance, const std::vector<Vec3>& colors) {
  const Material& material = scene.materials[surface.material];
  tinygltf::Material mat;
  mat.name = material.name;
  mat.pbrMetallicRoughness.baseColorFactor = {material.reflectance.x, material.reflectance.y, material.reflectance.z, 1};
  mat.pbrMetallicRoughness.metallicFactor = 0;
  mat.pbrMetallicRoughness.roughnessFactor = 1;
  makeUnlit(mat);
  m.materials.push_back(mat);

  std::vector<float> positions, normals;
  for (uint32_t v : surface.patchVertex) {
    const Vec3 &p = mesh.positions[v], &n = mesh.normals[v];
    positions.insert(positions.end(), {float(p.x), float(p.y), float(p.z)});
    normals.insert(normals.end(), {float(n.x), float(n.y), float(n.z)});
  }
  tinygltf::Primitive prim;
  prim.mode = TINYGLTF_MODE_TRIANGLES;
  prim.material = int(m.materials.size()) - 1;
  prim.attributes["POSITION"] = appendFloatAccessor(m, positions, TINYGLTF_TYPE_VEC3, 3, true);
  prim.attributes["NORMAL"] = appendFloatAccessor(m, normals, TINYGLTF_TYPE_VEC3, 3, false);
  prim.indices = appendIndexAccessor(m, surface.triangles);
  addBakeAttributes(m, prim, radiance, colors);

  tinygltf::Mesh out;
  out.name = std::filesystem::path(scene.path).stem().string();
  out.primitives.push_back(prim);
  m.meshes.push_back(out);
  tinygltf::Node node;
  node.name = out.name;
  node.mesh = int(m.meshes.size()) - 1;
  m.nodes.push_back(node);
  if (m.scenes.empty()) m.scenes.emplace_back();
  m.scenes[m.defaultScene >= 0 ? m.defaultScene : 0].nodes.push_back(int(m.nodes.size()) - 1);
}

void appendU32(std::string& out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(char((v >> (8 * i)) & 0xFF));
}

// tinygltf writes the JSON (buffer as a data URI); radbake then repairs what tinygltf 2.7 gets wrong
// and, for .glb, packs the container itself with the buffer as the BIN chunk.
std::string serialize(tinygltf::Model& m, bool binary, bool pretty) {
  std::vector<unsigned char> bin;
  if (!m.buffers.empty() && m.buffers[0].data.empty()) m.buffers.clear();  // a glTF buffer must not be empty
  if (binary && !m.buffers.empty()) bin = m.buffers[0].data;
  tinygltf::TinyGLTF writer;
  writer.SetImageWriter([](const std::string*, const std::string*, const tinygltf::Image*, bool, std::string*, void*) {
    return false;  // images are already inside the buffer; nothing is written beside the output
  }, nullptr);
  std::ostringstream stream;
  if (!writer.WriteGltfSceneToStream(&m, stream, false, false))
    throw Error(ExitCode::kCannotWrite, "serializing the glTF failed");
  nlohmann::json doc = nlohmann::json::parse(stream.str());
  // tinygltf writes a scene without nodes as null; the schema wants an object.
  if (auto it = doc.find("scenes"); it != doc.end())
    for (auto& scene : *it)
      if (scene.is_null()) scene = nlohmann::json::object();
  if (!binary) return doc.dump(pretty ? 2 : -1);

  if (!bin.empty()) doc["buffers"][0].erase("uri");
  std::string jsonText = doc.dump();
  while (jsonText.size() % 4) jsonText.push_back(' ');
  while (bin.size() % 4) bin.push_back(0);
  std::string out;
  const uint32_t total = 12 + 8 + uint32_t(jsonText.size()) + (bin.empty() ? 0 : 8 + uint32_t(bin.size()));
  out.reserve(total);
  out += "glTF";
  appendU32(out, 2);
  appendU32(out, total);
  appendU32(out, uint32_t(jsonText.size()));
  appendU32(out, 0x4E4F534A);  // "JSON"
  out += jsonText;
  if (!bin.empty()) {
    appendU32(out, uint32_t(bin.size()));
    appendU32(out, 0x004E4942);  // "BIN\0"
    out.append(reinterpret_cast<const char*>(bin.data()), bin.size());
  }
  return out;
}

}  // namespace

void writeFileAtomically(const std::string& path, const std::string& bytes) {
  namespace fs = std::filesystem;
  const fs::path target(path);
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw Error(ExitCode::kCannotWrite, path + ": cannot write: directory " + dir.string() + " does not exist");
  std::string tempName = ".";
  tempName += target.filename().string();
  tempName += ".radbake-";
  tempName += std::to_string(::getpid());
  tempName += ".tmp";
  const fs::path temp = dir / tempName;
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    if (!out) throw Error(ExitCode::kCannotWrite, path + ": cannot write: " + std::strerror(errno));
    out.write(bytes.data(), std::streamsize(bytes.size()));
    out.close();
    if (!out) {
      fs::remove(temp, ec);
      throw Error(ExitCode::kCannotWrite, path + ": cannot write: " + std::strerror(errno));
    }
  }
  fs::rename(temp, target, ec);
  if (ec) {
    fs::remove(temp, ec);
    throw Error(ExitCode::kCannotWrite, path + ": cannot write: " + ec.message());
  }
}

ExportSummary writeGltf(const std::string& path, const Scene& scene, const PatchMesh& mesh,
                        const std::vector<Vec3>& vertexRadiance, const std::vector<Vec3>& patchRadiance,
                        const ExportOptions& options) {
  const std::string ext = lowerExtension(path);
  if (ext != ".glb" && ext != ".gltf")
    throw Error(ExitCode::kUsage, path + ": output must end in .glb or .gltf");
  tinygltf::Model m;
  if (scene.document) {
    m = scene.document->model;
  } else {
    m.asset.version = "2.0";
    m.asset.generator = "radbake";
    m.scenes.emplace_back();
    m.defaultScene = 0;
  }
  consolidateBuffers(m);
  ExportSummary summary;

  // Each node instance of a mesh gets its own bake: the first instance keeps the mesh, later ones
  // get a copy (appended, so the original mesh indices stay valid).
  std::map<int, int> firstNodeOfMesh;
  std::map<int, int> meshOfNode;
  for (const Primitive& prim : scene.primitives) {
    if (meshOfNode.count(prim.node)) continue;
    auto [it, first] = firstNodeOfMesh.try_emplace(prim.mesh, prim.node);
    if (first) {
      meshOfNode[prim.node] = prim.mesh;
    } else {
      tinygltf::Mesh copy = m.meshes[prim.mesh];
      copy.name = (copy.name.empty() ? "mesh " + std::to_string(prim.mesh) : copy.name) + " (baked for node " +
                  std::to_string(prim.node) + ")";
      m.meshes.push_back(copy);
      meshOfNode[prim.node] = int(m.meshes.size()) - 1;
      m.nodes[prim.node].mesh = meshOfNode[prim.node];
      ++summary.clonedMeshes;
    }
  }

  // The radiance each output vertex carries, per baked primitive and per generated surface.
  std::vector<std::vector<Vec3>> radiance(scene.primitives.size() + mesh.generated.size());
  for (size_t p = 0; p < scene.primitives.size(); ++p) {
    const PrimitivePatches& patches = mesh.primitives[p];
    radiance[p].resize(patches.patchVertex.size());
    for (size_t v = 0; v < radiance[p].size(); ++v)
      radiance[p][v] = !patches.patch.empty() && !patchRadiance.empty() ? patchRadiance[patches.patch[v]]
                       : patches.patchVertex[v] == UINT32_MAX ? scene.materials[scene.primitives[p].material].emission
                                                              : vertexRadiance[patches.patchVertex[v]];
  }
  for (size_t g = 0; g < mesh.generated.size(); ++g)
    for (uint32_t v : mesh.generated[g].patchVertex) radiance[scene.primitives.size() + g].push_back(vertexRadiance[v]);

  // Display shaping: one exposure for the whole scene, set from the surfaces that only reflect.
  auto materialOf = [&](size_t k) -> const Material& {
    return scene.materials[k < scene.primitives.size() ? scene.primitives[k].material
                                                       : mesh.generated[k - scene.primitives.size()].material];
  };
  std::vector<Vec3> reflected, all;
  for (size_t k = 0; k < radiance.size(); ++k) {
    const Material& material = materialOf(k);
    const bool emits = material.emission.x > 0 || material.emission.y > 0 || material.emission.z > 0;
    if (!emits) reflected.insert(reflected.end(), radiance[k].begin(), radiance[k].end());
    all.insert(all.end(), radiance[k].begin(), radiance[k].end());
  }
  summary.display = resolveDisplay(options.display, reflected);
  const std::vector<Vec3> codes = toDisplay(summary.display, all);

  // COLOR_0 = the display value back in glTF's linear color, divided by what the unlit material
  // multiplies it with (its base color texture), clamped to glTF's [0,1].
  size_t next = 0;
  auto colorsOf = [&](size_t k, const std::vector<Vec3>& texture) {
    std::vector<Vec3> colors(radiance[k].size());
    for (size_t v = 0; v < colors.size(); ++v, ++next) {
      const Vec3& code = codes[next];
      const Vec3 t = texture.empty() ? Vec3{1, 1, 1} : texture[v];
      auto channel = [&](double c, double tex) {
        const double wanted = srgbDecode(c);
        if (wanted <= 0) return 0.0;
        if (wanted > tex + 1e-6) ++summary.clampedColors;
        return tex > 0 ? std::min(1.0, wanted / tex) : 1.0;
      };
      colors[v] = {channel(code.x, t.x), channel(code.y, t.y), channel(code.z, t.z)};
    }
    return colors;
  };

  std::set<int> unlit;
  int defaultUnlit = -1;  // primitives without a material get one unlit white material
  for (size_t p = 0; p < scene.primitives.size(); ++p) {
    const Primitive& prim = scene.primitives[p];
    const PrimitivePatches& patches = mesh.primitives[p];
    tinygltf::Primitive& target = m.meshes[meshOfNode[prim.node]].primitives[prim.primitive];
    if (!patches.keepsSourceVertices) target = tessellatedPrimitive(m, target, prim, patches);
    addBakeAttributes(m, target, radiance[p], colorsOf(p, textureAtVertices(scene, prim, patches)));
    if (target.material >= 0) {
      unlit.insert(target.material);
    } else {
      if (defaultUnlit < 0) {
        tinygltf::Material material;
        material.name = "radbake default (unlit)";
        makeUnlit(material);
        m.materials.push_back(material);
        defaultUnlit = int(m.materials.size()) - 1;
      }
      target.material = defaultUnlit;
    }
    ++summary.bakedPrimitives;
    summary.writtenVertices += radiance[p].size();
  }
  for (int material : unlit) makeUnlit(m.materials[material]);
  summary.unlitMaterials = int(unlit.size()) + (defaultUnlit >= 0);

  for (size_t g = 0; g < mesh.generated.size(); ++g) {
    const size_t k = scene.primitives.size() + g;
    addGeneratedSurface(m, scene, mesh, mesh.generated[g], radiance[k], colorsOf(k, {}));
    ++summary.bakedPrimitives;
    ++summary.unlitMaterials;
    summary.writtenVertices += radiance[k].size();
  }
  if (summary.unlitMaterials > 0 &&
      std::find(m.extensionsUsed.begin(), m.extensionsUsed.end(), "KHR_materials_unlit") == m.extensionsUsed.end())
    m.extensionsUsed.push_back("KHR_materials_unlit");
  writeFileAtomically(path, serialize(m, ext == ".glb", options.pretty));
  return summary;
}

}  // namespace radbake

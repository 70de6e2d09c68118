#include <algorithm>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "core/core.h"
#include "exporters/exporters.h"
#include "exporters/image_files.h"
#include "exporters/lightmap.h"
#include "importers/gltf_document.h"

namespace radbake {
namespace {

constexpr int kArrayBuffer = 34962;
constexpr int kElementArrayBuffer = 34963;

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
  if (withBounds && acc.count > 0) setAccessorBounds(acc, values, components);
  m.accessors.push_back(acc);
  return int(m.accessors.size()) - 1;
}

// JOINTS_n must stay unsigned integers: written as unsigned shorts.
int appendJointsAccessor(tinygltf::Model& m, const std::vector<float>& values, int type, int components) {
  std::vector<uint16_t> joints(values.begin(), values.end());
  tinygltf::Accessor ja;
  ja.bufferView = appendView(m, joints.data(), joints.size() * 2, kArrayBuffer);
  ja.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
  ja.type = type;
  ja.count = joints.size() / components;
  m.accessors.push_back(ja);
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
// Without colors (lightmap output) only _RADIANCE is added.
void addBakeAttributes(tinygltf::Model& m, tinygltf::Primitive& prim, const std::vector<Vec3>& radiance,
                       const std::vector<Vec3>& colors) {
  prim.attributes["_RADIANCE"] = appendFloatAccessor(m, radianceFloats(radiance), TINYGLTF_TYPE_VEC3, 3, false);
  if (colors.empty()) return;
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
  prim.attributes["COLOR_0"] = appendFloatAccessor(m, radianceFloats(colors), TINYGLTF_TYPE_VEC3, 3, false);
}

// The base color texture (linear) at each output vertex of a baked primitive: an unlit viewer
// shows texture × COLOR_0, so COLOR_0 is the display value divided by it. (1, 1, 1) without one.
std::vector<Vec3> textureAtVertices(const Scene& scene, const Primitive& prim, const PrimitivePatches& patches) {
  const TextureRef& ref = scene.materials[prim.material].baseColorTexture;
  std::vector<Vec3> out(patches.patchVertex.size(), Vec3{1, 1, 1});
  if (ref.texture < 0 || !hasTexcoords(prim, ref.texCoord)) return out;
  for (size_t v = 0; v < out.size(); ++v) {
    const auto at = patches.keepsSourceVertices ? prim.texcoords[ref.texCoord][v]
                                                : uvAt(prim, ref.texCoord, patches.source[v]);
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
      const Vec3 p = transformPoint(inverse, patches.positions[v]);
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
      out.attributes[semantic] = appendJointsAccessor(m, values, acc.type, comps);
    } else {
      out.attributes[semantic] = appendFloatAccessor(m, values, acc.type, comps, semantic == "POSITION");
    }
  }
  out.indices = appendIndexAccessor(m, patches.triangles);
  return out;
}

// Curved input without a glTF primitive (a .bpt): a new node, mesh and material carry it. Returns
// the new mesh; the bake attributes are added by the caller.
int addGeneratedMesh(tinygltf::Model& m, const Scene& scene, const PatchMesh& mesh, const GeneratedSurface& surface) {
  const Material& material = scene.materials[surface.material];
  tinygltf::Material mat;
  mat.name = material.name;
  mat.pbrMetallicRoughness.baseColorFactor = {material.reflectance.x, material.reflectance.y, material.reflectance.z, 1};
  mat.pbrMetallicRoughness.metallicFactor = 0;
  mat.pbrMetallicRoughness.roughnessFactor = 1;
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
  return node.mesh;
}

// One baked glTF primitive in the output, with what its vertices carry.
struct BakedPrimitive {
  int mesh = -1, primitive = 0;     // in the output model
  int material = 0;                 // Scene::materials
  std::vector<Vec3> radiance;       // per output vertex
  std::vector<Vec3> light;          // lightmaps: the light that multiplies albedo, per output vertex
  std::vector<Vec3> texture;        // COLOR_0: the base color texture at each vertex (empty: none)
  std::vector<Vec3> positions;      // world space, per output vertex
  std::vector<std::array<uint32_t, 3>> triangles;  // in the output's winding
};

// The light that multiplies albedo (what three.js, Babylon.js and Hubs expect in a lightmap):
// irradiance E = π (L − L⁰) / ρ, so that a Lambertian surface of albedo ρ shows ρ E / π. Zero
// where the surface reflects nothing (ρ = 0), where no albedo can bring light back.
Vec3 lightOf(const Vec3& radiance, const Vec3& emission, const Vec3& reflectance) {
  auto channel = [](double L, double L0, double rho) { return rho > 0 ? std::max(0.0, kPi * (L - L0) / rho) : 0.0; };
  return {channel(radiance.x, emission.x, reflectance.x), channel(radiance.y, emission.y, reflectance.y),
          channel(radiance.z, emission.z, reflectance.z)};
}

// The output primitive with every vertex attribute (and morph target) re-gathered through
// `source` and new triangles: the atlas splits vertices where its charts meet.
int gatherAccessor(tinygltf::Model& m, int index, const std::vector<uint32_t>& source, bool joints, bool bounds) {
  const auto& acc = m.accessors[index];
  const int comps = int(tinygltf::GetNumComponentsInType(acc.type));
  const int type = acc.type;
  const std::vector<double> values = readAccessorValues(m, index);
  std::vector<float> out;
  out.reserve(source.size() * comps);
  for (uint32_t v : source)
    for (int c = 0; c < comps; ++c) out.push_back(float(values[size_t(v) * comps + c]));
  if (joints) return appendJointsAccessor(m, out, type, comps);
  return appendFloatAccessor(m, out, type, comps, bounds);
}

void remapVertices(tinygltf::Model& m, tinygltf::Primitive& prim, const std::vector<uint32_t>& source,
                   const std::vector<std::array<uint32_t, 3>>& triangles) {
  for (auto& [semantic, accessor] : prim.attributes)
    accessor = gatherAccessor(m, accessor, source, semantic.rfind("JOINTS_", 0) == 0, semantic == "POSITION");
  for (auto& target : prim.targets)
    for (auto& [semantic, accessor] : target) accessor = gatherAccessor(m, accessor, source, false, semantic == "POSITION");
  prim.indices = appendIndexAccessor(m, triangles);
  prim.mode = TINYGLTF_MODE_TRIANGLES;
}

// World position of each output vertex of a baked primitive.
std::vector<Vec3> outputPositions(const Primitive& prim, const PrimitivePatches& patches) {
  if (patches.keepsSourceVertices) return prim.positions;
  if (!patches.positions.empty()) return patches.positions;  // a subdivision surface's limit points
  std::vector<Vec3> out;
  out.reserve(patches.source.size());
  for (const SurfacePoint& sp : patches.source) out.push_back(positionAt(prim, sp));
  return out;
}

// The primitive's triangles in the file's own winding (the importer made them counter-clockwise in
// world space, which flips them under a mirroring node).
std::vector<std::array<uint32_t, 3>> sourceTriangles(const Primitive& prim) {
  std::vector<std::array<uint32_t, 3>> out = prim.triangles;
  if (determinant3(prim.world) < 0)
    for (auto& t : out) std::swap(t[1], t[2]);
  return out;
}

// COLOR_0 = the display value back in glTF's linear color, divided by what the unlit material
// multiplies it with (its base color texture), clamped to glTF's [0,1]. `codes`: the display
// values of every baked vertex, in order.
void addVertexColors(tinygltf::Model& m, const std::vector<BakedPrimitive>& baked, const std::vector<Vec3>& codes,
                     ExportSummary* summary) {
  size_t next = 0;
  auto channel = [&](double code, double tex) {
    const double wanted = srgbDecode(code);
    if (wanted <= 0) return 0.0;
    if (wanted > tex + 1e-6) ++summary->clampedColors;
    return tex > 0 ? std::min(1.0, wanted / tex) : 1.0;
  };
  std::set<int> unlit;
  int defaultUnlit = -1;  // primitives without a material get one unlit white material
  for (const BakedPrimitive& b : baked) {
    std::vector<Vec3> colors(b.radiance.size());
    for (size_t v = 0; v < colors.size(); ++v, ++next) {
      const Vec3 t = b.texture.empty() ? Vec3{1, 1, 1} : b.texture[v];
      colors[v] = {channel(codes[next].x, t.x), channel(codes[next].y, t.y), channel(codes[next].z, t.z)};
    }
    tinygltf::Primitive& target = m.meshes[b.mesh].primitives[b.primitive];
    addBakeAttributes(m, target, b.radiance, colors);
    if (target.material < 0) {
      if (defaultUnlit < 0) {
        tinygltf::Material material;
        material.name = "radbake default (unlit)";
        m.materials.push_back(material);
        defaultUnlit = int(m.materials.size()) - 1;
      }
      target.material = defaultUnlit;
    }
    unlit.insert(target.material);
  }
  for (int material : unlit) makeUnlit(m.materials[material]);
  summary->unlitMaterials = int(unlit.size());
  if (!unlit.empty() &&
      std::find(m.extensionsUsed.begin(), m.extensionsUsed.end(), "KHR_materials_unlit") == m.extensionsUsed.end())
    m.extensionsUsed.push_back("KHR_materials_unlit");
}

bool usesTexCoord(const tinygltf::Material& material, int set) {
  const auto& pbr = material.pbrMetallicRoughness;
  auto uses = [&](int index, int texCoord) { return index >= 0 && texCoord == set; };
  return uses(pbr.baseColorTexture.index, pbr.baseColorTexture.texCoord) ||
         uses(pbr.metallicRoughnessTexture.index, pbr.metallicRoughnessTexture.texCoord) ||
         uses(material.normalTexture.index, material.normalTexture.texCoord) ||
         uses(material.occlusionTexture.index, material.occlusionTexture.texCoord) ||
         uses(material.emissiveTexture.index, material.emissiveTexture.texCoord);
}

std::string previewPath(const std::string& exr) {
  return std::filesystem::path(exr).replace_extension(".preview.png").string();
}

// The lightmap: the asset's own TEXCOORD_1 when every baked primitive has a usable one, else an
// atlas of our own (vertices split where its charts meet); the light rasterized and dilated; an EXR
// (half float, the exact light) and a preview through the display transform written beside the
// glTF, and an sRGB PNG copy embedded and referenced from each material with MOZ_lightmap.
LightmapSummary addLightmap(tinygltf::Model& m, std::vector<BakedPrimitive>& baked, const LightmapOptions& options,
                            const DisplayShaping& shaping, std::vector<std::pair<std::string, std::string>>* files) {
  LightmapSummary out;
  out.exr = options.path;
  out.preview = previewPath(options.path);
  std::vector<AtlasPieceLayout> layout(baked.size());
  bool own = !baked.empty();
  for (size_t k = 0; k < baked.size() && own; ++k) {
    const tinygltf::Primitive& prim = m.meshes[baked[k].mesh].primitives[baked[k].primitive];
    const auto it = prim.attributes.find("TEXCOORD_1");
    own = it != prim.attributes.end();
    if (!own) break;
    const std::vector<double> uv = readAccessorValues(m, it->second);
    AtlasPieceLayout& piece = layout[k];
    for (size_t v = 0; v < uv.size() / 2; ++v) {
      piece.vertexSource.push_back(uint32_t(v));
      piece.uv.push_back({float(uv[2 * v]), float(uv[2 * v + 1])});
    }
    piece.triangles = baked[k].triangles;
    piece.chart.assign(piece.triangles.size(), int(k));
  }
  int width = options.size, height = options.size;
  if (own) {
    out.atlasReason = lightmapLayoutProblem(width, height, layout);
    own = out.atlasReason.empty();
  }
  if (!own) {
    std::vector<AtlasPiece> pieces;
    for (const BakedPrimitive& b : baked) pieces.push_back({b.positions, b.triangles});
    AtlasOptions atlasOptions;
    atlasOptions.size = options.size;
    atlasOptions.texelSize = options.texelSize;
    Atlas atlas = buildAtlas(pieces, atlasOptions);
    width = atlas.width;
    height = atlas.height;
    out.charts = atlas.charts;
    out.texelSize = atlas.texelSize;
    layout = std::move(atlas.pieces);
    for (size_t k = 0; k < baked.size(); ++k) {
      BakedPrimitive& b = baked[k];
      remapVertices(m, m.meshes[b.mesh].primitives[b.primitive], layout[k].vertexSource, layout[k].triangles);
      std::vector<Vec3> radiance, light;
      for (uint32_t v : layout[k].vertexSource) {
        radiance.push_back(b.radiance[v]);
        light.push_back(b.light[v]);
      }
      b.radiance = std::move(radiance);
      b.light = std::move(light);
    }
  } else {
    out.assetUVs = true;
    out.charts = int(baked.size());
  }
  out.width = width;
  out.height = height;

  // The texels.
  std::vector<std::vector<Vec3>> values;
  for (const BakedPrimitive& b : baked) values.push_back(b.light);
  LightmapImage image = rasterize(width, height, layout, values);
  const size_t texels = size_t(width) * height;
  size_t inside = 0;
  for (int owner : image.owner) inside += owner >= 0;
  out.fill = texels ? double(inside) / double(texels) : 0;
  dilate(image);
  float peak = 0;
  for (float v : image.rgb)
    if (std::isfinite(v)) peak = std::max(peak, v);
  out.intensity = peak > 0 ? peak : 1;

  // The embedded PNG (glTF images cannot be EXR): sRGB-encoded E / intensity.
  std::vector<uint8_t> codes(image.rgb.size()), preview(image.rgb.size());
  for (size_t i = 0; i < image.rgb.size(); ++i)
    codes[i] = uint8_t(std::lround(255 * srgbEncode(std::clamp(image.rgb[i] / out.intensity, 0.0, 1.0))));
  // The preview: what a white (ρ = 1) surface would show, E/π, through the display transform.
  std::vector<Vec3> whiteSurface(texels);
  for (size_t i = 0; i < texels; ++i)
    whiteSurface[i] = Vec3{image.rgb[3 * i], image.rgb[3 * i + 1], image.rgb[3 * i + 2]} * (1 / kPi);
  const std::vector<Vec3> shown = toDisplay(shaping, whiteSurface);
  for (size_t i = 0; i < texels; ++i) {
    preview[3 * i] = uint8_t(std::lround(255 * shown[i].x));
    preview[3 * i + 1] = uint8_t(std::lround(255 * shown[i].y));
    preview[3 * i + 2] = uint8_t(std::lround(255 * shown[i].z));
  }
  const std::string png = encodePng(width, height, codes);
  tinygltf::Image pngImage;
  pngImage.name = "radbake lightmap";
  pngImage.mimeType = "image/png";
  pngImage.bufferView = appendView(m, png.data(), png.size(), 0);
  m.bufferViews.back().target = 0;
  m.images.push_back(pngImage);
  tinygltf::Sampler sampler;
  sampler.magFilter = TINYGLTF_TEXTURE_FILTER_LINEAR;
  sampler.minFilter = TINYGLTF_TEXTURE_FILTER_LINEAR_MIPMAP_LINEAR;
  sampler.wrapS = sampler.wrapT = TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
  m.samplers.push_back(sampler);
  tinygltf::Texture texture;
  texture.name = "radbake lightmap";
  texture.source = int(m.images.size()) - 1;
  texture.sampler = int(m.samplers.size()) - 1;
  m.textures.push_back(texture);
  const int textureIndex = int(m.textures.size()) - 1;

  // Per primitive: _RADIANCE, the lightmap UVs, and MOZ_lightmap on its material (copied when
  // primitives sharing a material read the lightmap from different TEXCOORD sets).
  std::map<std::pair<int, int>, int> lightmapMaterial;  // (material, set) → material in the output
  std::set<int> claimed;
  for (size_t k = 0; k < baked.size(); ++k) {
    tinygltf::Primitive& prim = m.meshes[baked[k].mesh].primitives[baked[k].primitive];
    addBakeAttributes(m, prim, baked[k].radiance, {});
    int set = 1;
    if (!own) {
      std::vector<float> uv;
      for (const auto& t : layout[k].uv) uv.insert(uv.end(), {t[0], t[1]});
      const int accessor = appendFloatAccessor(m, uv, TINYGLTF_TYPE_VEC2, 2, false);
      if (prim.material >= 0 && prim.attributes.count("TEXCOORD_1") && usesTexCoord(m.materials[prim.material], 1)) {
        set = 0;  // set 1 feeds a texture: the lightmap takes the first free set instead
        while (prim.attributes.count("TEXCOORD_" + std::to_string(set))) ++set;
      }
      prim.attributes["TEXCOORD_" + std::to_string(set)] = accessor;
      for (int lower = 0; lower < set; ++lower)  // TEXCOORD sets must be contiguous from 0
        prim.attributes.try_emplace("TEXCOORD_" + std::to_string(lower), accessor);
    }
    out.texCoord = std::max(out.texCoord, set);
    auto [it, added] = lightmapMaterial.try_emplace({prim.material, set}, -1);
    if (added) {
      tinygltf::Material material;
      if (prim.material >= 0) {
        material = m.materials[prim.material];
      } else {
        material.name = "radbake default";  // radbake bakes glTF's default material as white and diffuse
        material.pbrMetallicRoughness.metallicFactor = 0;
      }
      tinygltf::Value::Object ext;
      ext["index"] = tinygltf::Value(textureIndex);
      ext["texCoord"] = tinygltf::Value(set);
      ext["intensity"] = tinygltf::Value(out.intensity);
      material.extensions["MOZ_lightmap"] = tinygltf::Value(ext);
      if (prim.material >= 0 && claimed.insert(prim.material).second) {
        m.materials[prim.material] = material;
        it->second = prim.material;
      } else {
        m.materials.push_back(material);
        it->second = int(m.materials.size()) - 1;
      }
    }
    prim.material = it->second;
  }
  if (std::find(m.extensionsUsed.begin(), m.extensionsUsed.end(), "MOZ_lightmap") == m.extensionsUsed.end())
    m.extensionsUsed.push_back("MOZ_lightmap");

  files->push_back({options.path, encodeExrHalfRgb(width, height, image.rgb)});
  files->push_back({out.preview, encodePng(width, height, preview)});
  return out;
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

ExportSummary writeGltf(const std::string& path, const Scene& scene, const PatchMesh& mesh,
                        const std::vector<Vec3>& vertexRadiance, const std::vector<Vec3>& patchRadiance,
                        const ExportOptions& options) {
  std::vector<std::pair<std::string, std::string>> files;
  const ExportSummary summary = exportGltf(path, scene, mesh, vertexRadiance, patchRadiance, options, files);
  writeFilesAtomically(files);
  return summary;
}

ExportSummary exportGltf(const std::string& path, const Scene& scene, const PatchMesh& mesh,
                         const std::vector<Vec3>& vertexRadiance, const std::vector<Vec3>& patchRadiance,
                         const ExportOptions& options, std::vector<std::pair<std::string, std::string>>& out) {
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

  // Every baked primitive in the output, with the radiance of its output vertices.
  const bool lightmap = !options.lightmap.path.empty();
  std::vector<BakedPrimitive> baked;
  for (size_t p = 0; p < scene.primitives.size(); ++p) {
    const Primitive& prim = scene.primitives[p];
    const PrimitivePatches& patches = mesh.primitives[p];
    BakedPrimitive b;
    b.mesh = meshOfNode[prim.node];
    b.primitive = prim.primitive;
    b.material = prim.material;
    tinygltf::Primitive& target = m.meshes[b.mesh].primitives[b.primitive];
    if (!patches.keepsSourceVertices) target = tessellatedPrimitive(m, target, prim, patches);
    const Material& material = scene.materials[prim.material];
    const bool constant = !patches.patch.empty() && !patchRadiance.empty();
    for (size_t v = 0; v < patches.patchVertex.size(); ++v) {
      const uint32_t pv = patches.patchVertex[v];
      if (constant) {
        const Patch& patch = mesh.patches[patches.patch[v]];
        b.radiance.push_back(patchRadiance[patches.patch[v]]);
        if (lightmap) b.light.push_back(lightOf(b.radiance.back(), patch.emission, patch.reflectance));
      } else if (pv == UINT32_MAX) {  // a vertex no patch uses (a dropped degenerate face)
        b.radiance.push_back(material.emission);
        if (lightmap) b.light.push_back({0, 0, 0});
      } else {
        b.radiance.push_back(vertexRadiance[pv]);
        if (lightmap) b.light.push_back(lightOf(vertexRadiance[pv], mesh.vertexEmission[pv], mesh.vertexReflectance[pv]));
      }
    }
    // (the geometry for lightmaps and for the automatic exposure's areas)
    b.positions = outputPositions(prim, patches);
    b.triangles = patches.keepsSourceVertices ? sourceTriangles(prim) : patches.triangles;
    if (!lightmap) b.texture = textureAtVertices(scene, prim, patches);
    baked.push_back(std::move(b));
  }
  for (const GeneratedSurface& surface : mesh.generated) {
    BakedPrimitive b;
    b.mesh = addGeneratedMesh(m, scene, mesh, surface);
    b.material = surface.material;
    for (uint32_t v : surface.patchVertex) {
      b.radiance.push_back(vertexRadiance[v]);
      b.light.push_back(lightOf(vertexRadiance[v], mesh.vertexEmission[v], mesh.vertexReflectance[v]));
      b.positions.push_back(mesh.positions[v]);
    }
    b.triangles = surface.triangles;
    baked.push_back(std::move(b));
  }

  // Display shaping: one exposure for the whole scene, set from the surfaces that only reflect.
  std::vector<Vec3> reflected, all;
  std::vector<double> area;  // a third of the triangles around each vertex
  for (const BakedPrimitive& b : baked) {
    const Vec3& emission = scene.materials[b.material].emission;
    if (emission.x <= 0 && emission.y <= 0 && emission.z <= 0) {
      reflected.insert(reflected.end(), b.radiance.begin(), b.radiance.end());
      const size_t first = area.size();
      area.resize(first + b.radiance.size());
      for (const auto& t : b.triangles) {
        const double a = length(cross(b.positions[t[1]] - b.positions[t[0]], b.positions[t[2]] - b.positions[t[0]])) / 6;
        for (uint32_t v : t) area[first + v] += a;
      }
    }
    if (!lightmap) all.insert(all.end(), b.radiance.begin(), b.radiance.end());
  }
  summary.display = resolveDisplay(options.display, reflected, area);

  std::vector<std::pair<std::string, std::string>> files;
  if (lightmap) {
    if (lowerExtension(options.lightmap.path) != ".exr")
      throw Error(ExitCode::kUsage, "radbake: --lightmap " + options.lightmap.path + " must end in .exr");
    summary.lightmap = addLightmap(m, baked, options.lightmap, summary.display, &files);
  } else {
    addVertexColors(m, baked, toDisplay(summary.display, all), &summary);
  }
  for (const BakedPrimitive& b : baked) summary.writtenVertices += b.radiance.size();
  summary.bakedPrimitives = int(baked.size());
  out.push_back({path, serialize(m, ext == ".glb", options.pretty)});
  out.insert(out.end(), files.begin(), files.end());
  return summary;
}

}  // namespace radbake

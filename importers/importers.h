// importers: read a .gltf/.glb into a Scene (world-space triangles, materials, the source document).
//
// The Scene is plain data: every later stage reads it without knowing glTF. The parsed source
// document travels with it (opaque here) so the exporter can write back everything radbake did not
// touch.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/core.h"

namespace radbake {

// A decoded color texture: linear RGB (sRGB decoded, as glTF color textures are), rows top first.
struct Texture {
  int width = 0, height = 0;
  std::vector<float> rgb;
  std::vector<float> alpha;  // linear, one per texel
  int wrapS = 10497, wrapT = 10497;  // glTF sampler wrap modes (REPEAT by default)
};

// A material's use of a texture: which one, which TEXCOORD_n, and KHR_texture_transform.
struct TextureRef {
  int texture = -1;  // index into Scene::textures; -1: none
  int texCoord = 0;
  double offset[2] = {0, 0}, rotation = 0, scale[2] = {1, 1};
};

// Lambertian material as the solver sees it (DESIGN.md "Units").
struct Material {
  std::string name;
  int gltfIndex = -1;             // -1: the glTF default material
  Vec3 reflectance{1, 1, 1};      // ρ = baseColorFactor (linear); 0 for metals
  Vec3 emission{0, 0, 0};         // L⁰ = emissiveFactor × KHR_materials_emissive_strength
  bool doubleSided = false;
  bool alphaMask = false;         // alphaMode MASK: cut out where alpha < alphaCutoff
  double alphaCutoff = 0.5;
  double baseAlpha = 1;           // baseColorFactor's alpha
  TextureRef baseColorTexture;    // multiplies the reflectance
  TextureRef emissiveTexture;     // multiplies the emission
};

enum class SubdivisionScheme { kNone, kCatmullClark, kLoop };

// One glTF primitive placed in the world by one node: triangles only, counter-clockwise seen from
// the front in world space (winding already flipped for mirroring transforms).
struct Primitive {
  int node = -1;
  int mesh = -1;
  int primitive = -1;
  int material = 0;                                  // index into Scene::materials
  std::vector<Vec3> positions;                       // world space, one per glTF vertex
  std::vector<Vec3> normals;                         // world space, unit; flat normals if NORMAL is absent
  bool hasNormals = false;                           // whether NORMAL came from the file
  std::vector<std::array<uint32_t, 3>> triangles;    // indices into positions
  std::vector<std::vector<std::array<double, 2>>> texcoords;  // TEXCOORD_n, per vertex (sets the material uses)
  Matrix4 world{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};  // node to world
  // A subdivision surface: these triangles (paired into quads where coplanar) are its cage.
  // From "extras": {"subdivision": {"scheme": "catmull-clark" | "loop"}} on the mesh or node.
  SubdivisionScheme subdivision = SubdivisionScheme::kNone;
};

// A KHR_lights_punctual light placed by a node, in glTF's photometric units.
struct PunctualLight {
  enum class Type { kPoint, kSpot, kDirectional };
  Type type = Type::kPoint;
  std::string name;
  int node = -1;
  Vec3 position;      // world space (point, spot)
  Vec3 direction;     // world space, unit: where the light shines (spot, directional): local −z
  Vec3 intensity;     // color × intensity: candela (point, spot) or lux (directional)
  double range = 0;   // 0: unlimited
  double innerCone = 0, outerCone = 0.7853981633974483;  // spot cone half-angles (radians)
};

// A tensor-product Bezier patch (.bpt): S(u,v) = Σ_i Σ_j B_i(u) B_j(v) P[i][j], u, v ∈ [0,1].
struct BezierPatch {
  int degreeU = 3, degreeV = 3;
  std::vector<Vec3> control;  // (degreeU+1)·(degreeV+1) points, P[i][j] at i·(degreeV+1) + j
  int material = 0;
};

struct SourceDocument;  // the parsed glTF, defined in importers/gltf_document.h for the exporter only

struct SceneCounts {
  int nodes = 0, meshes = 0, primitives = 0, materials = 0, textures = 0, images = 0;
  int cameras = 0, lights = 0, skins = 0, animations = 0, scenes = 0;
  long long vertices = 0;  // Σ accessor count of POSITION over all primitives of all meshes
};

struct Scene {
  std::string path;
  std::vector<Material> materials;    // glTF materials in order, then the default material
  std::vector<Primitive> primitives;  // every triangle primitive instance of the default scene
  std::vector<BezierPatch> bezierPatches;  // curved input (.bpt), one smooth surface
  std::vector<PunctualLight> lights;       // KHR_lights_punctual lights of the default scene
  std::vector<Texture> textures;           // decoded color textures the materials use
  std::vector<std::string> warnings;  // each names the file and the element
  SceneCounts counts;                 // what the document holds (for `radbake info`)
  std::vector<std::string> extensionsUsed;  // as the file lists them
  std::shared_ptr<const SourceDocument> document;

  bool hasEmitter() const;
};

struct ImportOptions {
  // false (radbake info): report extensions radbake cannot bake instead of failing on them.
  bool requireSupportedExtensions = true;
  int scene = -1;  // the glTF scene to bake; -1: the document's default scene (or the first)
  // Buffers and images are read only from the asset's folder unless this is set (--allow-outside-paths).
  bool allowOutsidePaths = false;
  // The memory budget (--max-memory): files, accessors, decoded textures and the instanced scene are
  // estimated before they are allocated, and refused (exit 3, naming the element) past it.
  uint64_t maxMemoryBytes = physicalMemoryBytes();
};

// The texture's color at (u, v) after the reference's transform: bilinear filtering, the sampler's
// wrap modes. (1, 1, 1) when the reference has no texture.
Vec3 sampleTexture(const Scene& scene, const TextureRef& ref, double u, double v);

// The texture's alpha at (u, v) (nearest texel, after the transform); 1 without a texture.
double sampleAlpha(const Scene& scene, const TextureRef& ref, double u, double v);

// Reads INPUT (.gltf, .glb or .bpt). A .bpt (Bezier patches, z up) is turned to glTF's y up,
// (x, y, z) → (x, z, −y), and given one white material (ρ 0.8). Throws Error (exit 2 invalid, 3 unsupported) with one line naming
// the file and the broken element.
Scene importScene(const std::string& path, const ImportOptions& options = {});

// The same for a .gltf/.glb already in memory; `path` names it in messages and locates external
// files (buffers, images) beside it.
Scene importGltfBytes(const std::vector<unsigned char>& bytes, const std::string& path, const ImportOptions& options = {});

}  // namespace radbake

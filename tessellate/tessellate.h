// tessellate: Scene → PatchMesh, the planar quad patches the solver works on.
//
// A triangle is a quad whose last two vertices coincide (paper §2). Each face may be split into N×N
// patches. Vertices are welded where they coincide within one smooth surface and one material (same
// position, normal and material), so a K×K grid has (K+1)² unknowns, and never across a crease or a
// material boundary. Every patch vertex keeps a link to where it lies on the source primitive, so
// the exporter can carry the original attributes onto the new vertices.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <set>
#include <vector>

#include "core/core.h"
#include "importers/importers.h"

namespace radbake {

// Where a flat patch lies in the refinement of its source face: a face split n×n has n·2^level
// cells a side at `level`, and cell (level, i, j) covers its parameters [i, i + 1] × [j, j + 1]
// over n·2^level. primitive −1: a patch adaptive refinement cannot split (curved surfaces,
// generated geometry).
struct Cell {
  int primitive = -1, face = 0, level = 0, i = 0, j = 0;
  auto operator<=>(const Cell&) const = default;
};

struct Patch {
  std::array<uint32_t, 4> v;  // counter-clockwise seen from the front; v[2] == v[3] for a triangle
  int material = 0;           // index into Scene::materials
  int primitive = 0;          // index into Scene::primitives
  Vec3 normal;                // unit geometric normal (front side)
  double area = 0;
  bool backSide = false;      // the mirrored twin of a double-sided patch
  int twin = -1;              // double-sided: the coincident patch of the other side (front ↔ back)
  // ρ and L⁰ of this patch: the material's factors times its textures averaged over the patch.
  Vec3 reflectance, emission;
  bool shaded = false;        // set from textures (else the material's values are filled in)
  // alphaMode MASK: the corners' base color texture coordinates, so occlusion can test the mask
  // where a ray hits (empty mask: the patch is opaque).
  int mask = -1;              // index into PatchMesh::masks
  double coverage = 1;        // the opaque fraction of a cut-out patch
  Cell cell;                  // its cell (the fan triangles of a cell with hanging points share it)
};

inline Patch makePatch(const std::array<uint32_t, 4>& v, int material, int primitive, const Vec3& normal, double area) {
  Patch p;
  p.v = v;
  p.material = material;
  p.primitive = primitive;
  p.normal = normal;
  p.area = area;
  return p;
}

// Where an output vertex lies on its source primitive: a triangle and barycentric weights.
struct SurfacePoint {
  uint32_t triangle = 0;  // index into Primitive::triangles
  double w1 = 0, w2 = 0;  // weights of the triangle's 2nd and 3rd vertex (the 1st gets 1 − w1 − w2)
};

// The source primitive at a surface point (barycentric on its triangle): its TEXCOORD_`set` and its
// world position. hasTexcoords: whether the primitive carries TEXCOORD_`set` for every vertex.
std::array<double, 2> uvAt(const Primitive& prim, int set, const SurfacePoint& sp);
Vec3 positionAt(const Primitive& prim, const SurfacePoint& sp);
bool hasTexcoords(const Primitive& prim, int set);

// The tessellated geometry of one scene primitive, as the exporter writes it.
struct PrimitivePatches {
  // true: the output vertices are the glTF vertices themselves (no splitting happened), so the
  // bake is written onto the original primitive and its data stays bit-exact.
  bool keepsSourceVertices = true;
  std::vector<uint32_t> patchVertex;             // patch-mesh vertex of each output vertex (UINT32_MAX: unused)
  std::vector<SurfacePoint> source;              // where each output vertex lies (when !keepsSourceVertices)
  std::vector<std::array<uint32_t, 3>> triangles;  // output triangles (when !keepsSourceVertices)
  std::vector<uint32_t> patch;                   // patch of each output vertex (flatPatches only)
  // Subdivision surfaces: the limit positions and normals of the output vertices (world space);
  // `source` then only carries the other attributes.
  std::vector<Vec3> positions, normals;
};

// Geometry made from curved input that has no glTF primitive to carry it (a .bpt file): the
// exporter writes it as a new mesh. Its output vertices are patch vertices.
struct GeneratedSurface {
  int material = 0;
  std::vector<uint32_t> patchVertex;
  std::vector<std::array<uint32_t, 3>> triangles;
};

// A cut-out patch: where its base color alpha (factor × texture at the bilinear UV) falls below the
// cutoff, light passes.
struct PatchMask {
  std::array<std::array<double, 2>, 4> uv;  // TEXCOORD of the base color texture at v0..v3
  TextureRef texture;
  double baseAlpha = 1, cutoff = 0.5;
};

struct Contacts;  // contact.h

struct PatchMesh {
  std::vector<Vec3> positions;  // welded patch vertices
  std::vector<Vec3> normals;    // unit, the receiving orientation of each vertex
  std::vector<int> vertexMaterial;
  std::vector<Vec3> vertexReflectance, vertexEmission;  // area-weighted means of the patches around
  std::vector<Patch> patches;
  std::vector<PrimitivePatches> primitives;  // parallel to Scene::primitives
  std::vector<PatchMask> masks;
  std::vector<GeneratedSurface> generated;   // from Scene::bezierPatches
  int curvedRate = 0;             // quads per patch edge on curved surfaces
  double worstNonPlanarity = 0;   // curved surfaces: largest corner distance from a facet's plane over its diagonal
  size_t splitFacets = 0;         // non-planar facets split into two planar triangle patches
  std::set<Cell> split;           // the cells split in four: TessellateOptions::split and what balance added
  size_t contactSegments = 0;     // segments where a surface touches or crosses a flat face, which cut it
  // Those segments, found in the input alone whatever the splits: a later tessellation of the same
  // scene takes them from this mesh (tessellate's `previous`).
  std::shared_ptr<const Contacts> contacts;
};

struct TessellateOptions {
  int subdivide = 1;         // split every face into subdivide × subdivide patches
  double maxEdgeLength = 0;  // > 0: per primitive, the smallest subdivision with every patch edge ≤ this
  bool flatPatches = false;  // output vertices per patch (to show one value per patch, flat-shaded)
  // Curved surfaces: the smallest uniform rate with every patch within this distance of the true
  // surface (chord error), at least `subdivide`, and edges within maxEdgeLength. 0: 1/1000 of the
  // surface's size.
  double maxChord = 0;
  // Treat every mesh as a subdivision surface of this scheme (--subdivision-surfaces); meshes
  // flagged in their extras use their own scheme.
  SubdivisionScheme subdivisionSurfaces = SubdivisionScheme::kNone;
  // The memory budget (--max-memory): a subdivision whose patches would need more (estimated
  // before they are made) is refused with exit 3 naming the mesh.
  uint64_t maxMemoryBytes = UINT64_MAX;
  // Adaptive refinement: cells of flat faces to split in four (recursively: a child may be listed
  // too). The mesh stays conforming: a cell is split too where a neighbour is more than one level
  // finer, and a cell with a finer neighbour becomes a fan of triangles from the point on its
  // edge, so no vertex hangs on an edge. Ignored with flatPatches.
  std::set<Cell> split;
  // Cut flat faces along the segments where other flat surfaces touch them, pass through them or
  // lie on them (contact.h) before splitting them: no patch straddles a footprint.
  bool cutContacts = true;
};

// The deepest refinement level (a cell 1/1024 of its face's grid cell).
inline constexpr int kMaxRefineLevel = 10;

// `previous`: a mesh of the same scene tessellated before (refinement's rounds, some thirty for a
// room): the contacts it found are used again where it cut the same primitives (2.1 s of issue
// 16's room's 12 s of refinement went to finding them again every round).
PatchMesh tessellate(const Scene& scene, const TessellateOptions& options = {}, const PatchMesh* previous = nullptr);

}  // namespace radbake

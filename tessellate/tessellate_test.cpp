// Tessellation tests: counts that follow from the construction, welding rules, exact areas.
#include <gtest/gtest.h>

#include <filesystem>

#include "tessellate/tessellate.h"

namespace fs = std::filesystem;
using namespace radbake;

namespace {

const fs::path kScenes = fs::path(RADBAKE_SHARED_DIR) / "scenes";

double patchMeshArea(const PatchMesh& mesh) {
  double a = 0;
  for (const Patch& p : mesh.patches) a += p.area;
  return a;
}

TEST(Tessellate, FurnaceCubeFacesNeverWeldAcrossEdges) {
  const Scene scene = importScene((kScenes / "furnace_cube.gltf").string());
  for (int n : {1, 2, 5}) {
    TessellateOptions o;
    o.subdivide = n;
    const PatchMesh mesh = tessellate(scene, o);
    // Each face's two triangles become one quad, split n×n: (n+1)² unknowns per face, none shared
    // across the cube's edges.
    EXPECT_EQ(mesh.positions.size(), size_t(6 * (n + 1) * (n + 1))) << "n=" << n;
    EXPECT_EQ(mesh.patches.size(), size_t(6 * n * n));
    EXPECT_NEAR(patchMeshArea(mesh), 6.0, 1e-12);
  }
}

TEST(Tessellate, OriginalVerticesAreKeptWhenNothingSplits) {
  const Scene scene = importScene((kScenes / "two_plates.gltf").string());
  const PatchMesh mesh = tessellate(scene);
  // The receiver is a 4×4 grid on 25 shared vertices: 25 unknowns, plus the emitter's 4.
  EXPECT_EQ(mesh.positions.size(), 29u);
  for (const PrimitivePatches& p : mesh.primitives) EXPECT_TRUE(p.keepsSourceVertices);
}

TEST(Tessellate, FlatShadedNonPlanarQuadSplitsItsVertices) {
  // No NORMAL: flat normals from the winding, so the two triangles (20° apart) do not share
  // vertices along the diagonal.
  const Scene scene = importScene((kScenes / "one_quad_nonplanar.gltf").string());
  const PatchMesh mesh = tessellate(scene);
  size_t quadVertices = 0;
  for (size_t p = 0; p < scene.primitives.size(); ++p)
    if (!scene.primitives[p].hasNormals) {
      EXPECT_FALSE(mesh.primitives[p].keepsSourceVertices);
      quadVertices = mesh.primitives[p].patchVertex.size();
    }
  EXPECT_EQ(quadVertices, 6u);  // two triangles, 3 + 3 vertices: not paired into one quad
}

TEST(Tessellate, MaxEdgeBoundsEveryPatchEdge) {
  const Scene scene = importScene((kScenes / "cornell_box.gltf").string());
  TessellateOptions o;
  o.maxEdgeLength = 0.1;
  const PatchMesh mesh = tessellate(scene, o);
  for (const Patch& p : mesh.patches)
    for (int e = 0; e < 4; ++e)
      EXPECT_LE(length(mesh.positions[p.v[(e + 1) % 4]] - mesh.positions[p.v[e]]), 0.1 * (1 + 1e-9));
}

}  // namespace

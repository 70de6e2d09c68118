// Tessellation tests: counts that follow from the construction, welding rules, exact areas.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <tuple>

#include "tessellate/tessellate.h"

namespace fs = std::filesystem;
using namespace radbake;

namespace {

const fs::path kScenes = fs::path(RADBAKE_TEST_DATA_DIR) / "scenes";

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

namespace {

TEST(Tessellate, TeapotIsCrackFree) {
  // Newell's 32 Bezier patches: after welding, two patch vertices share a position only where two
  // different surfaces touch at an angle (the handle's end meets the body at one point, 66°
  // apart); an unwelded smooth seam would leave duplicates with equal normals. Patches are nearly
  // planar.
  const Scene scene = importScene((kScenes / "teapot.bpt").string());
  ASSERT_EQ(scene.bezierPatches.size(), 32u);
  double previousNonPlanarity = 1;
  for (int rate : {2, 4, 8}) {
    TessellateOptions o;
    o.subdivide = rate;
    o.maxChord = 1e9;  // the rate alone
    const PatchMesh mesh = tessellate(scene, o);
    EXPECT_EQ(mesh.curvedRate, rate);
    std::map<std::tuple<double, double, double>, std::vector<size_t>> seen;
    for (size_t i = 0; i < mesh.positions.size(); ++i) seen[{mesh.positions[i].x, mesh.positions[i].y, mesh.positions[i].z}].push_back(i);
    int duplicated = 0;
    for (const auto& [p, group] : seen) {
      if (group.size() == 1) continue;
      ++duplicated;
      for (size_t a = 0; a < group.size(); ++a)
        for (size_t b = a + 1; b < group.size(); ++b)
          EXPECT_LT(dot(mesh.normals[group[a]], mesh.normals[group[b]]), std::cos(10 * 3.14159265358979 / 180))
              << "unwelded smooth seam at " << std::get<0>(p) << " " << std::get<1>(p) << " " << std::get<2>(p);
    }
    EXPECT_LE(duplicated, 1) << "rate " << rate;
    // Patch seams: each interior seam point is shared, so the vertex count is far below 32·(n+1)².
    EXPECT_LT(mesh.positions.size(), size_t(32 * (rate + 1) * (rate + 1)));
    ASSERT_EQ(mesh.generated.size(), 1u);
    // Non-planarity (corner distance from the patch plane over its diagonal) falls with the rate.
    EXPECT_LT(mesh.worstNonPlanarity, previousNonPlanarity);
    previousNonPlanarity = mesh.worstNonPlanarity;
  }
}

TEST(Tessellate, CurvedRateFollowsTheChordTolerance) {
  const Scene scene = importScene((kScenes / "teapot.bpt").string());
  TessellateOptions coarse, fine;
  coarse.maxChord = 0.05;
  fine.maxChord = 0.002;
  EXPECT_LT(tessellate(scene, coarse).curvedRate, tessellate(scene, fine).curvedRate);
}

// No vertex of the mesh lies inside a patch edge (a T-junction): brute force over every edge.
// primitive ≥ 0: its patches and their vertices only.
int tJunctions(const PatchMesh& mesh, int primitive = -1) {
  int found = 0;
  std::vector<Vec3> points;
  for (const Patch& p : mesh.patches)
    if (primitive < 0 || p.primitive == primitive)
      for (uint32_t v : p.v) points.push_back(mesh.positions[v]);
  for (const Patch& p : mesh.patches)
    for (int e = 0; e < 4; ++e) {
      if (primitive >= 0 && p.primitive != primitive) continue;
      const Vec3 a = mesh.positions[p.v[e]], b = mesh.positions[p.v[(e + 1) % 4]];
      const double len = length(b - a);
      if (len == 0) continue;
      for (const Vec3& x : points) {
        const double t = dot(x - a, b - a) / (len * len);
        if (t > 1e-9 && t < 1 - 1e-9 && length(a + (b - a) * t - x) < 1e-9 * len) ++found;
      }
    }
  return found;
}

// The area of a primitive's output triangles, each output vertex checked to lie where its source
// point says (on the file's triangle) within 1e-12.
double outputArea(const Scene& scene, const PatchMesh& mesh, int primitive) {
  const PrimitivePatches& out = mesh.primitives[primitive];
  double area = 0;
  for (const auto& t : out.triangles) {
    std::array<Vec3, 3> x;
    for (int k = 0; k < 3; ++k) {
      x[k] = positionAt(scene.primitives[primitive], out.source[t[k]]);
      EXPECT_LT(length(x[k] - mesh.positions[out.patchVertex[t[k]]]), 1e-12);
    }
    area += 0.5 * length(cross(x[1] - x[0], x[2] - x[0]));
  }
  return area;
}

TEST(Tessellate, RefinedCellsStayConformingAcrossFacesAndKeepTheArea) {
  // One primitive per face: primitive 0 split three levels deep at the inner corner of its first
  // quarter (cell (2, 1, 1) touches both level-1 cells beside the quarter).
  const Scene scene = importScene((kScenes / "furnace_cube.gltf").string());
  ASSERT_EQ(scene.primitives.size(), 6u);
  TessellateOptions o;
  o.split = {{0, 0, 0, 0, 0}, {0, 0, 1, 0, 0}, {0, 0, 2, 1, 1}};
  const PatchMesh mesh = tessellate(scene, o);
  EXPECT_NEAR(patchMeshArea(mesh), 6.0, 1e-12);
  EXPECT_EQ(tJunctions(mesh), 0);
  // 2:1 balance: the face's level-1 cells beside the quarter were split too; so were the other
  // faces' cells along the first quarter's edges (their points at 1/8 and 1/4).
  EXPECT_TRUE(mesh.split.count({0, 0, 1, 1, 0}) && mesh.split.count({0, 0, 1, 0, 1}));
  int otherFaces = 0;
  for (const Cell& c : mesh.split) otherFaces += c.primitive != 0;
  EXPECT_GE(otherFaces, 2);
  // Every patch names its leaf cell, and the output triangles sit on the source surface.
  for (const Patch& p : mesh.patches) {
    EXPECT_EQ(p.cell.primitive, p.primitive);
    EXPECT_FALSE(mesh.split.count(p.cell));
  }
  EXPECT_FALSE(mesh.primitives[0].keepsSourceVertices);
  EXPECT_NEAR(outputArea(scene, mesh, 0), 1.0, 1e-12);  // the face's
}

TEST(Tessellate, ACellBesideAFinerOneIsAFanWithoutHangingVertices) {
  // A face (primitive 0) split once, then one child again: the two children beside it have one
  // midpoint each on an edge and become fans of 3 triangles from it; the diagonal child stays one
  // patch.
  const Scene scene = importScene((kScenes / "furnace_cube.gltf").string());
  TessellateOptions o;
  o.split = {{0, 0, 0, 0, 0}, {0, 0, 1, 0, 0}};
  const PatchMesh mesh = tessellate(scene, o);
  int face0 = 0, triangles = 0;
  for (const Patch& p : mesh.patches)
    if (p.primitive == 0) {
      ++face0;
      triangles += p.v[2] == p.v[3];
    }
  EXPECT_EQ(face0, 4 + 3 + 3 + 1);
  EXPECT_EQ(triangles, 6);
  EXPECT_EQ(tJunctions(mesh), 0);
  EXPECT_NEAR(patchMeshArea(mesh), 6.0, 1e-12);
  // Without the split, the unrefined path: the same mesh as before refinement existed.
  const PatchMesh plain = tessellate(scene);
  EXPECT_EQ(plain.patches.size(), 6u);
  EXPECT_TRUE(plain.split.empty());
}

// The blocks of the Cornell box stand on its floor, one input quad (issue 17's contact-aware
// patches): the floor is cut along their footprints, uniform or refined, so no floor patch has
// corners on both sides of a footprint's edge. The cut mesh is conforming, keeps the area, and its
// output vertices lie where their source points say. With --contacts off, patches straddle.
TEST(Contact, TheCornellFloorIsCutAlongTheBlocksFootprints) {
  const Scene scene = importScene((kScenes / "cornell_box.gltf").string());
  ASSERT_EQ(scene.primitives.size(), 8u);
  // The footprints: the blocks' (primitives 6 and 7) points on the floor, counter-clockwise.
  std::vector<std::vector<Vec3>> footprints;
  for (int b : {6, 7}) {
    std::vector<Vec3> foot;
    for (const Vec3& x : scene.primitives[b].positions)
      if (std::abs(x.y) < 1e-9 && std::none_of(foot.begin(), foot.end(), [&](const Vec3& y) { return length(x - y) < 1e-9; }))
        foot.push_back(x);
    ASSERT_EQ(foot.size(), 4u);
    Vec3 c{};
    for (const Vec3& x : foot) c += x / 4;
    std::sort(foot.begin(), foot.end(), [&](const Vec3& a, const Vec3& b) { return std::atan2(a.z - c.z, a.x - c.x) > std::atan2(b.z - c.z, b.x - c.x); });
    footprints.push_back(foot);
  }
  // How far x is inside the footprint (negative: outside), in the floor's plane.
  auto inside = [](const std::vector<Vec3>& foot, const Vec3& x) {
    double d = 1e300;
    for (size_t e = 0; e < foot.size(); ++e) {
      const Vec3 a = foot[e], b = foot[(e + 1) % foot.size()];
      const Vec3 n = normalize(cross(Vec3{0, 1, 0}, b - a));  // inward for this winding, checked below
      d = std::min(d, dot(x - a, n));
    }
    return d;
  };
  for (const auto& foot : footprints) {
    Vec3 c{};
    for (const Vec3& x : foot) c += x / 4;
    ASSERT_GT(inside(foot, c), 0);
  }
  auto straddling = [&](const PatchMesh& mesh) {
    int count = 0;
    for (const Patch& p : mesh.patches) {
      if (p.primitive != 0) continue;
      for (const auto& foot : footprints) {
        // Corners inside and outside, or a footprint corner strictly inside the patch.
        bool in = false, out = false;
        for (uint32_t v : p.v) {
          const double d = inside(foot, mesh.positions[v]);
          in |= d > 1e-9;
          out |= d < -1e-9;
        }
        for (const Vec3& x : foot) {
          bool within = true;
          for (int e = 0; e < 4; ++e) {
            const Vec3 a = mesh.positions[p.v[e]], b = mesh.positions[p.v[(e + 1) % 4]];
            if (length(b - a) > 0) within &= dot(cross(b - a, x - a), p.normal) > 1e-9;
          }
          in |= within;
        }
        count += in && out;
      }
    }
    return count;
  };
  const double floorArea = [&] {
    double a = 0;
    for (const auto& t : scene.primitives[0].triangles) {
      const auto& x = scene.primitives[0].positions;
      a += 0.5 * length(cross(x[t[1]] - x[t[0]], x[t[2]] - x[t[0]]));
    }
    return a;
  }();
  std::vector<TessellateOptions> cases(3);
  cases[1].subdivide = 3;
  cases[2].split = {{0, 0, 0, 0, 0}, {0, 0, 1, 1, 1}, {0, 0, 2, 2, 2}};  // the floor refined toward the blocks
  for (TessellateOptions o : cases) {
    const PatchMesh mesh = tessellate(scene, o);
    SCOPED_TRACE("subdivide " + std::to_string(o.subdivide) + ", " + std::to_string(o.split.size()) + " split cells");
    EXPECT_GE(mesh.contactSegments, 8u);  // at least the blocks' four sides each
    EXPECT_EQ(straddling(mesh), 0);
    EXPECT_EQ(tJunctions(mesh, 0), 0);  // (floor points on a block's foot are not the block's: two surfaces)
    double area = 0;
    for (const Patch& p : mesh.patches) area += p.primitive == 0 ? p.area : 0;
    EXPECT_NEAR(area, floorArea, 1e-12 * floorArea);
    EXPECT_NEAR(outputArea(scene, mesh, 0), floorArea, 1e-12 * floorArea);
    // The pieces are convex quads where two triangles pair across an edge that is not a cut (no
    // corner nearly straight: sin > 0.2), else triangles: a fifth fewer patches than triangles or
    // better (here 17 against 22, 45 against 66, 83 against 116).
    size_t quads = 0, triangles = 0;
    for (const Patch& p : mesh.patches) {
      if (p.primitive != 0) continue;
      if (p.v[3] == p.v[2]) {
        ++triangles;
        continue;
      }
      ++quads;
      for (int c = 0; c < 4; ++c) {
        const Vec3 a = mesh.positions[p.v[(c + 3) % 4]], b = mesh.positions[p.v[c]], d = mesh.positions[p.v[(c + 1) % 4]];
        EXPECT_GT(dot(cross(b - a, d - b), p.normal), 0.199 * length(b - a) * length(d - b));
      }
    }
    EXPECT_LE(quads + triangles, 0.8 * double(2 * quads + triangles));
    o.cutContacts = false;
    EXPECT_GT(straddling(tessellate(scene, o)), 0);
  }
}

// Refinement tessellates one scene again and again with other splits and hands each mesh to the
// next call: the contacts are taken from it, not found again, and the mesh is the one a fresh call
// makes. Asked to cut other primitives (here none), the call finds its own.
TEST(Contact, ATessellationAgainTakesThePreviousMeshsContacts) {
  const Scene scene = importScene((kScenes / "cornell_box.gltf").string());
  TessellateOptions o;
  const PatchMesh first = tessellate(scene, o);
  o.split = {{0, 0, 0, 0, 0}, {0, 0, 1, 1, 1}};
  const PatchMesh again = tessellate(scene, o, &first), fresh = tessellate(scene, o);
  EXPECT_EQ(again.contacts, first.contacts);
  EXPECT_NE(fresh.contacts, first.contacts);
  EXPECT_EQ(again.contactSegments, fresh.contactSegments);
  ASSERT_EQ(again.patches.size(), fresh.patches.size());
  EXPECT_EQ(again.positions, fresh.positions);
  for (size_t k = 0; k < again.patches.size(); ++k) EXPECT_EQ(again.patches[k].v, fresh.patches[k].v);
  o.cutContacts = false;
  const PatchMesh uncut = tessellate(scene, o, &first);
  EXPECT_NE(uncut.contacts, first.contacts);
  EXPECT_EQ(uncut.contactSegments, 0u);
}

}  // namespace

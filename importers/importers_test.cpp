// Importer tests against geometry whose answer is known from how the scene was built.
#include <gtest/gtest.h>

#include <filesystem>

#include "importers/importers.h"

namespace fs = std::filesystem;
using namespace radbake;

namespace {

const fs::path kScenes = fs::path(RADBAKE_TEST_DATA_DIR) / "scenes";

Vec3 faceNormal(const Primitive& p, const std::array<uint32_t, 3>& t) {
  return normalize(cross(p.positions[t[1]] - p.positions[t[0]], p.positions[t[2]] - p.positions[t[0]]));
}

double totalArea(const Primitive& p) {
  double a = 0;
  for (const auto& t : p.triangles) a += 0.5 * length(cross(p.positions[t[1]] - p.positions[t[0]], p.positions[t[2]] - p.positions[t[0]]));
  return a;
}

// A closed box seen from inside: every front face must face the box's centre, and each vertex
// normal must agree with its face's winding.
void expectInwardBox(const Scene& scene, const Vec3& centre) {
  ASSERT_EQ(scene.primitives.size(), 6u);
  for (const Primitive& p : scene.primitives) {
    for (const auto& t : p.triangles) {
      const Vec3 n = faceNormal(p, t);
      EXPECT_GT(dot(n, centre - p.positions[t[0]]), 0) << "mesh " << p.mesh << " node " << p.node;
      for (uint32_t v : t) EXPECT_NEAR(dot(p.normals[v], n), 1.0, 1e-9) << "node " << p.node;
    }
  }
}

TEST(Importer, NestedNodesWithMirrorFaceInward) {
  // One mesh instanced six times through matrix, TRS, non-uniform scale and a mirroring node.
  const Scene scene = importScene((kScenes / "nested_nodes.gltf").string());
  expectInwardBox(scene, {0, 0.5, 0});
  for (const Primitive& p : scene.primitives)
    for (const Vec3& v : p.positions) {
      EXPECT_NEAR(std::abs(v.x) <= 1 + 1e-9, 1, 0);
      EXPECT_GE(v.y, -1e-9);
      EXPECT_LE(v.y, 1 + 1e-9);
      EXPECT_LE(std::abs(v.z), 0.5 + 1e-9);
    }
}

TEST(Importer, ShearedNodesUseTheInverseTransposeForNormals) {
  const Scene scene = importScene((kScenes / "nested_nodes_sheared.gltf").string());
  Vec3 centre{};
  size_t n = 0;
  for (const Primitive& p : scene.primitives)
    for (const Vec3& v : p.positions) { centre += v; ++n; }
  expectInwardBox(scene, centre / double(n));
}

TEST(Importer, StripsAndFansBecomeTheSameUnitFaces) {
  const Scene scene = importScene((kScenes / "triangle_fan_strip.gltf").string());
  expectInwardBox(scene, {0.5, 0.5, 0.5});
  for (const Primitive& p : scene.primitives) EXPECT_NEAR(totalArea(p), 1.0, 1e-12) << "mesh " << p.mesh;
}

TEST(Importer, MaterialsFollowTheDesignUnits) {
  const Scene scene = importScene((kScenes / "cornell_box.gltf").string());
  bool sawLight = false;
  for (const Material& m : scene.materials)
    if (m.emission.x > 0) {
      sawLight = true;
      // emissiveFactor (1, 12/17, 4/17) × KHR_materials_emissive_strength 17
      EXPECT_NEAR(m.emission.x, 17, 1e-6);
      EXPECT_NEAR(m.emission.y, 12, 1e-6);
      EXPECT_NEAR(m.emission.z, 4, 1e-6);
      EXPECT_NEAR(m.reflectance.x, 0.78, 1e-6);
    }
  EXPECT_TRUE(sawLight);
  EXPECT_TRUE(scene.hasEmitter());
}

TEST(Importer, MissingNormalsBecomeFlatNormals) {
  const Scene scene = importScene((kScenes / "one_quad_nonplanar.gltf").string());
  bool sawNoNormals = false;
  for (const Primitive& p : scene.primitives) sawNoNormals |= !p.hasNormals;
  EXPECT_TRUE(sawNoNormals);
}

TEST(Importer, NormalizedQuantizedPositions) {
  // KHR_mesh_quantization: POSITION as normalized UNSIGNED_SHORT with a byte stride of 8;
  // 65535 reads as exactly 1, then the node scales by 2.
  const Scene scene = importScene(std::string(RADBAKE_SOURCE_DIR) + "/tests/data/quantized_triangle.gltf");
  ASSERT_EQ(scene.primitives.size(), 1u);
  const Primitive& p = scene.primitives[0];
  ASSERT_EQ(p.positions.size(), 3u);
  EXPECT_EQ(p.positions[1], (Vec3{0, 0, 2}));
  EXPECT_EQ(p.positions[2], (Vec3{2, 0, 0}));
  ASSERT_EQ(p.triangles.size(), 1u);
  EXPECT_NEAR(p.normals[0].y, 1.0, 1e-12);  // no NORMAL: flat, from the winding
}

TEST(Importer, SparseAccessorsSubstituteTheirValues) {
  // POSITION with no buffer view (zeros) and a sparse part setting elements 1 and 2.
  const Scene scene = importScene(std::string(RADBAKE_SOURCE_DIR) + "/tests/data/sparse_triangle.gltf");
  ASSERT_EQ(scene.primitives.size(), 1u);
  const Primitive& p = scene.primitives[0];
  EXPECT_EQ(p.positions[0], (Vec3{0, 0, 0}));
  EXPECT_EQ(p.positions[1], (Vec3{0, 0, 1}));
  EXPECT_EQ(p.positions[2], (Vec3{1, 0, 0}));
  EXPECT_EQ(p.triangles.size(), 1u);
}

// World bounding box and total area of every triangle of a scene.
std::pair<std::array<double, 6>, double> extentAndArea(const Scene& scene) {
  std::array<double, 6> box{1e300, 1e300, 1e300, -1e300, -1e300, -1e300};
  double area = 0;
  for (const Primitive& p : scene.primitives) {
    for (const auto& t : p.triangles)
      for (uint32_t v : t)
        for (int k = 0; k < 3; ++k) {
          box[k] = std::min(box[k], p.positions[v][k]);
          box[k + 3] = std::max(box[k + 3], p.positions[v][k]);
        }
    area += totalArea(p);
  }
  return {box, area};
}

TEST(Importer, DracoDecodesToTheSameEngine) {
  // The Draco-compressed 2CylinderEngine against the plain one: the same world extent within the
  // compression's quantization (1e-3 of the size) and the same surface area within 0.5%.
  const fs::path assets = fs::path(RADBAKE_TEST_DATA_DIR) / "assets" / "valid";
  const auto plain = extentAndArea(importScene((assets / "2CylinderEngine" / "2CylinderEngine.glb").string()));
  const auto draco = extentAndArea(importScene((assets / "2CylinderEngine-draco" / "2CylinderEngine.gltf").string()));
  const double size = plain.first[3] - plain.first[0];
  for (int k = 0; k < 6; ++k) EXPECT_NEAR(draco.first[k], plain.first[k], 1e-3 * size) << k;
  EXPECT_NEAR(draco.second / plain.second, 1.0, 5e-3);
}

TEST(Importer, ErrorsCarryExitCodes) {
  try {
    importScene("/nonexistent.glb");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kInvalidInput);
    EXPECT_STREQ(e.what(), "nonexistent.glb: cannot open: no such file");
  }
}

}  // namespace

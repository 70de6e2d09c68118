// Importer tests against geometry whose answer is known from how the scene was built.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <sys/stat.h>
#include <unistd.h>

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

// ---- Reading only the asset's own files (importers/asset_files.h) -----------------------------

// One triangle whose POSITION buffer is the file `uri` (36 bytes), written into `dir`.
std::string triangleWithBuffer(const std::string& uri) {
  return R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
    "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
    "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}],
    "bufferViews":[{"buffer":0,"byteLength":36}],"buffers":[{"byteLength":36,"uri":")" + uri + R"("}]})";
}

void writeBytes(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out << bytes;
}

// What importing `gltf` (written as dir/asset/scene.gltf) says: "" or the error's message.
std::string importProblem(const fs::path& dir, const std::string& gltf, bool allowOutside = false) {
  writeBytes(dir / "asset" / "scene.gltf", gltf);
  ImportOptions options;
  options.allowOutsidePaths = allowOutside;
  try {
    importScene((dir / "asset" / "scene.gltf").string(), options);
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kInvalidInput) << e.what();
    return e.what();
  }
  return "";
}

TEST(AssetFiles, UrisLeavingTheFolderAreRefusedUnlessAllowed) {
  const fs::path dir = fs::temp_directory_path() / ("radbake_asset_files_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "asset" / "sub");
  float triangle[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const std::string bytes(reinterpret_cast<const char*>(triangle), sizeof triangle);
  writeBytes(dir / "outside.bin", bytes);  // the right size: only the path rule can refuse it
  writeBytes(dir / "asset" / "sub" / "inside.bin", bytes);
  fs::create_symlink("../outside.bin", dir / "asset" / "link.bin");
  fs::create_symlink("sub/inside.bin", dir / "asset" / "good_link.bin");
  ASSERT_EQ(::mkfifo((dir / "asset" / "pipe.bin").c_str(), 0600), 0);
  const std::string abs = (dir / "outside.bin").string();

  EXPECT_EQ(importProblem(dir, triangleWithBuffer("sub/inside.bin")), "");
  EXPECT_EQ(importProblem(dir, triangleWithBuffer("good_link.bin")), "");  // a link that stays inside
  EXPECT_EQ(importProblem(dir, triangleWithBuffer("sub%2Finside.bin")), "");
  for (const std::string& uri : {std::string("../outside.bin"), std::string("%2E%2E/outside.bin"),
                                 std::string("%2e%2e%2Foutside.bin"), std::string("sub/../../outside.bin")}) {
    const std::string problem = importProblem(dir, triangleWithBuffer(uri));
    EXPECT_NE(problem.find("scene.gltf: buffer 0: uri \"" + uri + "\" leaves the asset's folder"), std::string::npos) << problem;
    EXPECT_EQ(importProblem(dir, triangleWithBuffer(uri), true), "") << uri;
  }
  EXPECT_NE(importProblem(dir, triangleWithBuffer(abs)).find("buffer 0: uri \"" + abs + "\" is an absolute path"), std::string::npos);
  EXPECT_EQ(importProblem(dir, triangleWithBuffer(abs), true), "");
  EXPECT_NE(importProblem(dir, triangleWithBuffer("file://" + abs)).find("is not a relative file path"), std::string::npos);
  EXPECT_NE(importProblem(dir, triangleWithBuffer("link.bin")).find("buffer 0: uri \"link.bin\" is a link leading out"), std::string::npos);
  EXPECT_EQ(importProblem(dir, triangleWithBuffer("link.bin"), true), "");
  // Non-regular files are refused even when outside paths are allowed; a FIFO must not block.
  EXPECT_NE(importProblem(dir, triangleWithBuffer("pipe.bin"), true).find("buffer 0: uri \"pipe.bin\": not a regular file (a FIFO)"),
            std::string::npos);
  EXPECT_NE(importProblem(dir, triangleWithBuffer("/dev/zero"), true).find("character device"), std::string::npos);
  EXPECT_NE(importProblem(dir, triangleWithBuffer("sub")).find("buffer 0: uri \"sub\": not a regular file (a directory)"),
            std::string::npos);
  // Never the working directory: a file there with the URI's name is not found.
  const fs::path cwd = fs::current_path();
  fs::current_path(dir / "asset" / "sub");
  const std::string fallback = importProblem(dir, triangleWithBuffer("inside.bin"));
  fs::current_path(cwd);
  EXPECT_NE(fallback.find("buffer 0: uri \"inside.bin\": no such file in the asset's folder"), std::string::npos) << fallback;
  fs::remove_all(dir);
}

TEST(AssetFiles, StrictReadingNamesTheElement) {
  const fs::path dir = fs::temp_directory_path() / ("radbake_asset_strict_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "asset");
  const std::string data = "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA";
  const std::string good = triangleWithBuffer(data);
  EXPECT_EQ(importProblem(dir, good), "");
  auto replaced = [&](const std::string& from, const std::string& to) {
    std::string s = good;
    s.replace(s.find(from), from.size(), to);
    return importProblem(dir, s);
  };
  EXPECT_EQ(replaced("AAAAgD8AAAAA\"", "AAAAgD8AAAAA!!\""), "scene.gltf: buffer 0: data URI: invalid base64 '!' at character 48");
  EXPECT_EQ(replaced("AAAAgD8AAAAA\"", "AAAAgD8AAAAAAAAA\""), "scene.gltf: buffer 0: byteLength 36, but its data URI holds 39 bytes");
  EXPECT_EQ(replaced("\"byteLength\":36}]", "\"byteLength\":36,\"byteStride\":4}]"),
            "scene.gltf: accessor 0: its 12-byte elements do not fit buffer view 0's byteStride 4");
  EXPECT_EQ(replaced("\"byteLength\":36}]", "\"byteLength\":36,\"byteStride\":13}]"),
            "scene.gltf: buffer view 0: byteStride 13 must be a multiple of 4 from 4 to 252");
  EXPECT_EQ(replaced("\"attributes\":{\"POSITION\":0}", "\"attributes\":{\"POSITION\":0},\"mode\":7"),
            "scene.gltf: mesh 0 primitive 0: mode 7 is not a glTF primitive mode (0 to 6)");
  EXPECT_EQ(replaced("\"nodes\":[0]", "\"nodes\":[0,0]"), "scene.gltf: scene 0: lists node 0 twice");
  EXPECT_EQ(replaced("\"componentType\":5126", "\"componentType\":5000"),
            "scene.gltf: accessor 0: componentType 5000 is not a glTF component type");
  EXPECT_EQ(replaced(data, ""), "scene.gltf: buffer 0: uri is empty");
  EXPECT_EQ(replaced("[{\"primitives\":[{\"attributes\":{\"POSITION\":0}}]}]", "[{\"primitives\":[]}]"),
            "scene.gltf: mesh 0: has no primitives (glTF requires at least one)");
  // A 3 MB bad data URI gives one short line, not the URI.
  const std::string huge = replaced("AAAAgD8AAAAA\"", std::string(3'000'000, 'A') + "*\"");
  EXPECT_LE(huge.size(), kMaxMessageLength);
  EXPECT_NE(huge.find("buffer 0: data URI: invalid base64 '*'"), std::string::npos) << huge;
  // Nesting 20,000 deep is refused before a parser recurses into it.
  const std::string deep = replaced("\"asset\":{\"version\":\"2.0\"}", "\"asset\":{\"version\":\"2.0\",\"extras\":" +
                                                                         std::string(20000, '[') + std::string(20000, ']') + "}");
  EXPECT_EQ(deep, "scene.gltf: JSON arrays and objects nested deeper than 128 levels (at byte 161)");
  fs::remove_all(dir);
}

#include "core/core.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <unistd.h>

namespace radbake {
namespace {

namespace fs = std::filesystem;

TEST(Transforms, InvertAffineUndoesAMirroringShearingNode) {
  // Column-major: x scaled by −2 (a mirror), y sheared into x, then translated.
  const Matrix4 m{-2, 0, 0, 0, 0.5, 1, 0, 0, 0, 0, 3, 0, 4, -5, 6, 1};
  EXPECT_DOUBLE_EQ(determinant3(m), -6);
  const Vec3 p{0.25, -1.5, 2};
  const Vec3 back = transformPoint(invertAffine(m), transformPoint(m, p));
  EXPECT_NEAR(back.x, p.x, 1e-14);
  EXPECT_NEAR(back.y, p.y, 1e-14);
  EXPECT_NEAR(back.z, p.z, 1e-14);
}

TEST(Files, LowerExtensionKeepsTheDotAndOnlyTheLastExtension) {
  EXPECT_EQ(lowerExtension("Dir.D/Scene.Baked.GLB"), ".glb");
  EXPECT_EQ(lowerExtension("out.gltf"), ".gltf");
  EXPECT_EQ(lowerExtension("dir.d/noext"), "");
}

std::string contents(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

TEST(Files, AtomicWritesAreAllOrNothing) {
  const fs::path dir = fs::temp_directory_path() / ("radbake-core-test-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string a = (dir / "a.txt").string(), b = (dir / "b.bin").string();
  writeFilesAtomically({{a, "first"}, {b, std::string("\0\1", 2)}});
  EXPECT_EQ(contents(a), "first");
  EXPECT_EQ(contents(b), std::string("\0\1", 2));

  // The second file cannot be written: the first is not replaced and no temporary stays behind.
  fs::remove(a);
  try {
    writeFilesAtomically({{a, "second"}, {(dir / "missing" / "c.txt").string(), "x"}});
    ADD_FAILURE() << "expected Error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kCannotWrite);
    EXPECT_NE(std::string(e.what()).find("c.txt: cannot write"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(a));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator{}), 1);  // b.bin alone
  fs::remove_all(dir);
}

TEST(Color, SrgbDecodeInvertsEncodeInBothPrecisions) {
  for (double x : {0.0, 0.001, 0.05, 0.18, 0.5, 1.0}) {
    EXPECT_NEAR(srgbDecode(srgbEncode(x)), x, 1e-12) << x;
    EXPECT_NEAR(srgbDecode<float>(float(srgbEncode(x))), x, 1e-6) << x;
  }
}

}  // namespace
}  // namespace radbake

#include "core/core.h"

#include <gtest/gtest.h>

namespace radbake {
namespace {

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

}  // namespace
}  // namespace radbake

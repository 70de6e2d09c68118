#include "core/core.h"

namespace radbake {

Matrix4 invertAffine(const Matrix4& m) {
  const double a = m[0], b = m[4], c = m[8], d = m[1], e = m[5], f = m[9], g = m[2], h = m[6], i = m[10];
  const double det = determinant3(m);
  const double r[9] = {(e * i - f * h) / det, (c * h - b * i) / det, (b * f - c * e) / det,
                       (f * g - d * i) / det, (a * i - c * g) / det, (c * d - a * f) / det,
                       (d * h - e * g) / det, (b * g - a * h) / det, (a * e - b * d) / det};  // row-major
  Matrix4 out{r[0], r[3], r[6], 0, r[1], r[4], r[7], 0, r[2], r[5], r[8], 0, 0, 0, 0, 1};
  const double tx = m[12], ty = m[13], tz = m[14];
  out[12] = -(r[0] * tx + r[1] * ty + r[2] * tz);
  out[13] = -(r[3] * tx + r[4] * ty + r[5] * tz);
  out[14] = -(r[6] * tx + r[7] * ty + r[8] * tz);
  return out;
}

}  // namespace radbake

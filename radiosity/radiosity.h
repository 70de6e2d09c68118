// radiosity: PatchMesh → Solution, diffuse interreflection.
//
// Outgoing radiance L (emission included, linear, per colour channel) solves
//   L(x) = L⁰(x) + ρ(x) ∫ L(y) cosθx cosθy V(x,y) / (π r²) dA_y.
// Bilinear method (Bian, Wittels & Fussell): unknowns at patch vertices, L bilinear across each
// patch. Constant method: one value per patch, the classic baseline.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "tessellate/tessellate.h"

namespace radbake {

enum class Method { kBilinear, kConstant };

struct RadiosityOptions {
  Method method = Method::kBilinear;
  double relativeResidual = 1e-6;  // stop when ‖L − (L⁰ + ρKL)‖ ≤ this × ‖L⁰‖
  int maxIterations = 10000;
  std::function<void(double fraction)> progress;  // called from the solving thread; may be empty
};

struct Solution {
  Method method = Method::kBilinear;
  std::vector<Vec3> vertexRadiance;  // per PatchMesh vertex (bilinear; constant: area-weighted patch average)
  std::vector<Vec3> patchRadiance;   // per patch (constant method)
  int iterations = 0;
  double residual = 0;  // relative, as in RadiosityOptions
  bool interreflection = false;  // false: emission only (L = L⁰), the stage is not built yet
};

Solution solveRadiosity(const Scene& scene, const PatchMesh& mesh, const RadiosityOptions& options = {});

}  // namespace radbake

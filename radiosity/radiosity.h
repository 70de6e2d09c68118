// radiosity: PatchMesh → Solution, diffuse interreflection.
//
// Outgoing radiance L (emission included, linear, per colour channel) solves
//   L(x) = L⁰(x) + ρ(x) ∫ L(y) cosθx cosθy V(x,y) / (π r²) dA_y.
// Bilinear method (Bian, Wittels & Fussell): unknowns at patch vertices, L bilinear across each
// patch. Constant method: one value per patch, the classic baseline.
#pragma once

#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "tessellate/tessellate.h"

namespace radbake {

enum class Method { kBilinear, kConstant };
// exact: every receiver gathers from every patch (the reference). hierarchical: far clusters of
// patches are gathered through their vector moment (docs/radiosity.md "Hierarchical transport").
enum class TransportMode { kExact, kHierarchical };

struct RadiosityOptions {
  Method method = Method::kBilinear;
  TransportMode transport = TransportMode::kExact;
  // Hierarchical transport: the largest estimated error of one far link, as a share of the
  // receiver's hemisphere (3 (r/d)² F for a cluster of radius r at distance d with factor F).
  double accuracy = 1e-3;
  double relativeResidual = 1e-6;  // stop when ‖L − (L⁰ + ρKL)‖ ≤ this × ‖L⁰‖
  int maxIterations = 10000;
  double kernelTolerance = 1e-6;   // relative accuracy of each bilinear kernel K_ij
  // Uniform sky radiance lighting an open scene from every direction no surface covers (zero: none,
  // light that leaves the scene is lost).
  Vec3 sky{};
  // Past this size the transport rows are not stored but recomputed in every iteration
  // (matrix-free: memory stays O(n), time grows by the iteration count).
  size_t matrixMemoryBytes = size_t(2) << 30;
  // The hierarchical transport has no matrix-free form: past this many bytes of near entries and
  // links, solveRadiosity stops building it and throws TransportMemoryExceeded.
  size_t transportMemoryBytes = SIZE_MAX;
  std::function<void(double fraction)> progress;  // serialized calls from worker threads; may be empty
};

struct Solution {
  Method method = Method::kBilinear;
  std::vector<Vec3> vertexRadiance;  // per PatchMesh vertex (bilinear; constant: area-weighted patch average)
  std::vector<Vec3> patchRadiance;   // per patch (constant method)
  int iterations = 0;
  bool converged = true;  // false: maxIterations ran out before the residual reached the tolerance
  double residual = 0;  // relative, as in RadiosityOptions
  bool interreflection = false;  // false: emission only (L = L⁰)
  // Under a sky, per unknown, the share of its hemisphere (cosine-weighted) that no surface covers:
  // what the solve lit by the sky (0 inside a closed surface). Empty without a sky.
  std::vector<double> skyFraction;
  size_t matrixEntries = 0;      // transport factors (stored, or estimated when matrix-free)
  size_t farLinks = 0;           // hierarchical: links from receivers to whole source clusters
  size_t refinedLinks = 0;       // hierarchical: links walked again for the light they carry
  size_t clusterRays = 0;        // hierarchical: visibility rays shot at clusters
  size_t nearRays = 0;           // hierarchical: visibility rays of the exact (vertex, patch) pairs
  size_t clusters = 0;           // hierarchical: nodes of the source and receiver trees
  // hierarchical: the largest sum, over one vertex's far links, of their error estimates (a share
  // of its hemisphere; each link is made below --accuracy)
  double linkErrorBound = 0;
  size_t transportBytes = 0;     // what the transport keeps (rows, or near entries, links and trees)
  bool matrixFree = false;
  // Closure: unknowns inside a closed surface (their total factor is exactly 1), and the largest
  // correction their rows needed, |Σ_j K_ij − 1| before scaling (partial-visibility estimates).
  size_t enclosedUnknowns = 0;
  double closureCorrection = 0;
  size_t darkUnknowns = 0;  // enclosed in a room with no emitter or light inside: black, not solved
  size_t contactUnknowns = 0;  // vertices under an object standing on their surface, gathered beside it
  size_t tracedUnknowns = 0;   // back sides seen little: gathered by fixed rays, not walked (hierarchical)
  // Power balance in radiance × area × π units, averaged over the three channels: what the
  // emitters send out and what the surfaces absorb of it and its reflections (sky light is not
  // counted). In a closed scene they agree; the gap is the light that leaves an open scene (plus
  // discretization error).
  double emittedPower = 0;
  double absorbedPower = 0;
  // Every emitting patch lies inside a closed room and there is no sky and no punctual light: all
  // the emitted power must be absorbed, so 1 − absorbed/emitted is the discretization's error.
  bool lightEnclosed = false;
};

// What solveRadiosity throws when the hierarchical transport outgrows options.transportMemoryBytes
// (what() names the budget in MiB).
struct TransportMemoryExceeded : std::runtime_error {
  using std::runtime_error::runtime_error;
};

Solution solveRadiosity(const Scene& scene, const PatchMesh& mesh, const RadiosityOptions& options = {});

// Adaptive refinement: each round measures the patches it has not seen (how far the bilinear
// interpolation of the direct light from emitting patches, punctual lights and a uniform `sky`
// (RadiosityOptions::sky) misses it at a patch's centre and edge midpoints, times ρ, relative to
// the scene's area-weighted mean of that light) and splits the cells of those above `target`, most
// squared error over area first, while the budget lasts (`maxPatches`; 0: the starting
// patches plus 20,000); tessellate balances and closes the splits. Once no cell is above the
// target or half the budget is spent, the light those surfaces reflect once is gathered at the
// samples too (64 rays each, from the mesh the first phase left), so a patch lit only by other surfaces (a lamp's back 2 cm under a ceiling)
// is split where that light changes. `mesh` is replaced by the refined one and `options.split`
// holds its cells. `progress`, if given, hears the fraction done (by patches measured, which is
// nearly all of the time), rising to 1 at the end; serialized calls from worker threads.
struct Refinement {
  size_t maxPatches = 0;
  int rounds = 0;
  size_t splitCells = 0;     // cells chosen for their error (balance splits more)
  double worst = 0;          // the largest error left on cells that can still be split
  bool budgetReached = false;  // stopped with cells above the target
};
Refinement refineMesh(const Scene& scene, TessellateOptions& options, PatchMesh& mesh, double target, size_t maxPatches,
                      const Vec3& sky = {}, const std::function<void(double)>& progress = {});
// The solved radiance at the surface point nearest to `point` among patches whose normal faces
// `normal` (dot > 0): bilinear inside a patch for the bilinear method, the patch value for the
// constant method.
Vec3 evaluateRadiance(const Solution& solution, const PatchMesh& mesh, const Vec3& point, const Vec3& normal);

}  // namespace radbake

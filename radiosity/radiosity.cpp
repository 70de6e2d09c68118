#include "radiosity/radiosity.h"

namespace radbake {

// Until the interreflection solver lands (issue 5), the answer is the emission alone: L = L⁰.
Solution solveRadiosity(const Scene& scene, const PatchMesh& mesh, const RadiosityOptions& options) {
  Solution solution;
  solution.method = options.method;
  solution.vertexRadiance.resize(mesh.positions.size());
  for (size_t v = 0; v < mesh.positions.size(); ++v)
    solution.vertexRadiance[v] = scene.materials[mesh.vertexMaterial[v]].emission;
  solution.patchRadiance.resize(mesh.patches.size());
  for (size_t p = 0; p < mesh.patches.size(); ++p)
    solution.patchRadiance[p] = scene.materials[mesh.patches[p].material].emission;
  return solution;
}

}  // namespace radbake

// Internal to tessellate/: limit surfaces of subdivision cages with OpenSubdiv Bfr.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "core/core.h"
#include "importers/importers.h"

namespace radbake {

// Samples of a cage's limit surface at a uniform rate per face edge. Bfr tessellates each face on
// its own; here every cage vertex and every point along a cage edge is evaluated once and shared
// by the faces around it, so the samples are crack-free by construction.
struct LimitTessellation {
  std::vector<Vec3> positions, normals;  // limit points and unit normals (front: the face winding)
  std::vector<int> face;                 // cage face each sample was evaluated on
  std::vector<std::array<uint32_t, 4>> quads;  // facets; a triangle has q[3] == q[2]
  std::vector<int> quadFace;             // cage face of each facet
};

// faces: vertex indices into cagePoints, counter-clockwise, 3 or 4 per face (more is accepted).
LimitTessellation tessellateLimitSurface(const std::vector<Vec3>& cagePoints,
                                         const std::vector<std::vector<uint32_t>>& faces,
                                         SubdivisionScheme scheme, int rate);

}  // namespace radbake

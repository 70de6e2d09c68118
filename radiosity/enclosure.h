// Internal to radiosity/: which patches lie inside a closed surface.
//
// A receiver whose hemisphere is covered by the scene gathers with a total factor of exactly 1.
// That holds on a closed surface whose front faces inward (a room, the inside of a furnace) and on
// anything inside one. Rays estimate partial visibility only approximately, so the solver uses
// this to restore the exact total of such receivers (docs/radiosity.md, "Closure").
#pragma once

#include <vector>

#include "tessellate/tessellate.h"

namespace radbake {

// The closed surfaces whose fronts face inward (rooms) and what each one encloses. Closed means
// every edge is shared by exactly two patches of the same side (front or double-sided back),
// running in opposite directions, matched by exact position (unwelded creases included).
struct Enclosures {
  std::vector<int> of;                        // per patch: the innermost room it is in or bounds, or −1
  std::vector<std::vector<uint32_t>> walls;   // per room: the patches of its closed surface
  // Whether `point` is inside room `room` (generalized winding number of its walls).
  bool contains(const PatchMesh& mesh, int room, const Vec3& point) const;
};

Enclosures findEnclosures(const PatchMesh& mesh);

}  // namespace radbake

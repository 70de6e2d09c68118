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

// Per patch: true when the patch belongs to a closed, consistently oriented surface whose front
// faces inward, or lies inside one. Closed means every edge is shared by exactly two patches of the
// same side (front or double-sided back), running in opposite directions, matched by exact
// position (unwelded creases included).
std::vector<bool> enclosedPatches(const PatchMesh& mesh);

}  // namespace radbake

// Internal to tessellate/: flat patches cut along the curves where other surfaces touch them or pass
// through them (a block standing on a floor, a leg through a rug, parts pressed into each other), so
// no patch straddles a footprint and no hidden vertex feeds a visible one (issue 17).
//
// Two steps. findContacts intersects the source triangles of the flat primitives: the segments
// where another triangle touches or crosses a triangle's plane (not where it lies in it: coincident
// surfaces are ambiguous). After the faces are split into patches (uniform or refined cells, so
// patch sizes stay what was asked for), cutPatches triangulates every patch a segment crosses along
// its segments, pairs the triangles back into quads where no cut runs between them, and puts the
// points where a cut ends on a patch edge into the patch across that edge too: the mesh stays
// conforming.
#pragma once

#include <array>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "core/core.h"
#include "importers/importers.h"
#include "tessellate/tessellate.h"

namespace radbake {

using ContactSegment = std::array<Vec3, 2>;

struct Contacts {
  std::vector<bool> cuttable;  // the primitives they were found among (findContacts' argument)
  double epsilon = 0;  // points this close are one (the files' rounding)
  // Per primitive (parallel to Scene::primitives): source triangle → the segments inside it.
  std::vector<std::unordered_map<uint32_t, std::vector<ContactSegment>>> segments;
  // Primitives whose patches may be cut: a segment inside, or a point of one on an edge.
  std::vector<bool> touched;
  size_t count = 0;
};

// The contact and intersection segments of the primitives marked `cuttable` (flat ones), among
// themselves.
Contacts findContacts(const Scene& scene, const std::vector<bool>& cuttable);

// A patch in pieces: its points (the corners first, then new ones; each with weights on the
// patch's four corners that give its position) and convex quads and triangles (d = c) over them,
// counter-clockwise seen from the patch's front.
struct PatchPieces {
  uint32_t patch = 0;
  std::vector<Vec3> position;
  std::vector<std::array<double, 4>> weights;
  std::vector<std::array<int, 4>> polygons;
};

// The pieces of the patches marked `cuttable`, given each one's candidate segments (those of its
// face's source triangles; most have none). A degenerate patch, one crossed by more than 32 cuts,
// or one whose cuts rounding leaves undecided stays whole.
std::vector<PatchPieces> cutPatches(const PatchMesh& mesh, const std::vector<bool>& cuttable,
                                    const std::vector<std::vector<ContactSegment>>& segments, double epsilon);

}  // namespace radbake

// Internal to radiosity/: occlusion queries against every patch, with Embree 3.
//
// All Embree calls stay in visibility.cpp (Embree 4 changed the signatures). Every patch occludes
// from both sides: a one-sided surface emits and reflects on its front only, but it still blocks
// light, which is what keeps light from leaking under the Cornell box's blocks.
#pragma once

#include <functional>
#include <memory>
#include <span>
#include <vector>

#include "tessellate/tessellate.h"

namespace radbake {

class Occlusion {
 public:
  explicit Occlusion(const PatchMesh& mesh);
  ~Occlusion();
  Occlusion(const Occlusion&) = delete;
  Occlusion& operator=(const Occlusion&) = delete;

  // True when nothing lies strictly between `from` and `to` (both ends excluded by a small margin
  // relative to the scene size, so surfaces at the ends do not count). Patches listed in `ignore`
  // do not block: the source patch itself and the patches around the receiving vertex, whose
  // triangles can stand between a point and its own slightly non-planar (curved) patch. Thread-safe.
  bool visible(const Vec3& from, const Vec3& to, std::span<const uint32_t> ignore = {}) const;
  // The same for up to 16 rays from one point (visible[k] for to[k]), traced as packets of 8 where
  // Embree has them: rays from one point to one patch are coherent, and a packet costs about what
  // two single rays do.
  void visibleFrom(const Vec3& from, std::span<const Vec3> to, std::span<const uint32_t> ignore, bool* visible) const;
  // The same for any number of segments, each with its own ends and ignore list (rays from the
  // receivers of a group to the patches of a cluster: nearby origins, nearly parallel), in packets
  // of 8 where Embree has them.
  struct Segment {
    Vec3 from, to;
    std::span<const uint32_t> ignore;
  };
  void visibleEach(std::span<const Segment> segments, bool* visible) const;
  // The patch whose surface the segment from `from` to `to` meets first (strictly between, as in
  // visible(); ignored and cut-out patches stepped over), or -1.
  int64_t firstHit(const Vec3& from, const Vec3& to, std::span<const uint32_t> ignore = {}) const;
  // firstHit(from, to[k], ignore) for every k, in packets of 8 where Embree has them (the rays of
  // a hemisphere gathered from one point).
  void firstHits(const Vec3& from, std::span<const Vec3> to, std::span<const uint32_t> ignore, int64_t* hit) const;
  // The patches whose bounds come within `radius` of `p` (appended to `out`; a superset of those
  // within that distance: the caller measures them).
  void patchesNear(const Vec3& p, double radius, std::vector<uint32_t>& out) const;
  // Whether `accept(patch)` holds for some patch whose bounds come within `radius` of `p`; asks
  // no more once one does.
  bool anyNear(const Vec3& p, double radius, const std::function<bool(uint32_t)>& accept) const;
  // Cut-out patches (alpha MASK): `passes(patch, u, v)` says whether light goes through `patch` at
  // Embree's quad coordinates (v0 = (0,0), v1 = (1,0), v2 = (1,1), v3 = (0,1); split v0 v1 v3 /
  // v2 v3 v1). Set before any query; only patches with a mask are asked.
  void setCutouts(std::function<bool(uint32_t patch, double u, double v)> passes) { passes_ = std::move(passes); }

  // A length that is negligible against the scene (1e-7 of its bounding-box diagonal).
  double epsilon() const { return epsilon_; }
  // The scene's bounding-box diagonal (1 for an empty scene).
  double sceneSize() const { return sceneSize_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::function<bool(uint32_t, double, double)> passes_;
  double epsilon_ = 0;
  double sceneSize_ = 1;
};

}  // namespace radbake

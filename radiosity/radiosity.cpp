#include "radiosity/radiosity.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <atomic>
#include <cmath>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <unordered_map>
#include <span>
#include <string>
#include <tuple>
#include <utility>

#include "core/core.h"
#include "radiosity/enclosure.h"
#include "radiosity/form_factor.h"
#include "radiosity/cluster_tree.h"
#include "radiosity/visibility.h"

namespace radbake {
namespace {

// Where visibility is first probed on a patch, in (s, t): its centre and four inner points.
constexpr double kProbe[5][2] = {{0, 0}, {-0.5, -0.5}, {0.5, -0.5}, {0.5, 0.5}, {-0.5, 0.5}};

// Calls progress(fraction) at most ~100 times, from whichever worker crosses each step.
class Ticker {
 public:
  Ticker(const std::function<void(double)>& progress, size_t total, double from, double to)
      : progress_(progress), total_(std::max<size_t>(total, 1)), from_(from), to_(to) {}
  void add(size_t n) {
    if (!progress_) return;
    const size_t before = done_.fetch_add(n);
    if ((before + n) * 100 / total_ != before * 100 / total_) {
      std::lock_guard lock(mutex_);
      // The count as it is now, read under the lock: two threads crossing a percent together could
      // otherwise report in the opposite order, and the progress would go back (seen in
      // Progress.SkyPassReportsBeforeTheTransport under a parallel ctest).
      progress_(from_ + (to_ - from_) * double(done_.load()) / double(total_));
    }
  }

 private:
  const std::function<void(double)>& progress_;
  size_t total_;
  double from_, to_;
  std::atomic<size_t> done_{0};
  std::mutex mutex_;
};

using Row = std::vector<std::pair<uint32_t, double>>;  // (column, factor), sorted by column

// Sums duplicate columns (a vertex shared by several source patches) in a fixed order.
void canonicalize(Row& row) {
  std::sort(row.begin(), row.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  size_t w = 0;
  for (size_t r = 0; r < row.size(); ++r) {
    if (w > 0 && row[w - 1].first == row[r].first) row[w - 1].second += row[r].second;
    else row[w++] = row[r];
  }
  row.resize(w);
}

// The transport operator, row i = what unknown i gathers from every other. Stored as sparse rows
// when they fit the memory budget, else rebuilt on the fly in every iteration (matrix-free): the
// same rows in the same order, so both give the same bits.
struct Transport {
  size_t rows = 0;
  std::function<void(size_t, Row&)> build;  // computes row i
  std::vector<size_t> start;                // stored form (empty: matrix-free)
  std::vector<uint32_t> column;
  std::vector<double> value;
  bool stored() const { return !start.empty(); }
};

// Hierarchical transport (docs/radiosity.md): what vertex i gathers is
//   rowScale_i · (Σ_j near_ij L_j + farScale_i · n_i · Φ(p_i)),
// near entries exact as in Transport, and Φ the vector irradiance of the far clusters: for each
// receiver group G ∋ i, Σ_links Φ_C(p) with Φ_C(p) = −w (w · M_C) / (π |w|⁴), w = c_C − p, M_C the
// cluster's vector moment of L. Each group keeps Φ at its centroid and its gradient, so that a
// receiver off the centroid is served to second order.
struct ClusterLink {
  uint32_t source;    // node of the source tree (w, from the group's centroid to its, is recomputed)
  float visible = 1;  // the seen share: below 1 only for a faint, partly hidden cluster and one vertex
};

constexpr uint32_t kNoLeaf = UINT32_MAX;  // a vertex that gathers nothing is in no group
constexpr uint32_t kNoMate = UINT32_MAX;

struct Receivers;

// Receivers at one point share a site (receiverSites): per receiver its site's first receiver, and
// per site of more than one receiver what its rays step over, the patches of all of them and their
// twins (`list`, the first `own` of them tested exactly, as a receiver's own are: Sight).
struct ReceiverSites {
  struct Patches {
    std::vector<uint32_t> list;
    uint32_t own = 0;
  };
  std::vector<uint32_t> first;
  std::vector<Patches> patches;  // per receiver; empty but at a shared site's first
  std::span<const uint32_t> ignored(const Receivers& recv, uint32_t v) const;
  std::span<const uint32_t> own(const Receivers& recv, uint32_t v) const;
};

// The receiver tree and the parallel tasks over it, shared by the sky and transport walks.
struct ReceiverGroups {
  ClusterTree tree;
  std::vector<uint32_t> leafOf;  // vertex → its leaf
  std::vector<int32_t> parent;   // node → its parent (-1 for the root): a vertex's groups, leaf up
  std::vector<uint32_t> tasks;   // subtrees of at most kTaskVertices vertices, in tree order
  // Receivers at one point (a flat-shaded crease's vertices, one per face, on one side) are one
  // site: their rays start within a hair of each other, so a group's visibility rays are traced
  // from one of them, its site's first in the group, for all of them (receiverSites). Per tree
  // order index, the order index of the previous and next receiver of its site (kNoMate: none);
  // per node, how many sites it holds (the tree keeps a site's receivers together: items at one
  // point are not split apart, buildClusterTree).
  std::vector<uint32_t> mateBefore, mateAfter;
  std::vector<uint32_t> siteCount;
  ReceiverSites site;
};

struct Hierarchical {
  ClusterTree source;                               // over patches
  ReceiverGroups groups;                            // over the unknowns that gather
  bool perPatch = false;  // the unknowns are patches (constant method): a patch's moment is n A L
  std::vector<std::array<double, 4>> shapeAreas;    // bilinear: per patch, A_j = ∫ N_j dA (the moments)
  // The near entries per vertex, (column, value) sorted by column; the value in 7 digits, more than
  // the near kernels are integrated to (--accuracy/10). And the links per receiver node. Both kept
  // as the walk built them: gathered into one array each they were held twice at the end (at 422k
  // patches, 260M entries and 177M links: the rows alone 2 GiB more at the peak).
  std::vector<std::vector<std::pair<uint32_t, float>>> near;
  std::vector<std::vector<ClusterLink>> links;
  size_t nearEntries = 0, linkCount = 0;
  std::vector<double> nodeError;                    // per receiver node, Σ of its links' error estimates
  std::vector<double> rowScale;                     // closure (0: dark or facing nothing)
  // Per vertex, whether it gathers by rays (tracedBackSides), and per patch, whether it is a bright
  // emitter (the traced vertices take those, and only those, from the walk).
  std::vector<bool> traced, bright;
  std::vector<double> farScale;                     // closure of the far share alone (kFarClosure)
  std::vector<Vec3> normal;                         // receiving normal per vertex
  size_t rays = 0;      // the walk's cluster rays
  size_t nearRays = 0;  // the (vertex, patch) pairs' rays
  // Per receiver task, the pairs the first walk called hidden without the rays their factor asks
  // for (WalkSetup::deferredHidden); refineByLight takes them up, by their light.
  std::vector<std::vector<std::pair<uint32_t, uint32_t>>> deferredHidden;
  // Per unknown, the patches pressed against it (pressedPatches), taken before the walks.
  std::vector<std::vector<uint32_t>> pressed;
  double worstError = 0;  // the largest Σ of link error estimates over one vertex's links
  size_t bytes() const {
    return near.size() * sizeof(near[0]) + nearEntries * sizeof(near[0][0]) + links.size() * sizeof(links[0]) +
           linkCount * sizeof(ClusterLink) +
           (source.nodes.size() + groups.tree.nodes.size()) * sizeof(TreeNode) +
           (source.order.size() + groups.tree.order.size() + groups.leafOf.size() + groups.parent.size()) * sizeof(uint32_t) +
           (nodeError.size() + rowScale.size() + farScale.size()) * sizeof(double) +
           normal.size() * sizeof(Vec3) + shapeAreas.size() * sizeof(shapeAreas[0]);
  }
};

// Closure (docs/radiosity.md): an enclosed unknown's hemisphere is covered by the scene, so its row
// sums to exactly 1; no row can sum to more. The kernels and crease limits are exact; what is not
// is the visible fraction of a partly hidden source, estimated from rays (and the near field of a
// saddle vertex). Scaling an enclosed row to 1, and any row above 1 down to 1, removes that
// estimate's net gain or loss (a furnace holds to rounding) without moving light between sources.
// An enclosed row below 0.9 is left alone: that is not estimation error but a receiver in contact
// with another surface (a box's bottom on a floor) or a scene the closedness test misjudged.
struct Closure {
  std::vector<bool> patches;            // per patch: enclosed (findEnclosures)
  std::vector<bool> rows;               // per unknown: enclosed
  std::vector<bool> dark;               // per unknown: in a room with no emitter and no light inside
  std::vector<bool> darkPatches;        // per patch: the same (the inside of a closed object)
  std::atomic<double> largest{0};       // largest |Σ − 1| corrected
  // Light never crosses a closed surface: an enclosed receiver gathers only from enclosed
  // patches, any other only from the rest. Exact, and it keeps a ray that slips through a closed
  // surface at a shared corner (a saddle of a torus, seen by estimated visibility) from bringing in
  // the light of its outside.
  bool separates(size_t row, size_t patch) const { return rows[row] != patches[patch]; }
  // Whether a row gathering `sum` in all is scaled to 1 (the rules above); records the correction.
  bool scales(size_t row, double sum) {
    if (!(sum > (rows[row] ? 0.9 : 1.0)) || sum == 1) return false;
    const double change = std::abs(sum - 1);
    double seen = largest.load();
    while (change > seen && !largest.compare_exchange_weak(seen, change)) {
    }
    return true;
  }
};

// The enclosed patches, and the enclosed unknowns: patches (constant) or their vertices (bilinear).
// A room with no emitting patch and no point or spot light inside is dark: everything in it is
// exactly black (the inside of a closed double-sided object), so its rows are left empty.
std::shared_ptr<Closure> makeClosure(const Scene& scene, const PatchMesh& mesh, Method method) {
  auto closure = std::make_shared<Closure>();
  const Enclosures rooms = findEnclosures(mesh);
  std::vector<bool> lit(rooms.walls.size(), false);
  for (size_t p = 0; p < mesh.patches.size(); ++p) {
    const Vec3& e = mesh.patches[p].emission;
    if (rooms.of[p] >= 0 && (e.x > 0 || e.y > 0 || e.z > 0)) lit[rooms.of[p]] = true;
  }
  for (size_t r = 0; r < rooms.walls.size(); ++r)
    for (const PunctualLight& light : scene.lights)
      if (!lit[r] && light.type != PunctualLight::Type::kDirectional && rooms.contains(mesh, int(r), light.position))
        lit[r] = true;
  const size_t n = method == Method::kConstant ? mesh.patches.size() : mesh.positions.size();
  closure->patches.resize(mesh.patches.size());
  closure->darkPatches.assign(mesh.patches.size(), false);
  closure->rows.assign(n, false);
  closure->dark.assign(n, method == Method::kBilinear);
  for (size_t p = 0; p < mesh.patches.size(); ++p) {
    const int room = rooms.of[p];
    closure->patches[p] = room >= 0;
    const bool dark = room >= 0 && !lit[room];
    closure->darkPatches[p] = dark;
    if (method == Method::kConstant) {
      closure->rows[p] = room >= 0;
      closure->dark[p] = dark;
      continue;
    }
    for (uint32_t v : mesh.patches[p].v) {  // a vertex is dark only if all its patches are
      closure->rows[v] = closure->rows[v] || room >= 0;
      closure->dark[v] = closure->dark[v] && dark;
    }
  }
  return closure;
}

void applyClosure(Transport& t, std::shared_ptr<Closure> closure) {
  t.build = [inner = t.build, closure](size_t i, Row& row) {
    if (closure->dark[i]) return;  // black, whatever it would gather
    inner(i, row);
    double sum = 0;
    for (const auto& entry : row) sum += entry.second;
    if (closure->scales(i, sum))
      for (auto& entry : row) entry.second /= sum;
  };
}

constexpr size_t kBytesPerEntry = sizeof(uint32_t) + sizeof(double);

// Builds the rows in parallel and keeps them if their estimated size (from a sample of rows)
// fits the budget.
void storeIfItFits(Transport& t, const RadiosityOptions& options, double progressFrom, size_t& entries) {
  const size_t sampleStep = std::max<size_t>(1, t.rows / 64);
  size_t sampled = 0, sampleRows = 0;
  Row row;
  for (size_t i = 0; i < t.rows; i += sampleStep, ++sampleRows) {
    row.clear();
    t.build(i, row);
    sampled += row.size();
  }
  const double estimate = sampleRows ? double(sampled) / sampleRows * t.rows : 0;
  if (estimate * kBytesPerEntry > double(options.matrixMemoryBytes)) {
    entries = size_t(estimate);
    return;
  }
  std::vector<Row> rows(t.rows);
  Ticker ticker(options.progress, t.rows, progressFrom, 0.8);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, t.rows, 16), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t i = range.begin(); i != range.end(); ++i) {
      t.build(i, rows[i]);
      rows[i].shrink_to_fit();
    }
    ticker.add(range.size());
  });
  t.start.assign(1, 0);
  for (Row& r : rows) {
    for (const auto& [c, v] : r) {
      t.column.push_back(c);
      t.value.push_back(v);
    }
    t.start.push_back(t.column.size());
    Row().swap(r);
  }
  entries = t.value.size();
}

std::array<Vec3, 4> corners(const PatchMesh& mesh, const Patch& patch) {
  return {mesh.positions[patch.v[0]], mesh.positions[patch.v[1]], mesh.positions[patch.v[2]], mesh.positions[patch.v[3]]};
}

Vec3 pointOnPatch(const std::array<Vec3, 4>& q, double s, double t) {
  const auto n = shapeFunctions(s, t);
  return q[0] * n[0] + q[1] * n[1] + q[2] * n[2] + q[3] * n[3];
}

// What a receiving vertex needs besides its position and normal.
//  * approach: the direction into its own surface from which a crease vertex takes its limit: the
//    mean direction to the centroids of the patches around it (the corner bisector for a patch
//    corner, the inward perpendicular on an edge). Not projected onto the tangent plane: on a
//    curved surface the facets around a vertex rise or fall away from it, and the limit must be
//    taken inside them (inside the closed faceted surface), or the closure Σ_j K_ij = 1 loses the
//    near field (docs/radiosity.md).
//  * origin: where its visibility rays start. Just off the vertex, into its face and into the
//    free side of every surface meeting at that point (freeDirection over the planes of all
//    patches of this side at this position, an unwelded crease included), plus the approach. The
//    face normal alone would leave a narrow apex (a cone's tip) through the opposite facets.
//  * ignore: the patches around it and their double-sided twins, which never block its rays.
//  * twins: the twins of its own patches, which it never sees (a side does not light its twin).
struct Receivers {
  // point: where the receiver is (a vertex; for the constant method a patch's area centroid).
  std::vector<Vec3> point, normal, approach, origin;  // normal: the receiving orientation (see receivers())
  std::vector<size_t> start;     // CSR over vertices
  std::vector<uint32_t> ignore;  // own patches first, then their twins
  std::vector<uint32_t> ownCount;
  // Whether every patch meeting at the point (this side's, own or not, welded or not) lies in one
  // plane: no crease, saddle or curvature there, so its near kernels are exact but for visibility.
  std::vector<uint8_t> flat;
  size_t moved = 0;  // receivers moved off a covered vertex (relocateCovered)
  std::span<const uint32_t> ignored(size_t v) const { return {ignore.data() + start[v], start[v + 1] - start[v]}; }
  std::span<const uint32_t> own(size_t v) const { return {ignore.data() + start[v], ownCount[v]}; }
  // Whether `patch` is the twin of one of v's own patches.
  bool isOwnTwin(size_t v, uint32_t patch) const {
    const auto all = ignored(v);
    return std::find(all.begin() + ownCount[v], all.end(), patch) != all.end();
  }
};

std::span<const uint32_t> ReceiverSites::ignored(const Receivers& recv, uint32_t v) const {
  const Patches& s = patches[first[v]];
  return s.list.empty() ? recv.ignored(v) : std::span<const uint32_t>(s.list);
}
std::span<const uint32_t> ReceiverSites::own(const Receivers& recv, uint32_t v) const {
  const Patches& s = patches[first[v]];
  return s.list.empty() ? recv.own(v) : std::span<const uint32_t>(s.list.data(), s.own);
}

bool usesCorner(const Patch& p, int k) { return k < 3 || p.v[3] != p.v[2]; }

// A direction into the free side of every plane in `normals` (dot ≥ a margin with each), where
// there is one: the sum of the normals, corrected perceptron-style toward any plane it still
// points behind (a narrow wedge between planes of unequal count, the tip of a cone). Returns false
// where the planes meet as a saddle and no such direction exists.
bool freeDirection(const std::vector<Vec3>& normals, Vec3& d) {
  Vec3 sum{};
  for (const Vec3& m : normals) sum += m;
  if (!(length(sum) > 1e-9)) return false;
  d = normalize(sum);
  for (int step = 0; step < 64; ++step) {
    const Vec3* worst = nullptr;
    double lowest = 0.05;  // a margin, so the offset point is not within rounding of a plane
    for (const Vec3& m : normals)
      if (dot(m, d) < lowest) lowest = dot(m, d), worst = &m;
    if (!worst) return true;
    d = normalize(d + *worst * (0.1 - lowest));
  }
  return false;
}

// Whether nothing of the scene lies in front of the plane through p with normal n: the whole
// bounding box behind it or in it (the outside of a room's walls, the back of a double-sided
// surface on the scene's edge). Such a receiver's row is empty, and costs no pass over the
// patches.
bool facesNothing(const Bounds& scene, const Vec3& p, const Vec3& n, double epsilon) {
  for (int c = 0; c < 8; ++c) {
    const Vec3 corner{c & 1 ? scene.hi.x : scene.lo.x, c & 2 ? scene.hi.y : scene.lo.y, c & 4 ? scene.hi.z : scene.lo.z};
    if (dot(n, corner - p) > epsilon) return false;
  }
  return true;
}

Bounds sceneBounds(const PatchMesh& mesh) {
  Bounds b;
  for (const Vec3& p : mesh.positions) b.add(p);
  return b;
}

Receivers receivers(const PatchMesh& mesh, double offset) {
  const size_t n = mesh.positions.size();
  Receivers r;
  r.point = mesh.positions;
  std::vector<std::vector<uint32_t>> own(n);
  std::vector<Vec3> toCentroids(n);
  for (size_t i = 0; i < mesh.patches.size(); ++i) {
    const Patch& patch = mesh.patches[i];
    const auto q = corners(mesh, patch);
    const Vec3 centroid = pointOnPatch(q, 0, 0);
    for (int k = 0; k < 4; ++k) {
      if (!usesCorner(patch, k)) continue;
      own[patch.v[k]].push_back(uint32_t(i));
      toCentroids[patch.v[k]] += normalize(centroid - mesh.positions[patch.v[k]]);
    }
  }
  // The planes of all patches meeting at each position, per side (front and back twins apart).
  // Keyed by the exact position: coincident vertices of an unwelded crease come from the same
  // numbers.
  struct Key {
    Vec3 p;
    bool back;
    bool operator<(const Key& o) const {
      return std::tie(p.x, p.y, p.z, back) < std::tie(o.p.x, o.p.y, o.p.z, o.back);
    }
  };
  std::map<Key, std::vector<Vec3>> planes;
  std::vector<bool> back(n, false);
  for (size_t v = 0; v < n; ++v)
    for (uint32_t i : own[v]) {
      back[v] = mesh.patches[i].backSide;
      std::vector<Vec3>& normals = planes[{mesh.positions[v], back[v]}];
      const Vec3 m = mesh.patches[i].normal;
      if (std::none_of(normals.begin(), normals.end(), [&](const Vec3& o) { return dot(o, m) > 1 - 1e-9; }))
        normals.push_back(m);
    }
  r.normal.resize(n);
  r.approach.resize(n);
  r.origin.resize(n);
  r.start.assign(1, 0);
  r.ownCount.resize(n);
  r.flat.resize(n);
  for (size_t v = 0; v < n; ++v) {
    r.approach[v] = normalize(toCentroids[v]);
    // The planes meeting here, less the exact opposites of the vertex's own (a coincident surface
    // of the other orientation, such as a shell modelled around a lamp box, is not in the way);
    // where they allow no common free side, the vertex's own planes; else its normal.
    std::vector<Vec3> ownPlanes, meeting;
    for (uint32_t i : own[v]) ownPlanes.push_back(mesh.patches[i].normal);
    // The receiving normal is the geometry's: the mean of the vertex's own patch normals, inside
    // the cone they span. The file's shading normal can lie outside it (interpolated along a
    // subdivided edge, or tilted toward the rim on a smooth-shaded flat cap), and a hemisphere
    // tilted that way reaches behind the facets: into a convex object under the sky (which then
    // shades itself), or below a flat face. Inside a closed surface any normal gives the exact
    // total (docs/radiosity.md), so this costs nothing there.
    Vec3 facets{};
    for (const Vec3& m : ownPlanes) facets += m;
    r.normal[v] = length(facets) > 1e-9 ? normalize(facets) : mesh.normals[v];
    for (const Vec3& m : planes[{mesh.positions[v], back[v]}])
      if (std::none_of(ownPlanes.begin(), ownPlanes.end(), [&](const Vec3& o) { return dot(o, m) < -1 + 1e-9; }))
        meeting.push_back(m);
    Vec3 m = r.normal[v];
    if (!freeDirection(meeting, m) && !freeDirection(ownPlanes, m)) m = r.normal[v];
    // Into the face as well, unless that would put the origin behind one of its own facets (a
    // convex smooth vertex, whose facets fall away from the approach): the own facets are tested
    // exactly (Sight), from their front.
    Vec3 dir = m + r.approach[v];
    for (uint32_t i : own[v])
      if (dot(mesh.patches[i].normal, dir) < 0.05 * length(dir)) dir = m;
    r.origin[v] = mesh.positions[v] + dir * offset;
    r.ownCount[v] = uint32_t(own[v].size());
    r.flat[v] = planes[{mesh.positions[v], back[v]}].size() <= 1;
    r.ignore.insert(r.ignore.end(), own[v].begin(), own[v].end());
    for (uint32_t i : own[v])
      if (mesh.patches[i].twin >= 0) r.ignore.push_back(uint32_t(mesh.patches[i].twin));
    r.start.push_back(r.ignore.size());
  }
  return r;
}

// Whether corner c of a polygon rises clear of the horizon of a receiver at p (normal nrm): above it
// by more than `epsilon` and further from p than the rays' lift (10 `epsilon`). Corners above the
// horizon only within the lift make a sliver the rays never see (kernelReaches, snapToTouching).
bool risesClear(const Vec3& p, const Vec3& nrm, const Vec3& c, double epsilon) {
  return dot(nrm, c - p) > epsilon && length(c - p) > 10 * epsilon;
}

// Surfaces that touch within rounding (a floor vertex a float ulp beside the foot of a wall standing
// on it, as Blender's single-precision coordinates leave them): a vertex closer than the rays'
// `offset` to a patch not its own gathers from the nearest point on that patch instead, where the
// kernels take their exact contact limits. A millionth of the scene away, they were taken as a regular
// kernel a hair off the singular line and as rays that start past the wall: a floor vertex
// 1.2e-7 beside a box's wall gathered 10% too little of it, one 1e-6 inside the box the whole sky.
void snapToTouching(const PatchMesh& mesh, const Occlusion& occlusion, Receivers& r, double offset) {
  tbb::parallel_for(tbb::blocked_range<size_t>(0, r.point.size(), 256), [&](const tbb::blocked_range<size_t>& range) {
    std::vector<uint32_t> near;
    for (size_t v = range.begin(); v != range.end(); ++v) {
      if (r.ownCount[v] == 0) continue;
      near.clear();
      occlusion.patchesNear(r.point[v], offset, near);
      const auto ignored = r.ignored(v);
      const auto own = r.own(v);
      double best = offset;
      Vec3 target, across{};
      double bestOther = offset;  // the same, onto patches not in one of the vertex's own planes
      Vec3 targetOther;
      bool onContact = false;  // on a surface whose plane its own patches straddle
      bool risesThere = false;  // and a patch of it touching the vertex rises clear of its horizon
      std::vector<Vec3> centres;                       // of the vertex's own patches, from it
      std::vector<std::pair<Vec3, bool>> straddled;  // planes met so far: whether its patches lie on both sides
      for (uint32_t c : near) {
        if (std::find(ignored.begin(), ignored.end(), c) != ignored.end()) continue;
        const Patch& patch = mesh.patches[c];
        const auto q = corners(mesh, patch);
        const QuadPoint np = nearestQuadPoint(q, r.point[v]);
        if (!(np.distance <= offset)) continue;
        // A surface standing on the vertex's own (a wall on a floor) with the vertex's patches on
        // both sides of its plane: its front, along the floor. (A wall's foot vertex lies on the
        // floor and on a box's bottom too, but its patches are all on one side of theirs.)
        if (!patch.backSide) {
          // Judged once per plane: a face cut into many pieces touches a vertex with many.
          const auto known = std::find_if(straddled.begin(), straddled.end(), [&](const auto& s) { return dot(s.first, patch.normal) > 1 - 1e-12; });
          bool straddles = false;
          if (known != straddled.end()) {
            straddles = known->second;
          } else {
            if (centres.empty())
              for (uint32_t i : own) centres.push_back(pointOnPatch(corners(mesh, mesh.patches[i]), 0, 0) - mesh.positions[v]);
            bool before = false, behind = false;
            for (const Vec3& c : centres) {
              before |= dot(c, patch.normal) > offset;
              behind |= dot(c, patch.normal) < -offset;
            }
            straddles = before && behind;
            straddled.push_back({patch.normal, straddles});
          }
          if (straddles) across += patch.normal - r.normal[v] * dot(r.normal[v], patch.normal);
          if (straddles && np.distance == 0) {
            onContact = true;
            for (const Vec3& c : q) risesThere |= risesClear(r.point[v], r.normal[v], c, occlusion.epsilon());
          }
        }
        if (np.distance > 0 && np.distance <= best) {
          best = np.distance;
          target = pointOnPatch(q, np.s, np.t);
        }
        const bool ownPlane = std::any_of(own.begin(), own.end(), [&](uint32_t i) { return dot(mesh.patches[i].normal, patch.normal) > 1 - 1e-9; });
        if (!ownPlane && np.distance > 0 && np.distance <= bestOther) {
          bestOther = np.distance;
          targetOther = pointOnPatch(q, np.s, np.t);
        }
      }
      // A vertex on the line where its face runs into another surface is not moved onto a patch in
      // one of its own planes (its own surface beside a crack or a contact cut's T-junction): that
      // changes nothing of what it sees but can take it off the surface it lies on. A
      // 2CylinderEngine vertex moved 7.8e-5 along its face so, 5e-8 behind a plate it was on, and
      // took none of it: 0.95 of sky where independent rays see at most 0.45 (bench/skycheck).
      // Elsewhere such moves stay: forbidden everywhere, 38 vertices of another engine part came
      // out further from those rays, by up to 0.51 (docs/results.md, "Thirtieth session").
      // Nor is it moved at all where a patch of that surface touching it rises clear above its
      // horizon (a plate's piece whose edge is the vertex's foot): the move, onto the next piece
      // of the plate 2.7e-5 beside, left that piece edge-on to the vertex, which took none of
      // the plate: a shaft's vertex where it enters the plate saw a sky of 0.99 where independent
      // rays see at most 0.48 (thirty-first session). Not moved on contact at all, another
      // part's vertex came out 0.42 too bright; never onto the contact surface's plane, two 0.50
      // and 0.65 (docs/results.md).
      if (onContact) {
        best = risesThere ? offset : bestOther;  // offset: no move (its approach is still set below)
        target = targetOther;
      }
      // A vertex whose patches lie on both sides of the foot (a floor cell straddling it, or a floor
      // cut along it, whose vertices there may coincide with the wall's) takes the crease limit from
      // the side in front of the wall, perpendicular to the foot in its own tangent plane: the mean
      // direction to its patches' centres points along the foot (no light from the wall) or,
      // beside a cut's thin covered sliver, obliquely (the foot's values scattered by 8% with the
      // wall's cells), or, where a curved surface runs through a plate (a CAD assembly's bore
      // through a wall), into the buried side, which saw the plate from behind: its vertices
      // along the cut saw 0.92 of sky where the side in front of the plate sees about 0.42 (the
      // 2CylinderEngine; bench/skycheck). Until the thirtieth session only a vertex whose own
      // patches lie in one plane took this approach.
      if (length(across) > 1e-3 && dot(across, r.approach[v]) < (1 - 1e-9) * length(across)) {
        const Vec3 approach = normalize(across);
        r.origin[v] += (approach - r.approach[v]) * offset;
        r.approach[v] = approach;
      }
      if (best == offset) continue;
      r.origin[v] += target - r.point[v];
      r.point[v] = target;
    }
  });
}

// Two unit tangents completing n to a right-handed frame (t, b, n), for fixed direction sets
// around a normal (covered, nearOpenness).
std::pair<Vec3, Vec3> tangentFrame(const Vec3& n) {
  const Vec3 helper = std::abs(n.x) < 0.6 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  const Vec3 t = normalize(cross(n, helper));
  return {t, cross(n, t)};
}

// Direction k of S × S fixed cosine-distributed directions around n (t, b: its tangent frame):
// stratified in (r², φ) on the unit disc, projected up (Malley's method).
template <int S>
Vec3 malleyDirection(int k, const Vec3& t, const Vec3& b, const Vec3& n) {
  const double u = (k / S + 0.5) / S, phi = 2 * kPi * ((k % S) + 0.5 * (k / S % 2) + 0.25) / S;
  const double r = std::sqrt(u), h = std::sqrt(std::max(0.0, 1 - u));
  return t * (r * std::cos(phi)) + b * (r * std::sin(phi)) + n * h;
}

// The parameters (s, t) in [-1, 1]² of pointOnPatch at a point in the plane of a planar patch: the
// bilinear map inverted in closed form in the patch's plane (nearestQuadPoint's search was the
// gather's largest cost).
std::pair<double, double> patchParameters(const std::array<Vec3, 4>& q, const Vec3& normal, const Vec3& p) {
  // Project on the coordinate plane the normal is most nearly perpendicular to.
  const double ax = std::abs(normal.x), ay = std::abs(normal.y), az = std::abs(normal.z);
  auto flat = [&](const Vec3& v) -> std::array<double, 2> {
    if (ax >= ay && ax >= az) return {v.y, v.z};
    if (ay >= az) return {v.z, v.x};
    return {v.x, v.y};
  };
  const auto a = flat(q[0]), b = flat(q[1]), c = flat(q[2]), d = flat(q[3]), x = flat(p);
  const std::array<double, 2> e{b[0] - a[0], b[1] - a[1]}, f{d[0] - a[0], d[1] - a[1]},
      g{a[0] - b[0] + c[0] - d[0], a[1] - b[1] + c[1] - d[1]}, h{x[0] - a[0], x[1] - a[1]};
  auto cross2 = [](const std::array<double, 2>& u, const std::array<double, 2>& v) { return u[0] * v[1] - u[1] * v[0]; };
  const double k2 = cross2(g, f), k1 = cross2(e, f) + cross2(h, g), k0 = cross2(h, e);
  auto uOf = [&](double v) {  // from whichever coordinate divides better
    const double dx = e[0] + g[0] * v, dy = e[1] + g[1] * v;
    return std::abs(dx) >= std::abs(dy) ? (h[0] - f[0] * v) / dx : (h[1] - f[1] * v) / dy;
  };
  double u = 0, v = 0;
  if (std::abs(k2) <= 1e-12 * std::abs(k1)) {  // a parallelogram (or nearly): linear in v
    v = -k0 / k1;
    u = uOf(v);
  } else {
    const double w = std::sqrt(std::max(0.0, k1 * k1 - 4 * k0 * k2));
    v = (-k1 - w) / (2 * k2);
    u = uOf(v);
    if (!(u >= -1e-9 && u <= 1 + 1e-9 && v >= -1e-9 && v <= 1 + 1e-9)) {
      v = (-k1 + w) / (2 * k2);
      u = uOf(v);
    }
  }
  if (!std::isfinite(u) || !std::isfinite(v)) {
    const QuadPoint at = nearestQuadPoint(q, p);
    return {at.s, at.t};
  }
  return {2 * std::clamp(u, 0.0, 1.0) - 1, 2 * std::clamp(v, 0.0, 1.0) - 1};
}

// Both sides of a double-sided surface are patches in one place: a ray along d that meets patch
// `hit` sees the one facing its origin (hit's twin where hit faces away); the back of a one-sided
// patch, nothing (-1).
int64_t facingSide(const PatchMesh& mesh, int64_t hit, const Vec3& d) {
  return dot(mesh.patches[hit].normal, d) < 0 ? hit : mesh.patches[hit].twin;
}

// The shape functions of planar patch p where the ray from `from` along d meets its plane.
std::array<double, 4> shapeFunctionsAlong(const PatchMesh& mesh, const Patch& p, const Vec3& from, const Vec3& d) {
  const double along = dot(p.normal, mesh.positions[p.v[0]] - from) / dot(p.normal, d);
  const auto [s, t] = patchParameters(corners(mesh, p), p.normal, from + d * along);
  return shapeFunctions(s, t);
}

// Whether a point of a flat surface is covered: every one of 8 rays into its hemisphere, up to
// the scene's size, first meets the back of a one-sided patch or the inside of a closed dark
// object (a double-sided box: the side it meets is the twin facing the ray) — the floor under a
// block standing on it, one-sided as in the Cornell box or double-sided as Blender exports a cube.
bool covered(const PatchMesh& mesh, const Occlusion& occlusion, const Closure& closure, const Vec3& from, const Vec3& n,
             std::span<const uint32_t> ignore) {
  const auto [t, b] = tangentFrame(n);
  for (int k = 0; k < 8; ++k) {
    const double phi = 2 * kPi * (k + 0.5) / 8, lift = k % 2 ? 0.5 : 0.87;  // two rings
    const Vec3 dir = n * lift + (t * std::cos(phi) + b * std::sin(phi)) * std::sqrt(1 - lift * lift);
    const int64_t hit = occlusion.firstHit(from, from + dir * (2 * occlusion.sceneSize()), ignore);
    if (hit < 0) return false;
    const int64_t seen = facingSide(mesh, hit, dir);
    if (seen < 0) continue;  // the back of a one-sided surface: inside
    if (!closure.darkPatches[size_t(seen)]) return false;
  }
  return true;
}

// Contact (docs/radiosity.md): a vertex of a flat surface that another object stands on, under
// that object (a floor vertex inside a block's footprint), would gather nothing, and its zero would
// darken the visible part of every patch around it, up to a patch width from the contact (the
// floor at N = 16 was 32% too dark within 2 cm of the Cornell box's blocks), and through the crease
// limit the feet of the blocks' own faces. Its receiver moves to the nearest uncovered point of
// its patches (points from its corner toward each of their other corners and centres), which
// carries on the light of the visible part across the footprint's edge. Unchanged where no such
// point is found (deep under the object: nothing sees those patches).
void relocateCovered(const PatchMesh& mesh, const Occlusion& occlusion, const Closure& closure, Receivers& r, double offset) {
  const size_t n = mesh.positions.size();
  std::vector<uint8_t> moved(n, 0);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 64), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t v = range.begin(); v != range.end(); ++v) {
      if (!r.flat[v] || r.ownCount[v] == 0 || closure.dark[v]) continue;  // dark: black whatever it would gather
      if (!covered(mesh, occlusion, closure, r.origin[v], r.normal[v], r.ignored(v))) continue;
      double best = std::numeric_limits<double>::infinity();
      Vec3 target;
      for (uint32_t i : r.own(v)) {
        const Patch& patch = mesh.patches[i];
        const Vec3 centre = pointOnPatch(corners(mesh, patch), 0, 0);
        for (int k = 0; k < 4; ++k) {
          if (!usesCorner(patch, k)) continue;
          for (const Vec3& toward : {mesh.positions[patch.v[k]], centre}) {
            for (int step = 1; step <= 8; ++step) {
              const Vec3 x = mesh.positions[v] + (toward - mesh.positions[v]) * (step / 8.0);
              const double d = length(x - mesh.positions[v]);
              if (!(d > 0) || d >= best) break;
              if (!covered(mesh, occlusion, closure, x + r.normal[v] * offset, r.normal[v], r.ignored(v))) {
                best = d;
                target = x;
                break;
              }
            }
          }
        }
      }
      if (best == std::numeric_limits<double>::infinity()) continue;
      r.point[v] = target;
      r.origin[v] = target + r.normal[v] * offset;
      moved[v] = 1;
    }
  });
  r.moved = size_t(std::count(moved.begin(), moved.end(), 1));
}

// The constant method's receivers: one per patch, at its area centroid (where a linear field takes
// its mean over the patch: the far field's value for the patch), facing its normal; rays start
// just off its bilinear centre, as the exact transport's do (constantPairFactor), and step over
// the patch and its twin.
Receivers patchReceivers(const PatchMesh& mesh, double offset) {
  const size_t n = mesh.patches.size();
  Receivers r;
  r.point.resize(n);
  r.normal.resize(n);
  r.approach.resize(n);
  r.origin.resize(n);
  r.ownCount.assign(n, 1);
  r.flat.assign(n, 1);  // a planar patch, and its near factors are patch to patch
  r.start.assign(1, 0);
  for (size_t k = 0; k < n; ++k) {
    const Patch& patch = mesh.patches[k];
    const auto q = corners(mesh, patch);
    // Two triangles (the second empty for a triangle patch), each at its own centroid.
    const double a0 = length(cross(q[1] - q[0], q[2] - q[0])), a1 = length(cross(q[2] - q[0], q[3] - q[0]));
    r.point[k] = a0 + a1 > 0 ? ((q[0] + q[1] + q[2]) * a0 + (q[0] + q[2] + q[3]) * a1) / (3 * (a0 + a1)) : q[0];
    r.normal[k] = r.approach[k] = patch.normal;
    r.origin[k] = pointOnPatch(q, 0, 0) + patch.normal * offset;
    r.ignore.push_back(uint32_t(k));
    if (patch.twin >= 0) r.ignore.push_back(uint32_t(patch.twin));
    r.start.push_back(r.ignore.size());
  }
  return r;
}

// The receiver tree's items, one per unknown: a vertex (a point with its receiving normal) or a
// patch (its corners and area, so that a group's radius covers what its patches average over).
std::vector<TreeItem> receiverItems(const PatchMesh& mesh, const Receivers& recv, const Closure& closure, Method method) {
  std::vector<TreeItem> items(recv.point.size());
  for (size_t v = 0; v < items.size(); ++v) {
    const bool enclosed = closure.rows[v];
    if (method == Method::kBilinear) items[v] = {{recv.point[v]}, 1, recv.normal[v], 1.0, enclosed, {}};
    else items[v] = {corners(mesh, mesh.patches[v]), 4, recv.normal[v], mesh.patches[v].area, enclosed, recv.point[v]};
  }
  return items;
}

// The answers of one sight's rays, by their end: the receivers of a site (receiverSites) ask the
// same rays of the same patch one after the other in a walk, from one origin.
struct RayMemo {
  uint32_t site = UINT32_MAX, patch = UINT32_MAX;
  std::vector<std::pair<Vec3, bool>> answers;
  size_t found = 0;  // rays answered from here, not traced
  const bool* find(const Vec3& to) {
    for (const auto& [end, seen] : answers)
      if (end == to) {
        ++found;
        return &seen;
      }
    return nullptr;
  }
};

// What a receiving point sees. Embree answers for every patch but the receiver's own and their
// twins (`ignore`): a ray leaving a vertex grazes those, and in single precision it would hit them
// by rounding. The own patches are instead tested here in double precision against the segment,
// so a ray that really passes behind one of them (a grazing direction at a curved vertex, out
// through the facet beside it) is still blocked.
struct Sight {
  const Occlusion& occlusion;
  const PatchMesh& mesh;
  Vec3 from;
  std::span<const uint32_t> ignore;  // skipped by Embree
  std::span<const uint32_t> own;     // tested exactly (empty for a patch's own centre)
  RayMemo* memo = nullptr;           // answers already traced from here, and where to keep new ones

  bool visible(const Vec3& to) const {
    if (const bool* seen = memo ? memo->find(to) : nullptr) return *seen;
    const bool seen = !crossesOwn(to) && occlusion.visible(from, to, ignore);
    if (memo) memo->answers.emplace_back(to, seen);
    return seen;
  }
  // visible(to[k]) for every k, the rays not yet answered traced together, 16 at a time.
  void visibleAll(std::span<const Vec3> to, bool* seen) const {
    if (!memo) {
      occlusion.visibleFrom(from, to, ignore, seen);
      for (size_t k = 0; k < to.size(); ++k) seen[k] = seen[k] && !crossesOwn(to[k]);
      return;
    }
    for (size_t first = 0; first < to.size(); first += 16) {
      std::array<Vec3, 16> ask;
      std::array<size_t, 16> at;
      size_t asked = 0;
      for (size_t k = first; k < std::min(to.size(), first + 16); ++k) {
        if (const bool* known = memo->find(to[k])) {
          seen[k] = *known;
          continue;
        }
        ask[asked] = to[k];
        at[asked++] = k;
      }
      if (asked == 0) continue;
      std::array<bool, 16> got;
      occlusion.visibleFrom(from, std::span(ask.data(), asked), ignore, got.data());
      for (size_t e = 0; e < asked; ++e) {
        seen[at[e]] = got[e] && !crossesOwn(ask[e]);
        memo->answers.emplace_back(ask[e], seen[at[e]]);
      }
    }
  }

  bool crossesOwn(const Vec3& to) const {
    for (uint32_t k : own) {
      const Patch& patch = mesh.patches[k];
      const Vec3& q0 = mesh.positions[patch.v[0]];  // the plane first: most rays do not cross it
      const double da = dot(patch.normal, from - q0), db = dot(patch.normal, to - q0);
      if (!((da > 0 && db < 0) || (da < 0 && db > 0))) continue;
      const auto q = corners(mesh, patch);
      const Vec3 x = from + (to - from) * (da / (da - db));
      bool inside = true;
      for (int e = 0; e < 4 && inside; ++e)
        inside = dot(cross(q[(e + 1) % 4] - q[e], x - q[e]), patch.normal) >= 0;
      if (inside) return true;
    }
    return false;
  }
};

// A site's rays (receiverSites), for a walk's (vertex, patch) pair: their origin, the patches they
// test exactly, and the answers the site's last receiver got from this patch.
struct SharedSight {
  Vec3 from;
  std::span<const uint32_t> own;
  RayMemo* memo;
};

// A square piece of a source patch in its parameters: centre (s, t), half-width `half`; the whole
// patch is {0, 0, 1}.
struct Piece {
  double s = 0, t = 0, half = 1;
  Vec3 at(const std::array<Vec3, 4>& q, double a, double b) const { return pointOnPatch(q, s + half * a, t + half * b); }
};

constexpr double kGaussNode[4] = {-0.8611363115940526, -0.3399810435848563, 0.3399810435848563, 0.8611363115940526};
constexpr double kGaussPair = 0.5773502691896257;  // the 2×2 Gauss nodes, ±1/√3
constexpr double kGaussWeight[4] = {0.3478548451374538, 0.6521451548625461, 0.6521451548625461, 0.3478548451374538};

// The point kernel cos θ_n cos θ_m / r² over r² (the bilinear kernel's integrand less its shape
// function, and less 1/π): from a receiver of normal n to a surface point of normal m at offset d,
// zero where either faces away.
double pointKernel(const Vec3& n, const Vec3& m, const Vec3& d) {
  const double r2 = dot(d, d);
  return std::max(0.0, dot(n, d)) * std::max(0.0, -dot(m, d)) / (r2 * r2);
}

// The shape functions' unoccluded kernel from a receiving point over a piece, by a 4×4 Gauss grid
// (no Jacobian: only its ratios are used, the visible fractions of a piece), at grid point (a, b)
// where the point kernel is `kernel`.
std::array<double, 4> gridWeight(double kernel, const Piece& piece, int a, int b) {
  const auto nj = shapeFunctions(piece.s + piece.half * kGaussNode[a], piece.t + piece.half * kGaussNode[b]);
  std::array<double, 4> w;
  for (int j = 0; j < 4; ++j) w[j] = kGaussWeight[a] * kGaussWeight[b] * nj[j] * (kernel > 0 ? kernel : 1e-300);
  return w;
}

// A piece's five probe targets: its centre and four inner points. A whole patch's are kProbe's (at
// ±½); a piece's inner probes sit at ±1/√3 instead, off the dyadic points where the pieces' own
// edges (and, in scenes of round sizes, shadow edges) fall: a black plate's shadow edge through all
// five probes of a ceiling's pieces put a floor vertex 2.3% off.
std::array<Vec3, 5> probeTargets(const Sight& sight, const std::array<Vec3, 4>& q, const Vec3& qNormal, const Piece& piece) {
  const double lift = sight.occlusion.epsilon() * 10, inner = piece.half == 1 ? 1 : 2 * kGaussPair;
  std::array<Vec3, 5> probes;
  for (int k = 0; k < 5; ++k) probes[k] = piece.at(q, kProbe[k][0] * inner, kProbe[k][1] * inner) + qNormal * lift;
  return probes;
}

// A piece's visible fraction per shape function, from how many of its five probes got through: all
// or none, the piece is seen or hidden whole; otherwise a 4×4 Gauss grid on the piece, each ray
// weighted by the shape function and the unoccluded kernel there, gives the visible fraction of
// each K_j.
std::array<double, 4> probedFraction(const Sight& sight, const Vec3& n, const std::array<Vec3, 4>& q, const Vec3& qNormal,
                                     const Piece& piece, int seen, size_t& rays) {
  if (seen == 5) return {1, 1, 1, 1};
  if (seen == 0) return {0, 0, 0, 0};
  const double lift = sight.occlusion.epsilon() * 10;
  std::array<Vec3, 16> grid;     // the rays' ends, lifted off the piece
  std::array<double, 16> kernel;  // the point kernel there
  bool sends = false;
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < 4; ++b) {
      const Vec3 at = piece.at(q, kGaussNode[a], kGaussNode[b]);
      kernel[4 * a + b] = pointKernel(n, qNormal, at - sight.from);
      sends = sends || kernel[4 * a + b] > 0;
      grid[4 * a + b] = at + qNormal * lift;
    }
  // No grid point in front of the receiver (a sliver of a piece straddling its horizon, between the
  // grid's points): one ray to the sliver, halfway from the corner highest above the horizon to
  // where the line to the piece's centre crosses it, judges it whole. (The grid's points below
  // the horizon, all weighing alike, decided it before, as the probes there did.)
  if (!sends) {
    const Vec3 centre = piece.at(q, 0, 0);
    const std::array<Vec3, 4> corner{piece.at(q, -1, -1), piece.at(q, 1, -1), piece.at(q, 1, 1), piece.at(q, -1, 1)};
    const Vec3* top = &corner[0];
    for (const Vec3& c : corner)
      if (dot(n, c - sight.from) > dot(n, *top - sight.from)) top = &c;
    const double hTop = dot(n, *top - sight.from), hCentre = dot(n, centre - sight.from);
    if (hTop > 0 && hCentre < 0) {
      ++rays;
      const double v = sight.visible(*top + (centre - *top) * (0.5 * hTop / (hTop - hCentre)) + qNormal * lift) ? 1 : 0;
      return {v, v, v, v};
    }
  }
  bool gridSeen[16];
  sight.visibleAll(grid, gridSeen);
  rays += 16;
  std::array<double, 4> all{}, visible{};
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < 4; ++b) {
      const auto w = gridWeight(kernel[4 * a + b], piece, a, b);
      for (int j = 0; j < 4; ++j) {
        all[j] += w[j];
        if (gridSeen[4 * a + b]) visible[j] += w[j];
      }
    }
  std::array<double, 4> out{};
  for (int j = 0; j < 4; ++j) out[j] = all[j] > 0 ? visible[j] / all[j] : double(seen) / 5;
  return out;
}

// How many of a piece's five probes count as through, for probedFraction. A probe below the
// receiver's horizon says nothing of the part that sends light (the kernel and the grid's weights
// take only what lies above it): where one is below, the piece is not judged whole by its probes
// but by the grid. Counting them put a 2CylinderEngine piston vertex 5.3% of the mean off: a patch
// straddling its horizon, mostly below it, had every probe get through while the sliver above sits
// behind two front patches, and its back was taken for cover twice.
int probesThrough(const Vec3& from, const Vec3& n, std::span<const Vec3> probes, const bool* seen) {
  const int through = int(std::count(seen, seen + probes.size(), true));
  const bool straddles = std::any_of(probes.begin(), probes.end(), [&](const Vec3& p) { return !(dot(n, p - from) > 0); });
  return straddles ? std::clamp(through, 1, int(probes.size()) - 1) : through;  // neither all nor none: to the grid
}

// Visibility between a receiver point and a whole patch, as a fraction per shape function: five
// probes, then the grid where they disagree.
std::array<double, 4> patchFraction(const Sight& sight, const Vec3& n, const std::array<Vec3, 4>& q, const Vec3& qNormal,
                                    size_t& rays) {
  const auto probes = probeTargets(sight, q, qNormal, Piece{});
  bool seen[5];
  sight.visibleAll(probes, seen);
  rays += 5;
  return probedFraction(sight, n, q, qNormal, Piece{}, probesThrough(sight.from, n, probes, seen), rays);
}

// A source patch covering more of a receiver's hemisphere than this (its unoccluded factor) is
// split in four for its visibility, and so are its pieces, down to this size: a piece is judged
// by its probes (probedFraction), and a wrong verdict (five probes agreeing where a shadow clips
// the piece) costs at most its factor. Where four sibling pieces' verdicts differ (seen, hidden,
// partly), a shadow's edge runs through them and they are split again, down to kBoundaryShare of
// it. Whole walls of a Blender room (one patch of 4–6 m each at the default tessellation) were
// judged by 21 rays from a Suzanne crease: an independent ray count gave the walls 0.87 of such a
// vertex's hemisphere, the kernels 0.77, the floor 0 (its five probes blocked while its front part
// is in view). On the level-0 Blender room against pieces of 0.001 (emitters' weighted): the bake was
// 19.6% of the mean radiance off (RMS; 78% at worst), and with these values 0.27% (2.5%), at 3×
// the (vertex, patch) pairs' rays; uniform pieces of 0.005 without the sibling rule needed 75M rays
// for 0.45% (2.0%), and 0.02 without it was 1.9% (12%).
constexpr double kVisibilityPiece = 0.02;
constexpr double kBoundaryShare = 0.1;
constexpr int kVisibilityDepth = 8;

// Whether nothing can stand in the convex hull of `points`: every patch near them (but those in
// `skip`) lies wholly outside, by a margin, one plane that has all of them on its other side: a
// face of their hull (found by trying every plane through three of them) or one of `planes`
// (normal m, offset o: outside where m · x > o). A patch no plane separates says no, whether or
// not it meets the hull, and the rays decide.
bool hullClear(const Occlusion& occlusion, const PatchMesh& mesh, std::span<const Vec3> points,
               std::span<const std::pair<Vec3, double>> planes, std::span<const uint32_t> skip) {
  const double eps = occlusion.epsilon();
  std::array<std::pair<Vec3, double>, 64> faces;  // up to 8 points: 56 triples, and `planes`
  if (points.size() > 8 || planes.size() > faces.size() - 56) return false;  // not asked: the rays decide
  size_t count = 0;
  for (const auto& plane : planes) faces[count++] = plane;
  const size_t n = points.size();
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 1; j < n; ++j)
      for (size_t k = j + 1; k < n; ++k) {
        Vec3 m = cross(points[j] - points[i], points[k] - points[i]);
        const double len = length(m);
        if (!(len > eps * eps)) continue;  // three points in a line
        m = m / len;
        const double o = dot(m, points[i]);
        double lo = 0, hi = 0;
        for (const Vec3& x : points) lo = std::min(lo, dot(m, x) - o), hi = std::max(hi, dot(m, x) - o);
        if (hi <= eps) faces[count++] = {m, o};
        else if (lo >= -eps) faces[count++] = {-m, -o};
      }
  Bounds box;
  for (const Vec3& x : points) box.add(x);
  return !occlusion.anyNear((box.lo + box.hi) / 2, box.diagonal() / 2 + eps, [&](uint32_t patch) {
    if (std::find(skip.begin(), skip.end(), patch) != skip.end()) return false;
    const auto c = corners(mesh, mesh.patches[patch]);
    for (size_t f = 0; f < count; ++f) {
      const auto& [m, o] = faces[f];
      if (dot(m, c[0]) > o + eps && dot(m, c[1]) > o + eps && dot(m, c[2]) > o + eps && dot(m, c[3]) > o + eps) return false;
    }
    return true;
  });
}

// A pair that would be judged in at least this many pieces first asks whether anything can stand
// between its ends at all (shaftClear): one query of the patches near them instead of the pieces'
// rays. In the issue's Blender room the ceiling above the lamp, which sees the lamp's emitting back
// 2 cm away in pieces a hundred times finer for its emission, took 174M of its 367M pair rays.
constexpr double kShaftPieces = 16;

// Whether nothing can stand between the receiving point and the quad q lifted toward it (as the
// probes are): the hull of the point and the lifted corners (a bilinear quad lies in its corners'
// hull), and the receiver's horizon plane, clear (hullClear). The receiver's own patches are not
// exempt (at a curved vertex they can rise into the hull). Where the answer is yes, every ray the
// pieces would trace gets through, so the fraction is the same without them.
bool shaftClear(const Sight& sight, const Vec3& n, const std::array<Vec3, 4>& q, const Vec3& qNormal) {
  const double lift = sight.occlusion.epsilon() * 10;
  const std::array<Vec3, 5> points{sight.from, q[0] + qNormal * lift, q[1] + qNormal * lift, q[2] + qNormal * lift,
                                   q[3] + qNormal * lift};
  const std::pair<Vec3, double> horizon{-n, dot(-n, sight.from)};
  return hullClear(sight.occlusion, sight.mesh, points, std::span(&horizon, 1), {});
}

// Visibility between a receiver point and a source patch, as a fraction per shape function: the
// whole patch's patchFraction, or where the patch covers more than `largestPiece` of the
// hemisphere, its pieces' fractions weighted by their exact unoccluded factors (split among the
// shape functions by their mean over the piece).
std::array<double, 4> visibleFraction(const Sight& sight, const Vec3& n, const std::array<Vec3, 4>& q,
                                      const Vec3& qNormal, double largestPiece, size_t& rays) {
  const Piece whole;
  const double wholeFactor = pointPolygonFactor(sight.from, n, q.data(), 4);
  if (!(wholeFactor > largestPiece)) return patchFraction(sight, n, q, qNormal, rays);
  if (wholeFactor > largestPiece * kShaftPieces && shaftClear(sight, n, q, qNormal)) return {1, 1, 1, 1};
  std::array<double, 4> all{}, visible{};
  // Pieces to split, with their depth, depth first: at most 3 waiting per level below the one being
  // split, so kVisibilityDepth levels fit in a fixed array (no allocation per pair).
  std::array<std::pair<Piece, int>, 4 * kVisibilityDepth> stack;
  size_t waiting = 0;
  stack[waiting++] = {whole, 0};
  while (waiting > 0) {
    const auto [parent, parentDepth] = stack[--waiting];
    const int depth = parentDepth + 1;
    const double h = parent.half / 2;
    std::array<Piece, 4> child;
    std::array<double, 4> factor{};
    std::array<std::array<double, 4>, 4> verdict{};  // of the children judged here (slot[k] >= 0)
    // The children small enough to judge have their probes traced together (20 rays in three
    // packets of 8 instead of four of 5).
    std::array<Vec3, 20> probes;
    std::array<int, 4> slot{};  // where child k's probes start in `probes`, -1: not judged here
    int probed = 0;
    for (int k = 0; k < 4; ++k) {
      slot[k] = -1;
      child[k] = {parent.s + (k == 1 || k == 2 ? h : -h), parent.t + (k >= 2 ? h : -h), h};
      const std::array<Vec3, 4> corners{child[k].at(q, -1, -1), child[k].at(q, 1, -1), child[k].at(q, 1, 1),
                                        child[k].at(q, -1, 1)};
      factor[k] = pointPolygonFactor(sight.from, n, corners.data(), 4);
      if (!(factor[k] > 0)) continue;  // below the horizon, or behind
      if (factor[k] > largestPiece && depth < kVisibilityDepth) {
        stack[waiting++] = {child[k], depth};
        continue;
      }
      const auto targets = probeTargets(sight, q, qNormal, child[k]);
      std::copy(targets.begin(), targets.end(), probes.begin() + probed);
      slot[k] = probed;
      probed += 5;
    }
    bool seen[20];
    sight.visibleAll(std::span(probes.data(), size_t(probed)), seen);
    rays += size_t(probed);
    int kinds = 0;  // bit 0: a piece seen whole, 1: hidden whole, 2: partly
    for (int k = 0; k < 4; ++k) {
      if (slot[k] < 0) continue;
      const int through = probesThrough(sight.from, n, std::span(probes.data() + slot[k], 5), seen + slot[k]);
      verdict[k] = probedFraction(sight, n, q, qNormal, child[k], through, rays);
      kinds |= verdict[k] == std::array<double, 4>{1, 1, 1, 1} ? 1 : verdict[k] == std::array<double, 4>{} ? 2 : 4;
    }
    const bool differ = kinds != 0 && kinds != 1 && kinds != 2;
    for (int k = 0; k < 4; ++k) {
      if (slot[k] < 0) continue;
      if (differ && factor[k] > largestPiece * kBoundaryShare && depth < kVisibilityDepth) {
        stack[waiting++] = {child[k], depth};
        continue;
      }
      // The shape functions' mean over the piece (kernel-weighted means gave the same errors).
      const auto weight = shapeFunctions(child[k].s, child[k].t);
      for (int j = 0; j < 4; ++j) {
        all[j] += factor[k] * weight[j];
        visible[j] += factor[k] * weight[j] * verdict[k][j];
      }
    }
  }
  const double total = all[0] + all[1] + all[2] + all[3];
  std::array<double, 4> out{};
  for (int j = 0; j < 4; ++j)
    out[j] = all[j] > 0 ? visible[j] / all[j] : total > 0 ? (visible[0] + visible[1] + visible[2] + visible[3]) / total : 0;
  return out;
}

// How finely a pair's visibility is resolved (pairVisibility): a patch whose factor is below `faint`
// gets one ray, one above `piece` is split (visibleFraction). Both are divided by the patch's
// emission weight (emissionWeight; the sky cover, which is geometry, takes none).
struct PairSight {
  double faint = 0;
  double piece = kVisibilityPiece;
};

// The area-weighted mean emitted radiance of the scene (luminance), and a patch's brightness
// weight against it: max(1, its emission / the mean). Known before any solve, so both transports
// can resolve the visibility of emitters, which carry most of the light, that much more finely (a
// ceiling panel's pieces judged by five probes each at the unweighted share put Blender room
// vertices 15% of the mean radiance off their converged value).
double luminance(const Vec3& c) { return (c.x + c.y + c.z) / 3; }
double meanEmission(const PatchMesh& mesh) {
  double emitted = 0, area = 0;
  for (const Patch& p : mesh.patches) {
    emitted += luminance(p.emission) * p.area;
    area += p.area;
  }
  return area > 0 ? emitted / area : 0;
}
double emissionWeight(const Patch& patch, double meanEmission) {
  return meanEmission > 0 ? std::max(1.0, luminance(patch.emission) / meanEmission) : 1;
}

// visibleFraction, or for a faint patch (a bound on its factor from `from`, below `faint`, and d,
// the distance to its bounding sphere, at least twice its radius) one ray to its centre: all or
// nothing. A faint pair decided wrong costs at most its factor; the five probes and the
// 4×4 grid were most of the hierarchical transport's rays (in the level-0 Blender room, 3.9M of the
// 8.1M (vertex, patch) pairs are hidden, 5 rays each, against 8.0M cluster rays). Counts its rays.
std::array<double, 4> pairVisibility(const Sight& sight, const Vec3& n, const std::array<Vec3, 4>& q, const Vec3& qNormal,
                                     double area, const PairSight& resolve, size_t& rays) {
  const Vec3 c = pointOnPatch(q, 0, 0);
  double r2 = 0;
  for (const Vec3& x : q) r2 = std::max(r2, dot(x - c, x - c));
  const double r = std::sqrt(r2), d = length(c - sight.from) - r;
  // The pair's factor with both cosines is at most A (h_n / d) (h_m / d) / (π d²): h_n the highest
  // corner over the receiver's plane, h_m the receiver's height over the patch's plane (both linear
  // over the patch, so largest at a corner). A/(π d²) alone (until the fourteenth session) gave
  // the patches along a curved vertex's horizon line, and those seen edge-on, 5 to hundreds of
  // rays for light they barely send: issue 16's room, default bake, 205M -> 170M pair rays.
  if (resolve.faint > 0 && d >= 2 * r) {
    double hn = 0, hm = 0;
    for (const Vec3& x : q) {
      hn = std::max(hn, dot(n, x - sight.from));
      hm = std::max(hm, std::abs(dot(qNormal, sight.from - x)));
    }
    if (area * std::min(1.0, hn / d) * std::min(1.0, hm / d) < resolve.faint * kPi * d * d) {
      ++rays;
      const double seen = sight.visible(c + qNormal * (sight.occlusion.epsilon() * 10)) ? 1 : 0;
      return {seen, seen, seen, seen};
    }
  }
  // Below the piece size for certain (the factor is at most A/(π d²)): judged whole, without
  // visibleFraction's closed-form factor (most pairs of a finely tessellated scene).
  if (d > 0 && area <= resolve.piece * kPi * d * d) return patchFraction(sight, n, q, qNormal, rays);
  return visibleFraction(sight, n, q, qNormal, resolve.piece, rays);
}

// Antiparallel to this: a face pressed on another (their normals opposite to rounding).
constexpr double kPressedCos = -(1 - 1e-6);

// Whether a vertex at p (receiving normal nrm) takes anything from the quad q (normal m) in K: some
// corner above its horizon, and p not behind q's plane by more than `epsilon` (a vertex of a curved
// surface off its own non-planar patch's plane, whose limit would be ill-conditioned). The sky
// pass's cover takes the same rejections (skyCover).
// A corner above the horizon by no more than `epsilon`, the rest of the polygon further below, is
// either a face hanging down from an edge the vertex lies on (a part's side below another's top
// face) lifted by rounding, or a face pressed on one of the vertex's own (antiparallel to it, in
// its plane) that a smooth receiving normal tilts partly under the horizon. The kernel, which takes
// anything within `epsilon` of the vertex as touching it, gave the hanging face's wedge its whole
// crease limit (a 2CylinderEngine vertex took 0.80 of its hemisphere from three piston faces
// hanging below it, in both transports): it sends nothing. The pressed face keeps its in-plane
// limit (a sealed contact: dark). A polygon within `epsilon` of the plane throughout keeps the
// rounding's verdict.
// The same holds where the corners above the horizon lie within the rays' lift (10 `epsilon`) of
// the vertex, the rest further below (thirtieth session): the part above is a sliver smaller than
// the offset the vertex's rays start from, where a CAD part's face meets another's with a corner
// 4e-4 off (13 float steps at 360). Its whole in-plane or crease limit at the vertex made
// 2CylinderEngine vertices take 0.52–0.63 of their hemisphere from faces that, a lift away,
// cover nothing (independent rays: a sky of 1.0 where the bake had 0.32–0.45; bench/skycheck).
bool kernelReaches(const Vec3& p, const Vec3& nrm, const std::array<Vec3, 4>& q, const Vec3& m, double epsilon,
                   const PatchMesh& mesh, std::span<const uint32_t> own) {
  if (dot(m, p - q[0]) < -epsilon) return false;
  bool above = false, clear = false, below = false;
  for (const Vec3& c : q) {
    const double h = dot(nrm, c - p);
    above |= h > 0;
    clear |= risesClear(p, nrm, c, epsilon);
    below |= h < -epsilon;
  }
  if (clear || (above && !below)) return true;
  if (!above) return false;
  return std::any_of(own.begin(), own.end(), [&](uint32_t k) { return dot(mesh.patches[k].normal, m) < kPressedCos; });
}

// K_ij of one source patch for vertex i (the exact kernel times its visible fraction), appended to
// `row`. `ignore` is i's ignore list with one free slot at its end for the source. A pair fainter
// than `resolve.faint` gets one visibility ray (pairVisibility; 0: the exact transport's probes always).
// Returns the rays it traced.
size_t addPatchKernel(const PatchMesh& mesh, const Occlusion& occlusion, const Receivers& recv, const KernelOptions& kernelOptions,
                      size_t i, size_t source, std::vector<uint32_t>& ignore, Row& row, const PairSight& resolve,
                      const SharedSight* shared = nullptr) {
  const Vec3 p = recv.point[i], nrm = recv.normal[i], a = recv.approach[i];
  const Patch& patch = mesh.patches[source];
  if (recv.isOwnTwin(i, uint32_t(source))) return 0;  // a side never sees its own twin
  const auto q = corners(mesh, patch);
  if (!kernelReaches(p, nrm, q, patch.normal, occlusion.epsilon(), mesh, recv.own(i))) return 0;
  // Visibility before the kernel: a hidden pair costs its probe rays and no kernel (in a room
  // of self-occluding Suzannes, 39.5M of 48.7M kernels were computed for hidden pairs).
  // A crease contribution sits at the receiver itself: nothing can come between.
  const bool touching = nearestQuadPoint(q, p).distance <= occlusion.epsilon();
  ignore.back() = uint32_t(source);
  const Sight sight = shared ? Sight{occlusion, mesh, shared->from, ignore, shared->own, shared->memo}
                             : Sight{occlusion, mesh, recv.origin[i], ignore, recv.own(i)};
  size_t rays = 0;
  const size_t found = shared ? shared->memo->found : 0;
  const auto vis = touching ? std::array<double, 4>{1, 1, 1, 1} : pairVisibility(sight, nrm, q, patch.normal, patch.area, resolve, rays);
  if (shared) rays -= shared->memo->found - found;  // count the rays traced
  if (vis[0] == 0 && vis[1] == 0 && vis[2] == 0 && vis[3] == 0) return rays;
  const auto k = vertexQuadKernel(p, nrm, a, q, kernelOptions);
  for (int j = 0; j < 4; ++j) {
    // A triangle's collapsed corner (v3 == v2) adds its shape function to v2.
    if (k[j] * vis[j] != 0) row.emplace_back(patch.v[j], k[j] * vis[j]);
  }
  return rays;
}

// A source node's vector moment of L per color channel, beside its centroid: the far gather reads
// both for every link, from one place (they were two scattered reads, the centroid's in a TreeNode).
struct NodeMoment {
  Vec3 centroid;
  std::array<Vec3, 3> m;
};

// The source clusters' vector moments of L, M_node[c] = Σ_patches n_p Σ_j A_pj L_j[c] (c: the
// color channel), bottom-up in a fixed order so the sums have the same bits for any thread count.
std::vector<NodeMoment> clusterMoments(const Hierarchical& h, const PatchMesh& mesh, const std::vector<Vec3>& L) {
  const ClusterTree& tree = h.source;
  std::vector<NodeMoment> moment(tree.nodes.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, tree.nodes.size(), 1024), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t k = range.begin(); k != range.end(); ++k) {
      const TreeNode& node = tree.nodes[k];
      moment[k].centroid = node.centroid;
      if (node.count != 1) continue;
      const uint32_t p = tree.order[node.first];
      const Patch& patch = mesh.patches[p];
      Vec3 s{};
      if (h.perPatch) s = L[p] * patch.area;
      else for (int j = 0; j < 4; ++j) s += L[patch.v[j]] * h.shapeAreas[p][j];
      moment[k].m = {patch.normal * s.x, patch.normal * s.y, patch.normal * s.z};
    }
  });
  for (size_t k = tree.nodes.size(); k-- > 0;) {  // children come after their parent
    const TreeNode& node = tree.nodes[k];
    if (node.count == 1) continue;
    for (int c = 0; c < 3; ++c) moment[k].m[c] = moment[node.child[0]].m[c] + moment[node.child[1]].m[c];
  }
  return moment;
}

// Φ at a group's centroid and its gradient J = ∂Φ/∂p, per color channel.
struct LocalField {
  std::array<Vec3, 3> phi{};
  std::array<std::array<double, 9>, 3> jacobian{};  // row-major
};

// What each vertex gathers through the links, n_i · Φ(p_i) per channel: each group's field from its
// links (in parallel), then pushed down the receiver tree (parent before child), re-centred on
// each child's centroid: Φ_child += Φ_G + J_G (c_child − c_G), J_child += J_G.
std::vector<Vec3> gatherFar(const Hierarchical& h, const std::vector<NodeMoment>& moment) {
  const ClusterTree& R = h.groups.tree;
  std::vector<LocalField> field(R.nodes.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, R.nodes.size(), 256), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t k = range.begin(); k != range.end(); ++k) {
      const bool leaf = R.nodes[k].count == 1;  // a leaf's J is never pushed anywhere
      const Vec3 at = R.nodes[k].centroid;
      for (const ClusterLink& link : h.links[k]) {
        const NodeMoment& source = moment[link.source];
        const Vec3 w = source.centroid - at;
        const double d2 = dot(w, w), s = link.visible / (kPi * d2 * d2);
        // ∂Φ/∂p = (1/π) [(w·M) (I − 4 w wᵀ / |w|²) + w Mᵀ] / |w|⁴ = a I + w uᵀ, with a = s (w·M)
        // and u = s M − (4 a / |w|²) w: a diagonal and one outer product per channel.
        for (int c = 0; c < 3; ++c) {
          const Vec3& m = source.m[c];
          const double a = s * dot(w, m);
          field[k].phi[c] += w * -a;
          if (leaf) continue;
          const Vec3 u = m * s - w * (4 * a / d2);
          auto& J = field[k].jacobian[c];
          J[0] += w.x * u.x + a, J[1] += w.x * u.y, J[2] += w.x * u.z;
          J[3] += w.y * u.x, J[4] += w.y * u.y + a, J[5] += w.y * u.z;
          J[6] += w.z * u.x, J[7] += w.z * u.y, J[8] += w.z * u.z + a;
        }
      }
    }
  });
  for (size_t k = 0; k < R.nodes.size(); ++k) {
    const TreeNode& node = R.nodes[k];
    if (node.count == 1) continue;
    for (int child : node.child) {
      const Vec3 delta = R.nodes[child].centroid - node.centroid;
      for (int c = 0; c < 3; ++c) {
        const auto& J = field[k].jacobian[c];
        field[child].phi[c] += field[k].phi[c] + Vec3{J[0] * delta.x + J[1] * delta.y + J[2] * delta.z,
                                                      J[3] * delta.x + J[4] * delta.y + J[5] * delta.z,
                                                      J[6] * delta.x + J[7] * delta.y + J[8] * delta.z};
        for (int a = 0; a < 9; ++a) field[child].jacobian[c][a] += J[a];
      }
    }
  }
  std::vector<Vec3> far(h.groups.leafOf.size());
  for (size_t v = 0; v < far.size(); ++v) {
    if (h.groups.leafOf[v] == kNoLeaf) continue;
    const auto& phi = field[h.groups.leafOf[v]].phi;  // a leaf's centroid is its vertex
    far[v] = {dot(h.normal[v], phi[0]), dot(h.normal[v], phi[1]), dot(h.normal[v], phi[2])};
  }
  return far;
}

// Rays per receiver and cluster link, to patch centres spread over the cluster. All through: the
// link is made; none: the cluster is hidden from the group; some: a group is opened.
constexpr uint32_t kClusterRays = 4;
// Under a sky the hierarchical transport links at this share of --accuracy: its rows' errors are
// its sky's (skyFromRows), which weigh by the sky's radiance, brighter than the surfaces'. Against
// exact (--sky 1, --refine off; WalkSetup::rowsCoverSky): the 2CylinderEngine part 0.072% RMS and
// 1.02% largest at the full accuracy, 0.035% and 0.47% at half; a 13.8k-triangle part 0.135% and
// 1.13%, 0.112% and 1.09%, for 3% and 11% more time. (The separate sky pass before it linked at a
// quarter: there a cover link's error had the same sign at every vertex.)
constexpr double kSkyAccuracy = 0.5;
// The sky pass asks each vertex this many² fixed rays whether it sees the back of a patch (backSeeing).
constexpr int kBackGrid = 16;
// A pair whose link rays are all blocked is dropped as hidden only after up to this many rays per
// receiver, one for every kHiddenFactorPerRay of its factor: a hidden verdict that is wrong loses
// light, about the factor over the rays, and with a ray or two per receiver such verdicts made the
// hierarchical transport gather 1.2% less red than the exact one all over the Cornell box at N = 8
// (0.6% green; from the light's penumbrae, 8.7% RMS on the floor with the direct light alone).
// With these (and link rays spread over the patches, linkTarget): 0.27% less, 1.1 s for 1.0 s.
constexpr uint32_t kHiddenRays = 8;
constexpr double kHiddenFactorPerRay = 1e-4;
// Those extra rays go from at most this many sites' worth of the group in all, spread over its
// sites: every site's link rays were blocked already. Asked of every site, they were two fifths of
// the whole 2CylinderEngine's cluster rays (3.2G of 8.0G: a cluster hidden from a group of 17-64
// sites behind the parts of an assembly took 136 to 512 more). With these, 6.2G and 11% less time,
// the errors against exact unchanged on five scenes: docs/results.md, "Twenty-eighth session".
constexpr uint32_t kHiddenSites = 4;
// A link gets one visibility ray per receiver for every this much of its factor (up to
// kClusterRays): measured on the Cornell box at N = 20, it halves the rays of 4 per receiver for
// 0.2% RMS and 2.6% largest error, against 0.17% and 1.9%.
constexpr double kFactorPerRay = 1e-3;
// In the refinement by light, whose factors carry their source's brightness, a link's rays in all
// grow the same way up to this many, spread over its receivers. A link of one or two receivers to a
// bright cluster was decided on 4 rays: in the lamp room, floor vertices took ceiling clusters
// around the lamp whole (weighted factors of 0.01-0.03) that they see 17-59% of.
constexpr uint32_t kLinkRays = 32;
// A cluster dipping under a flat group's plane is linked when its horizon error is below this
// share of --accuracy.
constexpr double kHorizonShare = 0.1;
// A partly hidden cluster whose factor (about A/(π d²)) is below this share of --accuracy is linked
// to each vertex with the share of its factor that kFractionRays rays see (visibleShare), instead
// of being opened further. The share is sampled without bias, and the link's error estimate counts
// its noise as the factor over the rays.
// (Fixed at 1e-4 of the hemisphere until the twenty-second session, when pairs along shadow edges
// were opened down to single patches: with visibleShare and kLinkRays, Cornell box at N = 20
// 4.17 -> 3.32 s, 0.035% -> 0.044% RMS and 0.33% -> 0.63% largest against exact; issue 16's
// Blender room 88.8 -> 80.5 s; at ten times --accuracy, no faster. docs/results.md.)
constexpr double kFaintShare = 3;
// A partly hidden cluster fainter than this share of --accuracy whose probes are all blocked is
// hidden on them alone (a wrong verdict loses its whole factor: it stays at 1e-4 by default).
constexpr double kFaintHiddenShare = 0.1;
constexpr uint32_t kFractionRays = 8;
// The near (vertex, patch) kernels are integrated to this share of --accuracy (relative), and a
// pair whose factor is below this share of it gets one visibility ray (pairVisibility).
constexpr double kNearKernelShare = 0.1;
constexpr double kFaintPairShare = 0.1;
// No link spans less than twice the two groups' radii, whatever its error estimate says.
constexpr double kMaxRatio = 0.5;
// Groups of up to this many receivers are tested against a cluster receiver by receiver.
constexpr uint32_t kExactHorizons = 16;
// A pair of at most this many (vertex, patch) pairs may be proved hidden whole before it is opened
// (measured on the level-0 Blender room: 6–16% less time; larger pairs added rays and saved none).
constexpr uint64_t kHiddenProofPairs = 64;
// A task keeps trying them after kProofTrial while at least one in kProofYield succeeds.
constexpr size_t kProofTrial = 64, kProofYield = 8;
// Cluster rays are traced this many at a time: one of Occlusion::visibleEach's packets, so that a
// pair stops at the first packet that shows it mixed (32 at a time traced 2.9% more rays on the
// Cornell box at N = 20 and in issue 16's Blender room, for the same links and bytes out).
constexpr uint32_t kRayBatch = 8;
// Receiver subtrees of at most this many vertices are walked as one parallel task.
constexpr uint32_t kTaskVertices = 256;
// Closure corrects the far share alone of a row whose receiver is flat (Receivers::flat), when that
// takes at most this factor either way. There the error is the links' (their centroid expansions
// and few visibility rays), while the near entries are kernels integrated to a tenth of --accuracy
// with the exact transport's visibility. Scaling the whole row moved the error onto the near light:
// in the unit room with a lamp 2 cm under its ceiling (bench/hierarchical/lamp.sh) the ceiling above
// the lamp sees the walls through the slit between them, its links over-count them, and the
// whole-row scaling took the lamp's exact near light down with them (at 20×20, with the refinement
// by light: 0.41% RMS and 4.9% largest error against 0.047% and 0.60%, of the mean radiance). Not
// where surfaces meet at an angle: at a saddle or curved vertex the near field is taken without its
// own occlusion and errs itself (the Blender rooms' Suzannes, smooth or flat-shaded, went up to 24%
// off exact when their far share alone was scaled).
constexpr double kFarClosure = 2;

// Whether receiver v gathers anything: not in a dark room, and something of the scene in front of it
// (the outside of a room's walls faces nothing). The others stay out of the receiver tree.
std::vector<bool> gatheringReceivers(const PatchMesh& mesh, const Receivers& recv, const Closure& closure, double epsilon) {
  const Bounds bounds = sceneBounds(mesh);
  std::vector<bool> gathers(recv.point.size());
  for (size_t v = 0; v < gathers.size(); ++v)
    gathers[v] = !closure.dark[v] && !facesNothing(bounds, recv.point[v], recv.normal[v], epsilon);
  return gathers;
}

// Per receiver, its site: the first receiver at the same point on the same side, whose normal falls
// in the same bin of the receiver tree (normalBin), their rays' origins on one side of every other
// patch there (a flat-shaded crease has one vertex per face at a point). The constant method's
// receivers are patches: each its own.
ReceiverSites receiverSites(const PatchMesh& mesh, const Occlusion& occlusion, const Receivers& recv, Method method) {
  std::vector<uint32_t> site(recv.point.size());
  std::map<std::tuple<double, double, double, bool, int>, std::vector<uint32_t>> firsts;
  // Whether the two receivers' origins lie on different sides of a patch at the point that is
  // neither's own, or in its plane: where a floor is cut along the foot of a block standing on it,
  // the covered piece's vertex starts its rays in the block's wall (the Cornell box's floor beside
  // the tall block lost up to 9.9% of its light through it when shared).
  std::vector<uint32_t> near;
  auto apart = [&](uint32_t a, uint32_t b) {
    const Vec3 &oa = recv.origin[a], &ob = recv.origin[b];
    const double reach = length(oa - recv.point[a]) + length(ob - recv.point[b]), margin = 1e-3 * reach;
    near.clear();
    occlusion.patchesNear(recv.point[a], reach, near);
    const auto ownA = recv.own(a), ownB = recv.own(b);
    for (uint32_t p : near) {
      if (std::find(ownA.begin(), ownA.end(), p) != ownA.end() || std::find(ownB.begin(), ownB.end(), p) != ownB.end()) continue;
      const Patch& patch = mesh.patches[p];
      const Vec3& q0 = mesh.positions[patch.v[0]];
      const double da = dot(patch.normal, oa - q0), db = dot(patch.normal, ob - q0);
      if (!((da > margin && db > margin) || (da < -margin && db < -margin))) return true;
    }
    return false;
  };
  for (uint32_t v = 0; v < site.size(); ++v) {
    site[v] = v;
    const auto own = recv.own(v);
    if (method == Method::kConstant || own.empty()) continue;
    const Vec3& p = recv.point[v];
    std::vector<uint32_t>& sites = firsts[{p.x, p.y, p.z, mesh.patches[own[0]].backSide, normalBin(recv.normal[v])}];
    for (uint32_t first : sites)
      if (!apart(first, v)) {
        site[v] = first;
        break;
      }
    if (site[v] == v) sites.push_back(v);
  }
  ReceiverSites out;
  out.patches.resize(site.size());
  for (uint32_t v = 0; v < site.size(); ++v) {
    if (site[v] == v) continue;
    std::vector<uint32_t>& list = out.patches[site[v]].list;
    if (list.empty()) {
      const auto own = recv.own(site[v]);
      list.assign(own.begin(), own.end());
    }
    const auto own = recv.own(v);
    list.insert(list.end(), own.begin(), own.end());
  }
  for (ReceiverSites::Patches& s : out.patches) {
    if (s.list.empty()) continue;
    std::sort(s.list.begin(), s.list.end());
    s.list.erase(std::unique(s.list.begin(), s.list.end()), s.list.end());
    s.own = uint32_t(s.list.size());
    for (uint32_t k = 0; k < s.own; ++k)
      if (mesh.patches[s.list[k]].twin >= 0) s.list.push_back(uint32_t(mesh.patches[s.list[k]].twin));
  }
  out.first = std::move(site);
  return out;
}

// The receiver tree over `items` (one per unknown: a vertex, or for the constant method a patch),
// those that gather anything, and where their sites lie in it.
ReceiverGroups receiverGroups(const std::vector<TreeItem>& all, const std::vector<bool>& gathers, ReceiverSites&& sites) {
  const std::vector<uint32_t>& site = sites.first;
  ReceiverGroups groups;
  const size_t nv = all.size();
  std::vector<TreeItem> items;
  std::vector<uint32_t> vertexOf;
  for (size_t v = 0; v < nv; ++v)
    if (gathers[v]) {
      items.push_back(all[v]);
      vertexOf.push_back(uint32_t(v));
    }
  groups.tree = buildClusterTree(items);
  for (uint32_t& item : groups.tree.order) item = vertexOf[item];  // the tree's order holds vertices
  groups.leafOf.assign(nv, kNoLeaf);
  groups.parent.assign(groups.tree.nodes.size(), -1);
  for (size_t k = 0; k < groups.tree.nodes.size(); ++k) {
    const TreeNode& node = groups.tree.nodes[k];
    if (node.count == 1) groups.leafOf[groups.tree.order[node.first]] = uint32_t(k);
    for (int c : node.child)
      if (c >= 0) groups.parent[c] = int32_t(k);
  }
  const ClusterTree& tree = groups.tree;
  groups.mateBefore.assign(tree.order.size(), kNoMate);
  groups.mateAfter.assign(tree.order.size(), kNoMate);
  std::vector<uint32_t> last(nv, kNoMate);  // per site, its receiver last seen in tree order
  for (uint32_t k = 0; k < tree.order.size(); ++k) {
    uint32_t& before = last[site[tree.order[k]]];
    if (before != kNoMate) groups.mateAfter[before] = k;
    groups.mateBefore[k] = std::exchange(before, k);
  }
  groups.siteCount.resize(tree.nodes.size());
  for (size_t k = 0; k < tree.nodes.size(); ++k) {
    const TreeNode& node = tree.nodes[k];
    for (uint32_t i = node.first; i < node.first + node.count; ++i)
      groups.siteCount[k] += groups.mateBefore[i] == kNoMate || groups.mateBefore[i] < node.first;
  }
  groups.site = std::move(sites);
  for (std::vector<uint32_t> stack{0}; !stack.empty() && !groups.tree.empty();) {
    const uint32_t k = stack.back();
    stack.pop_back();
    const TreeNode& node = groups.tree.nodes[k];
    if (node.count <= kTaskVertices) groups.tasks.push_back(k);
    else for (int c = 1; c >= 0; --c) stack.push_back(uint32_t(node.child[c]));
  }
  return groups;
}

// A source tree over `patches` (indices into the mesh; its order holds positions in `patches`).
ClusterTree patchTree(const PatchMesh& mesh, const std::vector<uint32_t>& patches, const Closure& closure) {
  std::vector<TreeItem> items(patches.size());
  for (size_t k = 0; k < patches.size(); ++k) {
    const Patch& patch = mesh.patches[patches[k]];
    items[k] = {corners(mesh, patch), 4, patch.normal, patch.area, bool(closure.patches[patches[k]]), {}};
  }
  return buildClusterTree(items);
}

// What the walks keep, against RadiosityOptions::transportMemoryBytes, counted as they go. A near
// entry costs 16 bytes while its task fills its vertex's row (column and double value) and 8 once
// the task ends and packs it (the rows being filled are a task's, two tasks at a time); it is
// counted at 16, which leaves the budget a margin. A link costs its 8.
constexpr size_t kNearEntryBytes = 16;
struct MemoryBudget {
  size_t limit = SIZE_MAX;
  std::atomic<size_t> used{0};
  void add(size_t bytes) {
    if (bytes == 0 || limit == SIZE_MAX) return;
    const size_t now = used.fetch_add(bytes, std::memory_order_relaxed) + bytes;
    if (now > limit)
      throw TransportMemoryExceeded("the hierarchical transport needs more memory than its budget of " +
                                    std::to_string(limit >> 20) + " MiB");
  }
};

bool hasSky(const RadiosityOptions& options) { return options.sky.x > 0 || options.sky.y > 0 || options.sky.z > 0; }

// The walk of (receiver group, source cluster) pairs (docs/radiosity.md "Hierarchical transport"):
// for every receiver subtree of at most kTaskVertices vertices (in parallel), from (the subtree,
// the source root), or from the setup's `starts`. A pair becomes a link when the cluster is on the
// group's side of every closed surface, wholly above every receiver's horizon, facing every
// receiver with every patch, far (r/d < 0.5 and the error estimate of linkEstimate below
// `accuracy`) and seen whole by the link's rays; a hidden cluster is dropped; anything else splits
// the larger group, down to (vertex, patch), which gets the exact kernel.
// Transport: a link needs every patch facing every receiver, and light never crosses a closed
// surface. Cover (the sky pass, hierarchicalCover): every patch facing the group or every patch
// facing away (a surface covers the sky from either side), no closure; with `backsOnly`, only the
// latter. `leaf(v, patch)` handles the exact
// (vertex, patch) pairs and returns the bytes it kept (for the memory budget); `taskDone(node)`, if
// given, is called when a task's receiver subtree is walked (its vertices have all their pairs);
// `gathers(v)` says whether vertex v needs anything at all.
struct WalkSetup {
  const PatchMesh& mesh;
  const Occlusion& occlusion;
  const Receivers& recv;
  const ReceiverGroups& groups;
  const ClusterTree& source;
  const std::vector<uint32_t>& patchOf;  // source item → mesh patch
  bool cover;
  double accuracy;
  MemoryBudget& memory;
  // The light refinement's second walk (refineByLight): per source node, how much brighter its
  // light is than the scene's mean (at least 1; it scales the pair's factor in every criterion), the
  // light's running sum over the source order (every other link ray goes to a patch drawn by its
  // light), and per task the pairs to walk from (instead of its root against the source root).
  const std::vector<double>* weight = nullptr;
  const std::vector<double>* lightSum = nullptr;
  // And per source node, how much brighter its brightest patch is than the scene's mean (at least
  // 1): what a partly hidden link's share can miss (a fraction link's visible part may be its dim
  // rim, the hidden part its hot spot).
  const std::vector<double>* peak = nullptr;
  const std::vector<std::vector<std::pair<uint32_t, uint32_t>>>* starts = nullptr;
  // The transport's first walk: per task, the pairs called hidden by their link rays whose factor
  // would ask for more (kHiddenRays) are listed here instead of traced; refineByLight traces them
  // where their source's light asks for it.
  std::vector<std::vector<std::pair<uint32_t, uint32_t>>>* deferredHidden = nullptr;
  // refineByLight's walk: per task, those pairs taken up again (their link rays all blocked in the
  // first walk), walked from before `starts`: a pair that reaches the ray test goes straight to its
  // hidden verdict's rays instead of asking its link rays again.
  const std::vector<std::vector<std::pair<uint32_t, uint32_t>>>* hiddenStarts = nullptr;
  // Per vertex, whether it gathers by rays (tracedBackSides): its groups take only the patches
  // `bright` marks (per mesh patch) and nothing in the sky pass.
  const std::vector<bool>* traced = nullptr;
  const std::vector<bool>* bright = nullptr;
  // The sky pass: per vertex, whether its rays saw the back of any patch (backSeeing). A group none
  // of whose vertices did drops the clusters that show it only their backs, from its points and
  // from its rays' origins, which lie up to `originReach` away.
  const std::vector<bool>* seesBacks = nullptr;
  double originReach = 0;
  // Cover mode: only what patches seen from behind cover (the bilinear method's sky pass, whose
  // fronts are the transport's rows).
  bool backsOnly = false;
  // The transport: per receiver, the patches pressed against it (pressedPatches), which its row
  // took before the walk; the walk skips them.
  const std::vector<std::vector<uint32_t>>* pressed = nullptr;
  // The transport under a sky, whose rows are its sky's cover (skyFromRows): what they miss comes
  // back as sky, δ(S − L) of light instead of δ·L, so neither a faint pair's blocked probes nor a
  // turning cluster's negative cosines are taken for its cover. On a 13.8k-triangle part of the
  // 2CylinderEngine (`--sky 1`) they left its vertices 0.32% brighter than exact on average, 4.1%
  // at worst; without them 0.048% and 1.09%.
  bool rowsCoverSky = false;
};

// A link's factor and the error estimate of its centroid expansions (walkPairs), with the source's
// light weight folded into both.
struct LinkEstimate {
  Vec3 d;  // from the group's centroid to the cluster's
  double dist, ratio;
  double spread;  // the cluster's A/(π d²)
  double factor;  // with both cosines, |n_g · w| |w · Σ A n| / (π |w|⁴)
  double error;
};
LinkEstimate linkEstimate(const TreeNode& g, const TreeNode& c, double weight) {
  LinkEstimate e;
  e.d = c.centroid - g.centroid;
  e.dist = length(e.d);
  e.ratio = e.dist > 0 ? (g.radius + c.radius) / e.dist : 1e300;
  e.spread = weight * c.area / (kPi * e.dist * e.dist);
  e.factor = weight * std::abs(dot(g.axis, e.d)) * std::abs(dot(e.d, c.areaNormal)) / (kPi * e.dist * e.dist * e.dist * e.dist);
  // The error of the centroid expansions, second order in the ratio: the cross term of the two
  // cosines (linear in position) is bounded by the cluster's area without cosines, and the
  // curvature of 1/|w|⁴ scales the link's own factor. The second term was missing: on a 16k-patch
  // part of the 2CylinderEngine the large flat faces gathered up to 4.6% off exact (0.59% RMS)
  // from many links erring the same way; with it 2.4% (0.28%), in the same time. More link rays
  // did not help (4.5%). Cornell box N = 20: 11% more time, 0.152% RMS instead of 0.192%.
  e.error = e.ratio * e.ratio * (3 * e.spread + 6 * e.factor);
  return e;
}

// The offset in c's range of the patch whose share of `sum` (a running sum over the source order,
// of area or light) holds u in [0, 1); where c has none, u's share of its count.
uint32_t drawnBy(const std::vector<double>& sum, const TreeNode& c, double u) {
  const double lo = sum[c.first], hi = sum[c.first + c.count];
  if (!(hi > lo)) return std::min(c.count - 1, uint32_t(u * c.count));
  const auto first = sum.begin() + c.first;
  const auto it = std::upper_bound(first + 1, first + c.count + 1, lo + (hi - lo) * u);
  return uint32_t(std::min<ptrdiff_t>(c.count - 1, it - first - 1));
}

// The offset in c's range of the patch whose share of c's light holds the point (start + ½) / count:
// a draw by light, stratified over `start` and deterministic; `start` itself where c has no light.
uint32_t drawnByLight(const std::vector<double>& lightSum, const TreeNode& c, uint32_t start) {
  const double lo = lightSum[c.first], hi = lightSum[c.first + c.count];
  if (!(hi > lo)) return start;
  return drawnBy(lightSum, c, (start + 0.5) / c.count);
}

// Where link ray k ends on a source patch: spread over the patch by two irrational rotations of k
// (deterministic), not at its centre. A patch straddling a block's footprint has its centre under
// the block: centre rays called pairs of the floor around it hidden that are not.
Vec3 linkTarget(const PatchMesh& mesh, uint32_t patch, uint32_t k) {
  auto spread = [](double x) { return 2 * (x - std::floor(x)) - 1; };
  const double s = spread(0.5 + k * 0.6180339887498949), t = spread(0.5 + k * 0.7548776662466927);
  return pointOnPatch(corners(mesh, mesh.patches[patch]), 0.95 * s, 0.95 * t);
}

// Rays per receiver of a link: one for every kFactorPerRay of its factor, up to kClusterRays, and
// at least kClusterRays over the group (see walkPairs); with `cap` above kClusterRays (kLinkRays),
// the link's rays in all grow on with its factor up to `cap`, spread over the group.
uint32_t raysPerReceiver(uint32_t receivers, double factor, uint32_t cap) {
  const uint32_t asked = std::clamp<uint32_t>(uint32_t(std::ceil(std::min(1.0, factor) / kFactorPerRay)), 1, cap);
  return std::max((std::max(kClusterRays, asked) + receivers - 1) / receivers, std::min(asked, kClusterRays));
}

// Rays per receiver before a pair whose link rays are all blocked is called hidden: one for every
// kHiddenFactorPerRay of its factor, up to kHiddenRays (more than raysPerReceiver gives: the
// extra rays, which the first walk defers to refineByLight).
uint32_t hiddenRaysPerReceiver(double factor) {
  return std::min(kHiddenRays, uint32_t(std::ceil(factor / kHiddenFactorPerRay)));
}

// A pair's visibility rays, handed down to its children when it is opened: a ray from a receiver of
// the child to a patch of the child says as much about the child as about its parent. A child
// whose inherited rays already show some light through and some blocked is partly seen: it is
// opened without probes of its own (the probes of the pairs along a shadow's edge, walked down
// level by level, were asked again at every level), and a child is neither linked nor called
// hidden against its inherited rays. Receivers and patches by their positions in R.order and
// S.order, which a child's range holds.
struct Evidence {
  uint32_t receiver, source;
  bool through;
};
constexpr size_t kEvidence = 16;  // rays handed down per pair, at most
struct WalkEntry {
  uint32_t group, cluster;
  uint32_t count = 0;
  std::array<Evidence, kEvidence> rays{};
};

std::vector<std::vector<ClusterLink>> walkPairs(const WalkSetup& w, const std::function<bool(uint32_t)>& gathers,
                                                std::vector<double>& nodeError,
                                                const std::function<size_t(uint32_t, uint32_t, std::vector<uint32_t>&, const SharedSight*)>& leaf,
                                                const std::function<void(const TreeNode&)>& taskDone, Ticker& ticker,
                                                size_t& raysShot) {
  const ClusterTree &R = w.groups.tree, &S = w.source;
  std::vector<std::vector<ClusterLink>> links(R.nodes.size());
  nodeError.assign(R.nodes.size(), 0.0);  // Σ of its links' error estimates (tasks own disjoint nodes)
  if (S.empty()) return links;
  std::atomic<size_t> rays{0};
  const double lift = w.occlusion.epsilon() * 10, faintFactor = w.accuracy * kFaintShare;
  std::vector<Vec3> centre(w.patchOf.size());  // the cluster rays' targets, per source item
  for (size_t k = 0; k < centre.size(); ++k) centre[k] = pointOnPatch(corners(w.mesh, w.mesh.patches[w.patchOf[k]]), 0, 0);
  // Per source node, the area of its largest patch.
  const std::vector<double> largestPatch = bottomUp<double>(
      S, [&](size_t k) { return w.mesh.patches[w.patchOf[S.order[S.nodes[k].first]]].area; }, [](double a, double b) { return std::max(a, b); });
  std::vector<double> areaSum(S.order.size() + 1, 0.0);  // the source order's running sum of area
  for (size_t k = 0; k < S.order.size(); ++k) areaSum[k + 1] = areaSum[k] + w.mesh.patches[w.patchOf[S.order[k]]].area;
  // Per receiver node its traced vertices, per source node its bright patches (w.traced); per
  // receiver node its vertices that see backs (w.seesBacks).
  auto countIn = [](const ClusterTree& tree, auto flagged) {
    return bottomUp<uint32_t>(tree, [&](size_t k) { return flagged(tree.order[tree.nodes[k].first]); }, std::plus<uint32_t>());
  };
  std::vector<uint32_t> tracedIn, brightIn, backsIn;
  if (w.traced) {
    tracedIn = countIn(R, [&](uint32_t v) { return (*w.traced)[v]; });
    brightIn = countIn(S, [&](uint32_t item) { return w.bright && (*w.bright)[w.patchOf[item]]; });
  }
  if (w.seesBacks) backsIn = countIn(R, [&](uint32_t v) { return (*w.seesBacks)[v]; });
  tbb::parallel_for(tbb::blocked_range<size_t>(0, w.groups.tasks.size(), 1), [&](const tbb::blocked_range<size_t>& range) {
    std::vector<uint32_t> ignore;
    std::vector<Occlusion::Segment> segments;
    std::vector<uint32_t> segmentVertex;
    std::array<bool, kRayBatch> seenBuffer;
    std::vector<Evidence> traced, batchRays;  // the pair's own rays; this batch's (positions, answer pending)
    size_t shot = 0;
    // The current group's sites (ReceiverGroups::siteCount): the tree order index of each one's
    // first receiver in the group, listed only where some site has more than one there.
    std::vector<uint32_t> siteFirst;
    RayMemo memo;  // the last leaf's rays, for its site-mates (RayMemo)
    auto listSites = [&](uint32_t gi) {
      const TreeNode& g = R.nodes[gi];
      siteFirst.clear();
      if (w.groups.siteCount[gi] == g.count) return;
      for (uint32_t k = g.first; k < g.first + g.count; ++k)
        if (w.groups.mateBefore[k] == kNoMate || w.groups.mateBefore[k] < g.first) siteFirst.push_back(k);
    };
    auto siteAt = [&](const TreeNode& g, uint32_t s) { return siteFirst.empty() ? g.first + s : siteFirst[s]; };
    // Whether a point lies above the horizon of some receiver of the group at site s.
    auto aboveSomeHorizon = [&](const TreeNode& g, uint32_t s, const Vec3& to) {
      for (uint32_t k = siteAt(g, s); k < g.first + g.count; k = w.groups.mateAfter[k]) {
        const uint32_t v = R.order[k];
        if (dot(w.recv.normal[v], to - w.recv.point[v]) > 0) return true;
      }
      return false;
    };
    // Traces `segments` (each from receiver segmentVertex[e]) as one batch: seenBuffer[e] says
    // whether each gets through, Embree's answer and, in double precision, the receiver's own patches.
    auto traceSeen = [&] {
      w.occlusion.visibleEach(segments, seenBuffer.data());
      shot += segments.size();
      for (size_t e = 0; e < segments.size(); ++e) {
        const uint32_t v = segmentVertex[e];
        const Sight sight{w.occlusion, w.mesh, w.recv.origin[v], {}, w.groups.site.own(w.recv, v)};
        seenBuffer[e] = seenBuffer[e] && !sight.crossesOwn(segments[e].to);
      }
    };
    // traceSeen, counting those that get through and keeping this pair's rays (batchRays) as traced.
    auto traceBatch = [&] {
      traceSeen();
      uint32_t through = 0;
      for (size_t e = 0; e < segments.size(); ++e) {
        through += seenBuffer[e];
        if (e < batchRays.size()) traced.push_back({batchRays[e].receiver, batchRays[e].source, seenBuffer[e]});
      }
      batchRays.clear();
      return through;
    };
    // Whether every receiver of g sees nothing of c's patches: max(sites, patches) rays, ray i from
    // site i mod sites to the centre of patch i mod patches where that patch could send the site
    // light (facing it, above its horizon), all blocked. So every site and every patch is asked
    // once or more where they can meet. (A ray from each site to each patch until the
    // twenty-eighth session: on the 23k-triangle engine part the cluster rays went 130M -> 105M,
    // the errors against exact the same; docs/results.md.) A few rays spread over them go first,
    // then the rest in batches, until one gets through.
    auto hiddenFromAll = [&](uint32_t gi, const TreeNode& c) {
      const TreeNode& g = R.nodes[gi];
      listSites(gi);
      const uint32_t sites = w.groups.siteCount[gi], n = std::max(sites, c.count), probes = std::min(n, kClusterRays);
      for (uint32_t first = 0; first < n;) {
        const uint32_t last = first == 0 ? probes : std::min(n, first + kRayBatch);
        segments.clear();
        segmentVertex.clear();
        for (uint32_t j = first; j < last; ++j) {
          const uint32_t k = uint32_t((uint64_t(j) * 2654435761u) % n);  // a permutation of [0, n)
          const uint32_t s = k % sites, v = R.order[siteAt(g, s)], item = S.order[c.first + k % c.count];
          const Vec3& m = w.mesh.patches[w.patchOf[item]].normal;
          const double side = dot(m, w.recv.origin[v] - centre[item]);
          if (side > 0 ? w.backsOnly : !w.cover) continue;  // a front of the transport's, a back of the cover's
          const Vec3 to = centre[item] + m * (side > 0 ? lift : -lift);
          if (!aboveSomeHorizon(g, s, to)) continue;  // below the site's horizons
          segments.push_back({w.recv.origin[v], to, w.groups.site.ignored(w.recv, v)});
          segmentVertex.push_back(v);
        }
        if (traceBatch() > 0) return false;
        first = last;
      }
      return true;
    };
    // The share of cluster c's factor that receiver v sees, for a faint partly hidden link: rays to
    // patches drawn by their area (in the refinement by light, by their light: then the share is
    // of the light), stratified, each weighted by its end's cosines over the squared distance. Rays
    // to patches picked by index weighed a small patch like a large one: in the lamp room (a lamp's
    // many small refined patches in one cluster with the large ceiling patches behind it) shares
    // of 1.0 and 0.14 where the truth was 0.48 and 0.45, the floor 3.6% too bright.
    // A cover walk's patch seen from behind covers as its reversed polygon: its cosine is taken on
    // the side v sees, and its ray ends lifted off that side. (Until the twenty-seventh session
    // every back sent a zero weight, so a faint, partly hidden cluster of backs had a share of 0
    // and was dropped: on the 23k-triangle engine part the rims of body_6, ending on body_4's
    // walls, lost 0.044 of the 0.478 that backs cover of their hemisphere, and saw that much more
    // sky: 3.8% of the mean too bright against exact.)
    static_assert(kFractionRays <= kRayBatch);
    auto visibleShare = [&](uint32_t v, const TreeNode& c) {
      const std::vector<double>& sum = w.lightSum ? *w.lightSum : areaSum;
      std::array<double, kFractionRays> factor{};
      segments.clear();
      segmentVertex.clear();
      for (uint32_t k = 0; k < kFractionRays; ++k) {
        const uint32_t patch = w.patchOf[S.order[c.first + drawnBy(sum, c, (k + 0.5) / kFractionRays)]];
        const Vec3 on = linkTarget(w.mesh, patch, k);
        const Vec3& m = w.mesh.patches[patch].normal;
        const Vec3 side = w.cover && dot(m, w.recv.origin[v] - on) < 0 ? -m : m;
        const Vec3 target = on + side * lift;
        factor[segments.size()] = pointKernel(w.recv.normal[v], side, target - w.recv.point[v]);
        if (!(factor[segments.size()] > 0)) continue;
        segments.push_back({w.recv.origin[v], target, w.groups.site.ignored(w.recv, v)});
        segmentVertex.push_back(v);
      }
      traceSeen();
      double all = 0, seen = 0;
      for (size_t e = 0; e < segments.size(); ++e) {
        all += factor[e];
        if (seenBuffer[e]) seen += factor[e];
      }
      return all > 0 ? seen / all : 0.0;
    };
    for (size_t task = range.begin(); task != range.end(); ++task) {
      std::vector<WalkEntry> stack{{w.groups.tasks[task], 0}};
      // The hidden starts lie at the bottom of the stack, below `hiddenBelow`: an entry popped from
      // there is one (what is pushed after it lies above).
      size_t hiddenBelow = 0;
      if (w.starts) {
        stack.clear();
        if (w.hiddenStarts)
          for (const auto& [gi, ci] : (*w.hiddenStarts)[task]) stack.push_back({gi, ci});
        hiddenBelow = stack.size();
        for (const auto& [gi, ci] : (*w.starts)[task]) stack.push_back({gi, ci});
      }
      size_t kept = 0;  // bytes of links and near entries, handed to the budget a MiB at a time
      size_t proofs = 0, proved = 0;  // hidden proofs tried and succeeded in this task
      while (!stack.empty()) {
        if (kept >= (size_t(1) << 20)) w.memory.add(std::exchange(kept, 0));
        const WalkEntry entry = stack.back();
        const uint32_t gi = entry.group, ci = entry.cluster;
        stack.pop_back();
        traced.clear();
        const bool wasHidden = stack.size() < hiddenBelow;
        if (wasHidden) hiddenBelow = stack.size();
        const TreeNode &g = R.nodes[gi], &c = S.nodes[ci];
        // Pushes the two children of g (receiver side) or of c, each with the rays inherited and
        // traced here that fall in it.
        auto open = [&](bool receiverSide) {
          for (int k = 1; k >= 0; --k) {
            WalkEntry child{receiverSide ? uint32_t(g.child[k]) : gi, receiverSide ? ci : uint32_t(c.child[k])};
            const TreeNode& part = receiverSide ? R.nodes[child.group] : S.nodes[child.cluster];
            auto add = [&](const Evidence& e) {
              const uint32_t at = receiverSide ? e.receiver : e.source;
              if (child.count < kEvidence && at >= part.first && at < part.first + part.count) child.rays[child.count++] = e;
            };
            for (uint32_t e = 0; e < entry.count; ++e) add(entry.rays[e]);
            for (const Evidence& e : traced) add(e);
            stack.push_back(child);
          }
        };
        // A group of traced vertices (parts keep them apart from the others) takes only bright
        // emitters here; its rays gather the rest, and its sky.
        if (w.traced && tracedIn[gi] == g.count) {
          if (w.cover || brightIn[ci] == 0) continue;
          if (brightIn[ci] < c.count) {
            open(false);
            continue;
          }
        }
        // Light never crosses a closed surface (Closure::separates), group by group.
        if (!w.cover && ((g.enclosed == g.count && c.enclosed == 0) || (g.enclosed == 0 && c.enclosed == c.count))) continue;
        if (g.count == 1 && c.count == 1) {
          const uint32_t v = R.order[g.first];
          if (!gathers(v)) continue;
          const uint32_t patch = w.patchOf[S.order[c.first]], site = w.groups.site.first[v];
          if (w.pressed && std::binary_search((*w.pressed)[v].begin(), (*w.pressed)[v].end(), patch)) continue;
          const auto ignored = w.groups.site.ignored(w.recv, v);
          ignore.assign(ignored.begin(), ignored.end());
          ignore.push_back(0);
          if (w.groups.site.patches[site].list.empty()) {
            kept += leaf(v, patch, ignore, nullptr);
            continue;
          }
          // A site's receivers reach a patch one after the other (their group opened for it):
          // the rays go from the site's origin, answered once for all of them.
          if (memo.site != site || memo.patch != patch) {  // in place: its buffer is kept
            memo.site = site;
            memo.patch = patch;
            memo.answers.clear();
          }
          const SharedSight shared{w.recv.origin[site], w.groups.site.own(w.recv, v), &memo};
          kept += leaf(v, patch, ignore, &shared);
          continue;
        }
        const double lightWeight = w.weight ? (*w.weight)[ci] : 1;
        const LinkEstimate estimate = linkEstimate(g, c, lightWeight);
        const Vec3 d = estimate.d;
        const double dist = estimate.dist;
        // Where the cluster lies against the receivers' horizons. A small group asks each receiver
        // (its leaf node is exact: one point, one plane) where the cone's bound cannot tell; a large
        // group keeps the bound, which on a curved surface is loose (tan(cone) × distance) and
        // would walk every pair of two curved objects down to single patches.
        Heights over = heightsOver(g, c);
        // A site (receivers at one point, receiverSites) straddled by the cluster: how far it
        // dips under the plane of the receiver it dips under most, if every receiver has some of
        // it above its plane (each receiver is flat: see the horizon rule below).
        const bool oneSite = g.count > 1 && w.groups.siteCount[gi] == 1;
        double siteDip = std::numeric_limits<double>::infinity();
        if (g.count > 1 && g.count <= kExactHorizons && g.coneSin > 0 && over.low < -over.rounding && over.high > over.rounding) {
          over = {std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(), 0};
          bool everyOneAbove = true;
          for (uint32_t k = g.first; k < g.first + g.count; ++k) {
            const Heights h = heightsOver(R.nodes[w.groups.leafOf[R.order[k]]], c);
            over = {std::min(over.low, h.low), std::max(over.high, h.high), std::max(over.rounding, h.rounding)};
            everyOneAbove = everyOneAbove && h.high > h.rounding;
          }
          if (oneSite && everyOneAbove) siteDip = -over.low;
        }
        if (over.high <= over.rounding) continue;  // on or below every receiver's horizon
        // Behind every patch's plane (strictly: a receiver in a patch's plane takes its crease limit):
        // the cluster shows the group only its back, whatever else holds (the back twins of a
        // double-sided surface were otherwise walked down to single patches wherever the front
        // ones were).
        const Heights facing = heightsOver(c, g);
        if (!w.cover && facing.high < -facing.rounding) continue;
        // No receiver of the group saw a back: it takes a patch only where the patch's plane passes
        // between a receiver's point and its rays' origin (a contact), so the point lies at most
        // originReach (+ ε) behind it. A cluster wholly further behind is dropped; with backs only,
        // so is one that covers the group below the horizon rule's share of --accuracy: seen at a
        // cosine of at most that reach over the distance, it covers at most
        // A (originReach + ε) / (π d³), d the gap between the two. It was opened down to single
        // patches wherever fronts and backs mix (the whole 2CylinderEngine's walk of backs took
        // about 630 s, 441 s with this).
        if (w.seesBacks && backsIn[gi] == 0) {
          if (facing.high < -facing.rounding - w.originReach) continue;
          const double gap = estimate.dist - g.radius - c.radius;
          if (w.backsOnly && gap > 0 &&
              c.area * (w.originReach + w.occlusion.epsilon()) / (kPi * gap * gap * gap) < w.accuracy * kHorizonShare)
            continue;
        }
        if (w.backsOnly && facing.low >= -w.occlusion.epsilon()) continue;  // only fronts
        const bool mixed = !w.cover && ((g.enclosed != 0 && g.enclosed != g.count) || (c.enclosed != 0 && c.enclosed != c.count));
        const double ratio = estimate.ratio;
        // (Curved groups once had this raised by 1 + 15 sin(cone): three Suzanne vertices of the
        // Blender room were 12–16% off exact without it. They were off for lack of visibility rays
        // at links of one to three receivers, not for the estimate: with at least kClusterRays rays
        // per link they are within 1.4% without the factor, which opened curved groups to twice the
        // (vertex, patch) pairs.)
        const double spread = estimate.spread, factor = estimate.factor, linkError = estimate.error;
        // A flat group (one plane for every receiver) may take a cluster that dips below that plane
        // by `depth`: the dipping part keeps its negative cosine, at most F · depth / d of light,
        // and along a plane's horizon line these shrink as the cube of the distance, so they stay
        // bounded (measured: the straddling pairs were opened to n^1.5 leaves otherwise).
        // (Not in the sky pass: its cover is not closed by anything, and the furnaces under a sky
        // are exact to 1e-5.)
        const bool flat = !w.cover && g.coneSin < 1e-6 && g.thickness <= 1e-9 * (g.radius + dist);
        // The light of patches with negative cosines, the cluster reaching `depth` past their zero.
        auto dipError = [&](double depth) { return spread * std::max(0.0, depth) / dist; };
        // A site's receivers are each flat: the one it dips under most decides, as if it were opened
        // to them (which walked each receiver of a flat-shaded crease down the cluster alone).
        const double horizonError = flat ? dipError(-over.low) : std::isfinite(siteDip) ? dipError(siteDip) : std::numeric_limits<double>::infinity();
        const bool above = over.low >= -over.rounding || horizonError < w.accuracy * kHorizonShare;
        // Everything a link needs but its horizon, facing and visibility.
        const bool linkable = !mixed && g.coneSin < 1 && c.coneSin <= 1 && ratio < kMaxRatio && linkError < w.accuracy;
        bool split = true;
        bool byVertex = false;  // open the group down to its vertices
        bool sawLight = false;  // a ray of the link test got through
        if (linkable && above) {
          const Vec3 u = d / dist;
          const double alpha = std::asin(c.coneSin), gamma = std::asin(std::min(1.0, ratio));
          const double beta = std::acos(std::clamp(-dot(c.axis, u), -1.0, 1.0));
          // Facing by the normal cones, or by the group's box over the cluster's patches' planes
          // (which also passes a floor group and a wall cluster meeting at a corner).
          const bool away = beta - alpha - gamma >= kPi / 2 || facing.high <= facing.rounding;
          // A cluster whose patches turn away from some receivers by a little (the terminator of a
          // curved object) is linked like one facing them, when the backs' negative cosines, at most
          // F · depth / d of light as under a flat group's horizon, stay below the same share of
          // --accuracy (dipError); their centres are not asked for visibility (`sends`).
          const bool turning = !w.cover && !w.rowsCoverSky && facing.high > facing.rounding && dipError(-facing.low) < w.accuracy * kHorizonShare;
          const bool toward = alpha + beta + gamma < kPi / 2 || facing.low >= -facing.rounding || turning;
          if (away && !w.cover) continue;  // every patch shows the group its back
          if (w.backsOnly ? away : toward || away) {
            // Rays from every receiver of the group, each to a patch of the cluster (spread over
            // it by a multiplicative hash): fewer, from sample receivers only, let light through
            // to the floor beside and under a block (measured: 3% errors there).
            // Rays per receiver grow with the link's factor (with both cosines: A/(π d²) without them
            // gave grazing links 4 rays: 37% more rays at Cornell N = 20 for 2.57% largest error
            // instead of 2.75%): a wrong answer costs at most that much light, so faint links get
            // one ray and bright ones kClusterRays.
            // And a link asks at least kClusterRays rays in all: a link of one vertex decided by one
            // ray let light through partly hidden clusters (Suzanne vertices of the Blender room up
            // to 5% too bright once groups opened to their vertices at horizons, below).
            // Per site rather than per receiver (ReceiverGroups::siteCount): the receivers at one point,
            // one per face of a flat-shaded crease, share its rays (issue 16's Blender room:
            // 80.4 → 70.1 s, its Suzannes and spheres flat-shaded as Blender makes them).
            const uint32_t sites = w.groups.siteCount[gi];
            listSites(gi);
            const uint32_t perReceiver = raysPerReceiver(sites, factor, w.weight ? kLinkRays : kClusterRays);
            const uint32_t count = sites * perReceiver;
            // Rays k of `total` to a hashed patch, for k = index(j), j < n, traced in batches, ray k
            // from site k · sites / total (k / per receiver where total = sites · per);
            // with `stopWhenMixed` it stops at the first batch that shows some rays through and
            // some blocked, counting `prior` rays already traced (the pair is then opened whatever
            // the rest say). Returns those through and those asked, `prior` included.
            auto trace = [&](uint32_t n, uint32_t total, auto index, bool stopWhenMixed, std::pair<uint32_t, uint32_t> prior) {
              auto [through, asked] = prior;
              for (uint32_t first = 0; first < n; first += kRayBatch) {
                segments.clear();
                segmentVertex.clear();
                const uint32_t last = std::min(n, first + kRayBatch);
                for (uint32_t j = first; j < last; ++j) {
                  const uint32_t k = index(j);
                  const uint32_t from = siteAt(g, uint32_t(uint64_t(k) * sites / total)), v = R.order[from];
                  uint32_t start = uint32_t((uint64_t(k) * 2654435761u + c.count / 2) % c.count);
                  if (w.lightSum && k % 2 == 0) start = drawnByLight(*w.lightSum, c, start);
                  uint32_t at = c.first + start, item = S.order[at];
                  Vec3 target;
                  // A patch dipping under a flat group's plane (linked by horizonError) or turned
                  // away from v (linked as `turning`) sends v no light: the next patch that does is
                  // asked instead, and if there is none the ray counts as through.
                  auto sends = [&] {
                    target = linkTarget(w.mesh, w.patchOf[item], k) + w.mesh.patches[w.patchOf[item]].normal * (away ? -lift : lift);
                    return (!flat || dot(w.recv.normal[v], target - w.recv.point[v]) > 0) &&
                           (!turning || dot(w.mesh.patches[w.patchOf[item]].normal, w.recv.origin[v] - centre[item]) > 0);
                  };
                  bool found = sends();
                  for (uint32_t step = 1; step < c.count && !found; ++step) {
                    at = c.first + (start + step) % c.count;
                    item = S.order[at];
                    found = sends();
                  }
                  if (!found) {
                    ++through;
                    continue;
                  }
                  segments.push_back({w.recv.origin[v], target, w.groups.site.ignored(w.recv, v)});
                  segmentVertex.push_back(v);
                  batchRays.push_back({from, at, false});
                }
                through += traceBatch();
                asked = prior.second + last;
                if (stopWhenMixed && through > 0 && through < asked) break;
              }
              return std::pair{through, asked};
            };
            // A few rays spread over the pair first: most pairs that will be opened show it here,
            // before a ray from every receiver is spent on them.
            const uint32_t probes = std::min(count, kClusterRays);
            auto probe = [&](uint32_t k) { return uint32_t((uint64_t(2 * k + 1) * count) / (2 * probes)); };
            // A pair the first walk called hidden on these rays asks only for its extra rays.
            bool inheritedThrough = false, inheritedBlocked = false;
            for (uint32_t e = 0; e < entry.count; ++e) (entry.rays[e].through ? inheritedThrough : inheritedBlocked) = true;
            const bool inheritedMixed = inheritedThrough && inheritedBlocked;
            auto [seen, asked] = wasHidden || inheritedMixed ? std::pair{0u, count} : trace(probes, count, probe, false, {0, 0});
            // Partly seen on the inherited rays and its own together: opened, as on mixed probes.
            if (inheritedMixed || (seen == probes && inheritedBlocked) || (seen == 0 && inheritedThrough))
              std::tie(seen, asked) = std::pair{1u, probes};
            // A faint pair whose probes are all blocked is hidden: a receiver whose own rays would
            // have seen some of it loses at most the pair's factor (cluster rays −11% in the
            // level-0 Blender room, −16% on the engine part; errors against exact unchanged). Not
            // the other way round: a faint pair whose probes all get through was linked until the
            // third session of 2026-12-03, and the few receivers it shadows (the ceiling above a
            // lamp hung 2 cm below it, which sees the walls only through the slit between them)
            // gained the factors of some 200 such links, 0.035 of their hemisphere where the exact
            // row holds 0.028 (lamp room at N = 20: 12.8% too dark there after closure).
            const double peakFactor = w.peak ? factor / lightWeight * (*w.peak)[ci] : factor;
            if (!w.rowsCoverSky && peakFactor < w.accuracy * kFaintHiddenShare && seen == 0) asked = count;
            if (asked < count && (seen == probes || seen == 0)) {  // a link, or hidden: every ray says
              // The other rays, in an order spread over the group (j → j · p mod their number, p a
              // prime above it), so that a shadow over part of the receivers shows in the first
              // batches: the j-th index that is not a probe's (the probes' rise strictly).
              auto rest = [&](uint32_t j) {
                j = uint32_t(uint64_t(j) * 2654435761u % (count - probes));
                for (uint32_t k = 0; k < probes && probe(k) <= j; ++k) ++j;
                return j;
              };
              std::tie(seen, asked) = trace(count - probes, count, rest, true, {seen, asked});
            }  // else: some probes through and some blocked, the pair is opened
            // Hidden when every receiver's rays are blocked, the same evidence a link needs (it was
            // taken for small pairs only, and large hidden pairs were opened down to them: in the
            // Cornell box at N = 40, 69M of 120M cluster rays went to finding the blocks' shadows).
            // All blocked: more rays before the pair is called hidden, where its factor asks for
            // them (kHiddenRays a site, for kHiddenSites sites at most, spread over the group); one
            // getting through makes it partly seen (count is at least kClusterRays, so seen = 1 is
            // not a link).
            // (A pair the first walk called hidden was traced with that walk's rays per receiver,
            // which the light's weight may have raised since: it is asked the larger number.)
            const uint32_t hiddenRays = std::max(hiddenRaysPerReceiver(factor), perReceiver);
            const uint32_t tracedPer = wasHidden ? raysPerReceiver(sites, factor / lightWeight, kClusterRays) : perReceiver;
            if (seen == 0 && asked == count && hiddenRays > tracedPer) {
              if (w.deferredHidden) {
                (*w.deferredHidden)[task].push_back({gi, ci});
                kept += sizeof(std::pair<uint32_t, uint32_t>);
              } else if (const uint32_t extra = std::min(sites, kHiddenSites) * hiddenRays;
                         trace(extra, extra, [](uint32_t k) { return k; }, true, {0, 0}).first > 0) {
                seen = 1;
              }
            }
            if (seen == 0 && asked == count) continue;
            sawLight = seen > 0;
            if (seen == count && asked == count) {
              links[gi].push_back({ci});
              kept += sizeof(ClusterLink);
              nodeError[gi] += (linkError + (over.low >= -over.rounding ? 0 : horizonError)) / lightWeight;
              split = false;
            } else if (seen > 0 && peakFactor < faintFactor) {
              // Faint and partly hidden (a cluster behind an occluder's silhouette): linked to each
              // vertex with the share its own rays see, instead of opened down to single patches
              // at every receiver, which grows as n^1.5 (every receiver × the silhouette's patches).
              if (g.count == 1) {
                const double share = visibleShare(R.order[g.first], c);
                if (!(share > 0)) continue;
                links[gi].push_back({ci, float(share)});
                kept += sizeof(ClusterLink);
                nodeError[gi] += (linkError + factor / kFractionRays) / lightWeight;  // and the share's sampling
                split = false;
              } else {
                byVertex = true;
              }
            }
          }
        }
        if (!split) continue;
        // A small pair about to be opened (kHiddenProofPairs (vertex, patch) pairs at most, which
        // would cost 5 rays each) that is hidden from every receiver is dropped whole: one ray per
        // receiver and patch centre, all blocked. Only where the pair is apart (no receiver touches
        // a patch, so no crease limit is cut off) and every patch is faint enough that a centre
        // ray blocked while some of the patch shows costs at most --accuracy: judged by its centre,
        // a ceiling light cut the Suzannes of the Blender room by up to 75%.
        const double gap = dist - g.radius - c.radius;
        // Proofs are tried while they pay in this task: where they fail (a convex scene, the Cornell
        // box: 2% of its proofs found a hidden pair) each failure costs its probe rays.
        if (!byVertex && !sawLight && !mixed && ratio < kMaxRatio && uint64_t(g.count) * c.count <= kHiddenProofPairs &&
            largestPatch[ci] * lightWeight < w.accuracy * kPi * gap * gap && (proofs < kProofTrial || proved * kProofYield >= proofs)) {
          ++proofs;
          if (hiddenFromAll(gi, c)) {
            ++proved;
            continue;
          }
        }
        // Open the larger group (a leaf cannot be opened); but a pair that fails only by straddling
        // some receivers' horizons opens the group while the wedge its receivers' planes sweep
        // at the cluster (d sin(cone) + r_g) is wider than the cluster: opening the cluster instead
        // walked each curved vertex down to the single patches along its horizon line, n^1.5
        // (Blender room at Suzanne level 1: 10.5M of 23M (vertex, patch) pairs). A single vertex
        // then links the line's clusters under the flat horizon rule.
        const bool wedge = linkable && !above && g.count > 1 && dist * g.coneSin + g.radius > c.radius;
        const bool openReceiver = byVertex || c.count == 1 || wedge || (g.count > 1 && g.radius >= c.radius);
        open(openReceiver);
      }
      w.memory.add(kept);
      if (taskDone) taskDone(R.nodes[w.groups.tasks[task]]);
      ticker.add(R.nodes[w.groups.tasks[task]].count);
    }
    rays += shot;
  });
  raysShot += rays.load();
  return links;
}

// The part of vertex i's projected solid angle that patch `source` covers, seen from either side:
// seen from the front, what it sends in K (Σ_j K_ij, addPatchKernel), so that the sky and the
// transport agree on what covers a receiver and a white scene under a sky of 1 is uniform. A
// patch that touches the vertex covers its kernel's limits (all at the vertex: no quadrature); a
// fully visible one its factor (Σ_j K_ij = F to rounding); only a partly hidden one needs the
// kernel, integrated with `kernel`, to weight its corners' visible fractions. Until the seventh
// session of 2026-12-02 the cover was the polygon's own limit times the plain mean of its corners'
// visibility: it missed the floor patch under a block's foot (the limit of a plane the vertex
// stands inside, half the hemisphere of the vertices along the foot: a white block on a white
// floor under a sky of 1 went to 1.5 there), and it put partly hidden patches near a vertex up to
// 30% off Σ_j K_ij. Seen from behind, a double-sided patch's twin covers in its place (its front is
// K's); a one-sided patch, the same solid angle with the polygon reversed. `ignore` has a free
// last slot. With `backsOnly`, a patch K takes (seen from its front) covers nothing here: the
// hierarchical transport's rows hold it (skyFromRows).
double skyCover(const PatchMesh& mesh, const Occlusion& occlusion, const Receivers& recv, const KernelOptions& kernel,
                size_t i, size_t source, std::vector<uint32_t>& ignore, const PairSight& resolve, bool backsOnly, size_t& rays) {
  const Patch& patch = mesh.patches[source];
  // Covering is geometry, not light: a double-sided surface covers once (its front patch stands
  // for both sides), and the vertex's own twin covers nothing.
  if (patch.backSide || recv.isOwnTwin(i, uint32_t(source))) return 0;
  const Vec3 p = recv.point[i], nrm = recv.normal[i], approach = recv.approach[i];
  // Behind by K's own margin (addPatchKernel): a patch whose plane holds the vertex to rounding
  // (the other wall at an unwelded crease of a flat-shaded export) is seen from the front.
  const auto own = recv.own(i);
  const bool isOwn = std::find(own.begin(), own.end(), uint32_t(source)) != own.end();
  const bool behind = !isOwn && dot(patch.normal, p - mesh.positions[patch.v[0]]) < -occlusion.epsilon();
  if (backsOnly && !behind) return 0;
  const uint32_t from = behind && patch.twin >= 0 ? uint32_t(patch.twin) : uint32_t(source);
  auto q = corners(mesh, mesh.patches[from]);
  Vec3 normal = mesh.patches[from].normal;
  if (from == source && behind) {  // the same solid angle, reversed polygon (a triangle's repeated
    std::swap(q[1], q[3]);         // vertex moves but stays consecutive, which the factor accepts)
    normal = -normal;
  }
  if (!kernelReaches(p, nrm, q, normal, occlusion.epsilon(), mesh, own)) return 0;
  auto sum = [](const std::array<double, 4>& k, const std::array<double, 4>& weight) {
    return k[0] * weight[0] + k[1] * weight[1] + k[2] * weight[2] + k[3] * weight[3];
  };
  if (nearestQuadPoint(q, p).distance <= occlusion.epsilon()) return sum(vertexQuadKernel(p, nrm, approach, q, kernel), {1, 1, 1, 1});
  const double f = pointPolygonFactorLimit(p, nrm, approach, q.data(), 4);
  if (!(f > 0)) return 0;
  ignore.back() = from;
  const Sight sight{occlusion, mesh, recv.origin[i], ignore, own};
  const auto vis = pairVisibility(sight, nrm, q, normal, mesh.patches[from].area, resolve, rays);
  if (vis == std::array<double, 4>{1, 1, 1, 1} || vis == std::array<double, 4>{}) return f * vis[0];
  return sum(vertexQuadKernel(p, nrm, approach, q, kernel), vis);
}

// The exact (receiver, patch) pairs of either transport (a walk's leaves, or every pair).
// NearPair appends what receiver v takes from
// `patch` to `row` (the bilinear method's K_ij per corner vertex j, the constant method's F_vl) and
// returns the rays it traced; CoverPair returns the share of v's hemisphere `patch` covers and
// counts its rays. `ignore` is v's ignore list with a free last slot; a walk passes, for a vertex
// with site-mates (receiverSites), the site's rays instead of v's own (SharedSight).
using NearPair = std::function<size_t(uint32_t v, uint32_t patch, std::vector<uint32_t>& ignore, Row& row, const SharedSight* shared)>;
using CoverPair = std::function<double(uint32_t v, uint32_t patch, std::vector<uint32_t>& ignore, size_t& rays)>;

// Whether any of kBackGrid² fixed cosine-distributed rays from vertex v first meets a one-sided
// patch from behind (with `backTwins`, or a double-sided surface's back twin), for the vertices
// the sky pass covers (not enclosed, not traced). Those walk the patches seen from behind
// (hierarchicalCover); elsewhere a back lies behind a front. On the 2CylinderEngine part
// (one-sided, `--sky 1`) 475 of 8,546 vertices see a back, and half of the sky pass's exact pairs
// had been patches seen from behind, 98% of them hidden (5 rays each). A back no ray meets is
// smaller than their spacing.
std::vector<bool> backSeeing(const PatchMesh& mesh, const Occlusion& occlusion, const Receivers& recv,
                             const Closure& closure, const ReceiverGroups& groups, const std::vector<bool>& traced,
                             bool backTwins, size_t& rays) {
  const size_t nv = recv.point.size();
  std::vector<uint8_t> sees(nv, 0);  // (not vector<bool>: written in parallel)
  std::atomic<size_t> shotAll{0};
  const double far = 2 * occlusion.sceneSize();
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nv, 64), [&](const tbb::blocked_range<size_t>& range) {
    size_t shot = 0;
    for (size_t v = range.begin(); v != range.end(); ++v) {
      // No sky, nothing in front, or a sky of its own rays.
      if (closure.rows[v] || groups.leafOf[v] == kNoLeaf || (!traced.empty() && traced[v])) continue;
      const Sight sight{occlusion, mesh, recv.origin[v], recv.ignored(v), recv.own(v)};
      const Vec3& n = recv.normal[v];
      const auto [t, b] = tangentFrame(n);
      for (int k = 0; k < kBackGrid * kBackGrid && !sees[v]; ++k) {
        const Vec3 d = malleyDirection<kBackGrid>(k, t, b, n);
        const Vec3 end = recv.origin[v] + d * far;
        if (sight.crossesOwn(end)) continue;  // its own patches: the walk takes them exactly
        ++shot;
        const int64_t hit = occlusion.firstHit(recv.origin[v], end, sight.ignore);
        const int64_t side = hit >= 0 ? facingSide(mesh, hit, d) : 0;
        sees[v] = side < 0 || (backTwins && mesh.patches[side].backSide);
      }
    }
    shotAll.fetch_add(shot, std::memory_order_relaxed);
  });
  rays += shotAll.load();
  return std::vector<bool>(sees.begin(), sees.end());
}

// What patches cover of each receiver's hemisphere (the sky pass), with the cluster walk in cover
// mode: near patches exactly (`coverPair`), far clusters as n · w |w · Σ A n| / (π |w|⁴) per
// receiver, w from it to the cluster's centroid. With `backsOnly` (the bilinear method, whose
// transport's rows cover the fronts: skyFromRows) only one-sided patches seen from behind: a
// double-sided surface seen from behind shows its back twin, whose front K holds. Otherwise every
// patch, a double-sided surface once. Patches seen from behind are walked only for the vertices
// whose rays see a back (backSeeing); for the others only those whose plane passes between their
// point and their rays' origin (a contact: from the origin the rays see that patch's front).
std::vector<double> hierarchicalCover(const PatchMesh& mesh, const Occlusion& occlusion, const Receivers& recv,
                                      const Closure& closure, const ReceiverGroups& groups, double accuracy,
                                      const CoverPair& coverPair, bool backsOnly, const std::vector<bool>& traced,
                                      MemoryBudget& memory, Ticker& ticker, size_t& rays, size_t& nearRays) {
  const size_t nv = recv.point.size();
  std::vector<double> covered(nv, 0.0);
  std::vector<uint32_t> sources;
  for (size_t p = 0; p < mesh.patches.size(); ++p)
    if (!mesh.patches[p].backSide && (!backsOnly || mesh.patches[p].twin < 0)) sources.push_back(uint32_t(p));
  if (sources.empty()) {  // backs only, and double-sided throughout (as Blender exports)
    ticker.add(nv);
    return covered;
  }
  const ClusterTree tree = patchTree(mesh, sources, closure);
  WalkSetup setup{mesh, occlusion, recv, groups, tree, sources, true, accuracy, memory};
  setup.backsOnly = backsOnly;
  if (!traced.empty()) setup.traced = &traced;  // their rays found their sky
  const std::vector<bool> seesBacks = backSeeing(mesh, occlusion, recv, closure, groups, traced, !backsOnly, nearRays);
  setup.seesBacks = &seesBacks;
  for (size_t v = 0; v < nv; ++v) setup.originReach = std::max(setup.originReach, length(recv.origin[v] - recv.point[v]));
  std::vector<double> nodeError;  // the cover pass's own estimate is not reported
  std::atomic<size_t> pairRays{0};
  const auto links = walkPairs(
      setup, [&](uint32_t v) { return !closure.rows[v]; }, nodeError,
      [&](uint32_t v, uint32_t patch, std::vector<uint32_t>& ignore, const SharedSight*) {
        // A vertex whose rays saw no back takes none behind from its point and from the rays'
        // origin (and with backsOnly, coverPair takes none in front).
        const Patch& p = mesh.patches[patch];
        auto behind = [&](const Vec3& x) { return dot(p.normal, x - mesh.positions[p.v[0]]) < -occlusion.epsilon(); };
        if (!seesBacks[v] && behind(recv.point[v]) && behind(recv.origin[v])) return size_t(0);
        size_t traced = 0;
        covered[v] += coverPair(v, patch, ignore, traced);
        pairRays.fetch_add(traced, std::memory_order_relaxed);
        return size_t(0);
      },
      {}, ticker, rays);
  nearRays += pairRays.load();
  // Each vertex adds the links of its groups, from its leaf to the root.
  const std::vector<int32_t>& parent = groups.parent;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nv, 256), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t v = range.begin(); v != range.end(); ++v) {
      if (groups.leafOf[v] == kNoLeaf) continue;
      for (int32_t k = int32_t(groups.leafOf[v]); k >= 0; k = parent[k])
        for (const ClusterLink& link : links[k]) {
          const Vec3 w = tree.nodes[link.source].centroid - recv.point[v];
          const double d2 = dot(w, w);
          covered[v] += link.visible * dot(recv.normal[v], w) * std::abs(dot(w, tree.nodes[link.source].areaNormal)) / (kPi * d2 * d2);
        }
    }
  });
  return covered;
}

// Walks `setup` and adds what it finds to h: near entries merged into each vertex's row (packed at
// 8 bytes an entry once its task is done), links appended to their groups' lists, their error
// estimates, rays and counts.
void walkInto(Hierarchical& h, const WalkSetup& setup, const NearPair& nearPair, Ticker& ticker) {
  const size_t nv = h.near.size();
  std::vector<Row> near(nv);
  std::vector<double> nodeError;
  std::atomic<size_t> pairRays{0};
  const ClusterTree& R = h.groups.tree;
  auto links = walkPairs(
      setup, [&](uint32_t v) { return h.groups.leafOf[v] != kNoLeaf; }, nodeError,
      [&](uint32_t v, uint32_t patch, std::vector<uint32_t>& ignore, const SharedSight* shared) {
        const size_t before = near[v].size();
        pairRays.fetch_add(nearPair(v, patch, ignore, near[v], shared), std::memory_order_relaxed);
        return (near[v].size() - before) * kNearEntryBytes;
      },
      [&](const TreeNode& task) {  // its vertices' rows are complete
        for (uint32_t k = task.first; k < task.first + task.count; ++k) {
          const uint32_t v = R.order[k];
          if (near[v].empty()) continue;
          for (const auto& [col, val] : h.near[v]) near[v].emplace_back(col, val);
          canonicalize(near[v]);
          std::vector<std::pair<uint32_t, float>>(near[v].size()).swap(h.near[v]);
          for (size_t e = 0; e < near[v].size(); ++e) h.near[v][e] = {near[v][e].first, float(near[v][e].second)};
          Row().swap(near[v]);
        }
      },
      ticker, h.rays);
  h.nearRays += pairRays.load();
  if (h.links.empty()) h.links.resize(links.size());
  if (h.nodeError.empty()) h.nodeError.assign(nodeError.size(), 0.0);
  for (size_t k = 0; k < links.size(); ++k) {
    h.nodeError[k] += nodeError[k];
    if (links[k].empty()) continue;
    h.links[k].insert(h.links[k].end(), links[k].begin(), links[k].end());
    h.links[k].shrink_to_fit();  // one list at a time: the slack of push_back's doubling goes
    std::vector<ClusterLink>().swap(links[k]);
  }
  h.nearEntries = h.linkCount = 0;
  for (const auto& row : h.near) h.nearEntries += row.size();
  for (const auto& list : h.links) h.linkCount += list.size();
  // The error estimate of what a vertex gathers far: its groups' link estimates, leaf to root.
  h.worstError = 0;
  for (size_t v = 0; v < nv; ++v) {
    double error = 0;
    for (int32_t k = h.groups.leafOf[v] == kNoLeaf ? -1 : int32_t(h.groups.leafOf[v]); k >= 0; k = h.groups.parent[k])
      error += h.nodeError[k];
    h.worstError = std::max(h.worstError, error);
  }
}

// Closure (as applyClosure does for exact rows): each row's total, near entries plus the far share
// n_i · Φ of L ≡ 1 (whose moments are Σ A n), brought to 1 where the rules say: at a flat receiver
// by the far share alone where that is within kFarClosure of itself, else the whole row.
void closeRows(Hierarchical& h, const Receivers& recv, Closure& closure) {
  const size_t nv = h.near.size();
  for (size_t v = 0; v < nv; ++v) h.rowScale[v] = h.groups.leafOf[v] == kNoLeaf ? 0 : 1;  // 0: gathers nothing
  h.farScale.assign(nv, 1.0);
  const ClusterTree& S = h.source;
  std::vector<NodeMoment> ones(S.nodes.size());
  for (size_t k = 0; k < S.nodes.size(); ++k)
    ones[k] = {S.nodes[k].centroid, {S.nodes[k].areaNormal, S.nodes[k].areaNormal, S.nodes[k].areaNormal}};
  const std::vector<Vec3> farOne = gatherFar(h, ones);
  for (size_t v = 0; v < nv; ++v) {
    if (h.rowScale[v] == 0) continue;
    double sum = farOne[v].x;
    for (const auto& entry : h.near[v]) sum += entry.second;
    if (!closure.scales(v, sum)) continue;
    const double far = farOne[v].x, scale = far > 0 ? (far - (sum - 1)) / far : 0;
    if (recv.flat[v] && scale >= 1 / kFarClosure && scale <= kFarClosure) h.farScale[v] = scale;
    else h.rowScale[v] = 1 / sum;
  }
}

// Back sides seen little (docs/radiosity.md "Back sides seen little"). The back side of a
// double-sided surface is written nowhere (COLOR_0 holds the front): its light matters only where
// a written surface sees it. The open insides of Blender's double-sided Suzannes took 44% of the
// walk's time in issue 16's room, proving the room hidden from them and walking their own cavity
// nearly all-pairs, for light that reaches the room only through the gaps around the eyes.
// Such a vertex gathers instead its near patches' exact kernels and, for the rest, kTracedGrid²
// fixed cosine-distributed rays: each meets a patch (the side facing the ray) and adds its
// bilinear weights there, the same gather E/π estimated by quadrature over the hemisphere; a ray
// that leaves the scene is its sky. Bright emitters are left to the walk (solveRadiosity gives
// the traced vertices receiver subtrees of their own, walkPairs gives those only bright clusters).
// Returns the rows without the walk's part, and the rays the rows took. The quadrature's error
// reaches the written surfaces weighted by how much of them sees the vertex: by reciprocity,
// Σ_f A_f F(f ← v) = A_v q_v, with q_v the share of v's rays that meet a written (front) side. So a
// back side is traced only where q_v ≤ kTracedSeen, lowest first, while Σ A_v q_v of those traced
// stays below kTracedShare of the written area (a room modelled inside out, seen by its furniture
// through its back sides, keeps its walk). A lamp's back 2 cm under a ceiling sees the ceiling's
// front with every ray and keeps its walk.
constexpr int kTracedGrid = 16;
constexpr double kTracedProgress = 0.05;  // the share of the progress they report
constexpr double kTracedSeen = 0.05;
constexpr double kTracedShare = 1e-3;

struct TracedBackSides {
  std::vector<bool> traced;  // per unknown
  std::vector<Row> rows;     // per unknown, empty unless traced
  std::vector<double> open;  // per unknown: the share of its rays that leave the scene
  size_t rays = 0;
};

TracedBackSides tracedBackSides(const PatchMesh& mesh, const Occlusion& occlusion, const Receivers& recv,
                                const Closure& closure, const std::vector<bool>& gathers, const std::vector<bool>& bright,
                                const NearPair& nearPair, Ticker& ticker) {
  const size_t nv = recv.point.size();
  TracedBackSides out;
  out.traced.assign(nv, false);
  out.rows.resize(nv);
  out.open.assign(nv, 0.0);
  std::vector<double> area(nv, 0.0);  // ∫ N_v dA over the vertex's patches
  double written = 0;
  for (const Patch& patch : mesh.patches) {
    const auto a = shapeFunctionAreas(corners(mesh, patch));
    for (int j = 0; j < 4; ++j) area[patch.v[j]] += a[j];
    if (!patch.backSide) written += patch.area;
  }
  std::vector<uint32_t> candidates;
  for (size_t v = 0; v < nv; ++v) {
    const auto own = recv.own(v);
    if (gathers[v] && !own.empty() &&
        std::all_of(own.begin(), own.end(), [&](uint32_t p) { return mesh.patches[p].backSide; }))
      candidates.push_back(uint32_t(v));
  }
  ticker.add(nv - candidates.size());  // the others have nothing to do here
  if (candidates.empty()) return out;
  constexpr int kRays = kTracedGrid * kTracedGrid;
  const double far = 2 * occlusion.sceneSize();
  std::vector<double> seenShare(candidates.size());
  std::atomic<size_t> rays{0};
  tbb::parallel_for(tbb::blocked_range<size_t>(0, candidates.size(), 16), [&](const tbb::blocked_range<size_t>& range) {
    std::vector<uint32_t> near, ignore;
    std::array<Vec3, kRays> dirs;
    std::array<int64_t, kRays> hits;  // per ray, the patch facing it that it meets first (facingSide), or kOpen
    std::array<Vec3, kRays> ends;     // the rays traced (not into an own patch), as firstHits takes them
    std::array<int64_t, kRays> firstHits;
    std::array<int, kRays> tracedAt;
    constexpr int64_t kOpen = -2;
    for (size_t c = range.begin(); c != range.end(); ++c) {
      const uint32_t v = candidates[c];
      const Vec3 &from = recv.origin[v], &n = recv.normal[v];
      const Sight sight{occlusion, mesh, from, recv.ignored(v), recv.own(v)};
      const auto [t, b] = tangentFrame(n);
      // The rays first: the share of them that meets a written side decides whether v is traced.
      int seen = 0, traced = 0;
      for (int k = 0; k < kRays; ++k) {
        dirs[k] = malleyDirection<kTracedGrid>(k, t, b, n);
        const Vec3 end = from + dirs[k] * far;
        if (sight.crossesOwn(end)) {  // into one of its own patches: a near one (below)
          hits[k] = recv.own(v)[0];
          continue;
        }
        tracedAt[traced] = k;
        ends[traced++] = end;
      }
      occlusion.firstHits(from, std::span(ends.data(), traced), sight.ignore, firstHits.data());
      for (int e = 0; e < traced; ++e) {
        const int k = tracedAt[e];
        hits[k] = firstHits[e] < 0 ? kOpen : facingSide(mesh, firstHits[e], dirs[k]);
        seen += hits[k] >= 0 && !mesh.patches[hits[k]].backSide;
      }
      seenShare[c] = double(seen) / kRays;
      rays.fetch_add(kRays, std::memory_order_relaxed);
      ticker.add(1);
      if (seenShare[c] > kTracedSeen) continue;  // walked
      Row& row = out.rows[v];
      // The near field exactly, as the walk would take it: the patches within twice the reach of
      // the vertex's own (touching ones take their contact limits, which rays from the offset
      // origin miss: a Suzanne's inside where its eye meets the head got 95% of its row from two
      // such patches), bright ones left to the walk; its own patches too (at a concave curved
      // vertex they rise into its hemisphere), not their twins.
      double reach = 0;
      for (uint32_t p : recv.own(v))
        for (const Vec3& x : corners(mesh, mesh.patches[p])) reach = std::max(reach, length(x - recv.point[v]));
      near.assign(recv.own(v).begin(), recv.own(v).end());
      occlusion.patchesNear(recv.point[v], 2 * reach, near);
      std::erase_if(near, [&](uint32_t p) { return bright[p] || recv.isOwnTwin(v, p); });
      std::sort(near.begin(), near.end());
      near.erase(std::unique(near.begin(), near.end()), near.end());
      size_t nearRays = 0;
      const auto ignored = recv.ignored(v);
      for (uint32_t p : near) {
        ignore.assign(ignored.begin(), ignored.end());
        ignore.push_back(0);
        nearRays += nearPair(v, p, ignore, row, nullptr);
      }
      rays.fetch_add(nearRays, std::memory_order_relaxed);
      double nearSum = 0;
      for (const auto& entry : row) nearSum += entry.second;
      // The rays whose first hit is not a near patch sample the rest of the hemisphere. Outside a
      // closed room its measure is 1 − Σ near, and each takes that over their count: row and sky
      // then cover the hemisphere once (a white open tube under a sky of 1 is uniform to 2e-5, and
      // 18% off with 1/count a ray). Inside one, each takes 1/count, as the exact transport's rows
      // take the near kernels and the rays from the same origin, and closure holds the row to 1:
      // where a vertex touches another surface (a Suzanne's inside where its eye meets the head)
      // the kernels' contact limits and the rays disagree, and the level-0 Blender room was 6.4%
      // off exact at such vertices with the share, 0.69% (as walked) without it.
      Row rest;
      int open = 0, nearHits = 0;
      for (int k = 0; k < kRays; ++k) {
        const int64_t hit = hits[k];
        if (hit == kOpen) ++open;
        if (hit < 0) continue;  // open, or the back of a one-sided patch
        if (std::binary_search(near.begin(), near.end(), uint32_t(hit))) {
          ++nearHits;
          continue;
        }
        if (bright[hit]) continue;  // the walk gathers it (rays would miss a small lamp)
        const Patch& p = mesh.patches[hit];
        const auto w = shapeFunctionsAlong(mesh, p, from, dirs[k]);
        for (int j = 0; j < 4; ++j)
          if (w[j] != 0) rest.emplace_back(p.v[j], w[j]);
      }
      const double perRay = closure.rows[v] ? 1.0 / kRays : nearHits < kRays ? std::max(0.0, 1 - nearSum) / (kRays - nearHits) : 0;
      for (auto& entry : rest) entry.second *= perRay;
      row.insert(row.end(), rest.begin(), rest.end());
      canonicalize(row);
      out.open[v] = open * perRay;
    }
  });
  out.rays = rays.load();
  // Lowest q first (ties by vertex: the same set for any thread count), within both bounds.
  std::vector<uint32_t> order(candidates.size());
  for (size_t c = 0; c < order.size(); ++c) order[c] = uint32_t(c);
  std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) { return seenShare[a] < seenShare[b]; });
  double weight = 0;
  for (uint32_t c : order) {
    const uint32_t v = candidates[c];
    if (seenShare[c] > kTracedSeen || weight + area[v] * seenShare[c] > kTracedShare * written) break;
    weight += area[v] * seenShare[c];
    out.traced[v] = true;
  }
  for (uint32_t v : candidates)
    if (!out.traced[v]) Row().swap(out.rows[v]);
  return out;
}

// Whether the transport's rows are also its sky's cover (the bilinear method under a sky:
// skyFromRows), which both of its walks must know (WalkSetup::rowsCoverSky).
bool rowsCoverSky(const Hierarchical& h, const RadiosityOptions& options) { return hasSky(options) && !h.perPatch; }

// Per receiver, the patches pressed against it: its point in their plane, facing it (any negative
// cosine between the normals: looser than kPressedCos), and touching its point (a
// face of another part in contact with its own, as an assembly's parts are). The kernel takes
// their in-plane limit, up to the receiver's whole hemisphere, all at its point. The walk cannot
// find them: a cluster in a flat group's plane lies on its horizon and is culled, and a larger one
// holding them can be called hidden by rays, which do not see a limit. So the transport takes them
// for each receiver before its walk, which then skips them. Without this, 2CylinderEngine vertices
// pressed against another part's face (bench/scaling/engine_subset.py ... 20000, `--sky 1`) took
// the sky their rays' origins saw from inside that part: 0.003 where the exact transport has 0.36.
// Sorted per receiver; empty for traced receivers, whose rows take their near patches exactly.
std::vector<std::vector<uint32_t>> pressedPatches(const PatchMesh& mesh, const Occlusion& occlusion, const Receivers& recv,
                                                  const ReceiverGroups& groups, const std::vector<bool>& traced) {
  const size_t nv = recv.point.size();
  std::vector<std::vector<uint32_t>> pressed(nv);
  const double e = occlusion.epsilon();
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nv, 256), [&](const tbb::blocked_range<size_t>& range) {
    std::vector<uint32_t> near;
    for (size_t v = range.begin(); v != range.end(); ++v) {
      if (groups.leafOf[v] == kNoLeaf || (!traced.empty() && traced[v])) continue;
      const Vec3 &p = recv.point[v], &n = recv.normal[v];
      near.clear();
      occlusion.patchesNear(p, 10 * e, near);
      const auto own = recv.ignored(v);  // its own patches and their twins
      for (uint32_t k : near) {
        const Patch& patch = mesh.patches[k];
        if (std::find(own.begin(), own.end(), k) != own.end() || !(dot(patch.normal, n) < 0)) continue;
        if (std::abs(dot(patch.normal, p - mesh.positions[patch.v[0]])) > e) continue;
        if (nearestQuadPoint(corners(mesh, patch), p).distance <= e) pressed[v].push_back(k);
      }
      std::sort(pressed[v].begin(), pressed[v].end());
      pressed[v].erase(std::unique(pressed[v].begin(), pressed[v].end()), pressed[v].end());
    }
  });
  return pressed;
}

// The hierarchical transport: the walk in transport mode over every patch, the exact (receiver,
// patch) pairs by `nearPair` (nearPairs), links stored per receiver group; then closure. The
// receiver groups move into the result.
Hierarchical hierarchicalTransport(const PatchMesh& mesh, const Occlusion& occlusion, const RadiosityOptions& options,
                                   const Receivers& recv, Closure& closure, ReceiverGroups&& groups, const NearPair& nearPair,
                                   TracedBackSides&& traced, std::vector<bool>&& bright, Ticker& ticker) {
  Hierarchical h;
  const size_t nv = recv.point.size(), np = mesh.patches.size();
  h.perPatch = options.method == Method::kConstant;
  std::vector<uint32_t> all(np);
  if (!h.perPatch) h.shapeAreas.resize(np);
  for (size_t p = 0; p < np; ++p) {
    all[p] = uint32_t(p);
    if (!h.perPatch) h.shapeAreas[p] = shapeFunctionAreas(corners(mesh, mesh.patches[p]));
  }
  h.source = patchTree(mesh, all, closure);
  h.normal = recv.normal;
  h.groups = std::move(groups);
  h.rowScale.assign(nv, 0.0);
  h.near.resize(nv);
  // The traced rows are filled before the walk, which adds only their bright emitters.
  h.traced = std::move(traced.traced);
  h.bright = std::move(bright);
  MemoryBudget memory;  // (the traced rows count against it as the walk's rows do)
  memory.limit = options.transportMemoryBytes;
  size_t entries = 0;  // the rows' entries taken before the walk: traced rows, pressed patches
  for (size_t v = 0; v < traced.rows.size(); ++v) {  // (none for the constant method)
    if (traced.rows[v].empty()) continue;
    h.near[v].resize(traced.rows[v].size());
    for (size_t e = 0; e < traced.rows[v].size(); ++e) h.near[v][e] = {traced.rows[v][e].first, float(traced.rows[v][e].second)};
    entries += traced.rows[v].size();
    Row().swap(traced.rows[v]);
  }
  h.pressed = pressedPatches(mesh, occlusion, recv, h.groups, h.traced);
  for (size_t v = 0; v < nv; ++v) {
    if (h.pressed[v].empty()) continue;
    Row row;
    std::vector<uint32_t> ignore;
    for (uint32_t patch : h.pressed[v]) {
      ignore.assign(recv.ignored(v).begin(), recv.ignored(v).end());
      ignore.push_back(0);
      h.nearRays += nearPair(uint32_t(v), patch, ignore, row, nullptr);
    }
    canonicalize(row);
    for (const auto& [col, val] : row) h.near[v].emplace_back(col, float(val));
    entries += row.size();
  }
  memory.add(entries * sizeof(h.near[0][0]));
  h.nearRays += traced.rays;
  h.deferredHidden.resize(h.groups.tasks.size());
  WalkSetup setup{mesh, occlusion, recv, h.groups, h.source, all, false, options.accuracy, memory};
  setup.rowsCoverSky = rowsCoverSky(h, options);
  setup.deferredHidden = &h.deferredHidden;
  setup.pressed = &h.pressed;
  if (!h.traced.empty()) setup.traced = &h.traced, setup.bright = &h.bright;
  walkInto(h, setup, nearPair, ticker);
  closeRows(h, recv, closure);
  return h;
}

// Refinement by light (the BF refinement of Hanrahan, Salzman & Aupperle 1991): the walk judges a
// link by its factor, but what a link's error costs is its factor's error times the light it
// carries. After a first solve, each source cluster's weight is how much brighter its mean radiance
// is than the scene's (at least 1), and every link whose criteria fail with its factor so weighted
// (the error estimate, the rays per receiver, a faint partly hidden link's faintness) is removed
// and walked again from its pair with the weights, every other ray of a link going to a patch drawn
// by its light. So are the pairs the first walk called hidden without their extra rays
// (Hierarchical::deferredHidden), where the source's brightness asks for them. Near pairs and the
// other hidden pairs are kept as they are. Returns the links walked again; the rows are closed
// again by the caller.
size_t refineByLight(Hierarchical& h, const PatchMesh& mesh, const Occlusion& occlusion, const RadiosityOptions& options,
                     const Receivers& recv, const NearPair& nearPair, const std::vector<Vec3>& L, Ticker& ticker) {
  const ClusterTree &S = h.source, &R = h.groups.tree;
  const auto deferred = std::move(h.deferredHidden);  // taken up here or dropped (hidden) on any return
  h.deferredHidden.clear();
  if (S.empty() || R.empty()) return 0;
  // Each patch's light ∫ L dA (the mean of the channels), the source order's running sum of it,
  // and each node's weight.
  const size_t np = mesh.patches.size();
  std::vector<double> light(np);
  for (size_t p = 0; p < np; ++p) {
    if (h.perPatch) {
      light[p] = luminance(L[p]) * mesh.patches[p].area;
      continue;
    }
    for (int j = 0; j < 4; ++j) light[p] += luminance(L[mesh.patches[p].v[j]]) * h.shapeAreas[p][j];
  }
  std::vector<double> lightSum(S.order.size() + 1, 0.0), weight(S.nodes.size(), 1.0);
  for (size_t k = 0; k < S.order.size(); ++k) lightSum[k + 1] = lightSum[k] + std::max(0.0, light[S.order[k]]);
  const double mean = lightSum.back() / S.nodes[0].area;
  if (!(mean > 0)) return 0;
  const double sky = luminance(options.sky) / mean;
  auto brightness = [&](const TreeNode& c) {
    const double own = (lightSum[c.first + c.count] - lightSum[c.first]) / c.area / mean;
    return std::max(own, sky - own);
  };
  for (size_t k = 0; k < S.nodes.size(); ++k) weight[k] = std::max(1.0, brightness(S.nodes[k]));
  // And the brightest patch's, per node.
  const std::vector<double> peak = bottomUp<double>(S, [&](size_t k) { return weight[k]; }, [](double a, double b) { return std::max(a, b); });
  // The links to walk again, per task (tasks own disjoint receiver subtrees).
  const auto& tasks = h.groups.tasks;
  std::vector<std::vector<std::pair<uint32_t, uint32_t>>> starts(tasks.size()), hiddenStarts(tasks.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, tasks.size(), 1), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t task = range.begin(); task != range.end(); ++task)
      for (std::vector<uint32_t> stack{tasks[task]}; !stack.empty();) {
        const uint32_t gi = stack.back();
        stack.pop_back();
        const TreeNode& g = R.nodes[gi];
        for (int c : g.child)
          if (c >= 0) stack.push_back(uint32_t(c));
        auto& list = h.links[gi];
        const size_t before = list.size();
        list.erase(std::remove_if(list.begin(), list.end(), [&](const ClusterLink& link) {
          const double w = weight[link.source];
          if (w <= 1 && (link.visible >= 1 || peak[link.source] <= 1)) return false;
          const LinkEstimate e = linkEstimate(g, S.nodes[link.source], 1);
          const bool redo = e.error * w >= options.accuracy ||
                            (link.visible < 1 ? e.factor * peak[link.source] >= options.accuracy * kFaintShare
                                              : raysPerReceiver(h.groups.siteCount[gi], e.factor * w, kLinkRays) >
                                                    raysPerReceiver(h.groups.siteCount[gi], e.factor, kClusterRays));
          if (redo) {
            starts[task].push_back({gi, link.source});
            h.nodeError[gi] = std::max(0.0, h.nodeError[gi] - e.error);
          }
          return redo;
        }), list.end());
        if (list.size() != before) list.shrink_to_fit();
      }
    // The pairs the first walk called hidden on their link rays alone: walked again where the
    // extra rays their factor asks for (kHiddenRays) are asked by it times their source's
    // brightness. A wrong hidden verdict loses about the factor over the rays of the source's
    // light; tracing them all in the first walk spent two thirds of the hidden verdicts' rays in
    // the Blender room, nearly all on the dark insides of its open, double-sided Suzannes.
    for (size_t task = range.begin(); task != range.end(); ++task)
      for (const auto& [gi, ci] : deferred[task]) {
        const TreeNode &g = R.nodes[gi], &c = S.nodes[ci];
        const double plain = linkEstimate(g, c, 1).factor, factor = plain * brightness(c);
        if (hiddenRaysPerReceiver(factor) > raysPerReceiver(g.count, factor, kClusterRays) ||
            raysPerReceiver(g.count, factor, kLinkRays) > raysPerReceiver(g.count, plain, kClusterRays))
          hiddenStarts[task].push_back({gi, ci});
      }
  });
  size_t walks = 0, redone = 0;  // pairs walked again, of them links
  for (size_t task = 0; task < tasks.size(); ++task) {
    walks += starts[task].size() + hiddenStarts[task].size();
    redone += starts[task].size();
  }
  if (walks == 0) return 0;
  std::vector<uint32_t> all(np);
  for (size_t p = 0; p < np; ++p) all[p] = uint32_t(p);
  MemoryBudget memory;
  if (options.transportMemoryBytes != SIZE_MAX) memory.limit = options.transportMemoryBytes - std::min(options.transportMemoryBytes, h.bytes());
  WalkSetup setup{mesh, occlusion, recv, h.groups, S, all, false, options.accuracy, memory};
  setup.rowsCoverSky = rowsCoverSky(h, options);
  setup.weight = &weight;
  setup.lightSum = &lightSum;
  setup.peak = &peak;
  setup.starts = &starts;
  setup.hiddenStarts = &hiddenStarts;
  setup.pressed = &h.pressed;
  if (!h.traced.empty()) setup.traced = &h.traced, setup.bright = &h.bright;
  walkInto(h, setup, nearPair, ticker);
  return redone;
}

// Constant method: F_kl (exact near, Gauss far to `tolerance`: see constantPatchFactor) times a
// visible fraction from rays between the two patches; 0 unless each has something in front of the
// other. Counts its rays.
double constantPairFactor(const PatchMesh& mesh, const Occlusion& occlusion, size_t k, size_t l, double tolerance, size_t& rays) {
  const Patch &pk = mesh.patches[k], &pl = mesh.patches[l];
  const auto qk = corners(mesh, pk), ql = corners(mesh, pl);
  bool facing = false, front = false;
  for (const Vec3& c : ql) facing |= dot(pk.normal, c - qk[0]) > occlusion.epsilon();
  for (const Vec3& c : qk) front |= dot(pl.normal, c - ql[0]) > occlusion.epsilon();
  if (!facing || !front) return 0;
  const double f = constantPatchFactor(qk, ql, tolerance);
  if (!(f > 0)) return 0;
  // Visible fraction: five rays from the receiver's centre first; if they disagree, 5×5
  // rays between inner points of both patches.
  // The two patches and the receiver's twin never block. (The source's twin does: a receiver
  // sees the back of a double-sided surface only from the back.)
  const Vec3 lift = pk.normal * (occlusion.epsilon() * 10);
  const uint32_t pair[3] = {uint32_t(k), uint32_t(l), pk.twin >= 0 ? uint32_t(pk.twin) : uint32_t(k)};
  const uint32_t self[1] = {uint32_t(k)};
  auto ray = [&](int a, int b) {
    ++rays;
    const Sight sight{occlusion, mesh, pointOnPatch(qk, kProbe[a][0], kProbe[a][1]) + lift, pair, self};
    return sight.visible(pointOnPatch(ql, kProbe[b][0], kProbe[b][1]) + pl.normal * (occlusion.epsilon() * 10));
  };
  int seen = 0;
  for (int b = 0; b < 5; ++b) seen += ray(0, b);
  if (seen == 5) return f;
  if (seen == 0) return 0;
  seen = 0;
  for (int a = 0; a < 5; ++a)
    for (int b = 0; b < 5; ++b) seen += ray(a, b);
  return f * (seen / 25.0);
}

// The share of patch k's hemisphere that patch l covers, seen from either side (constant method):
// l's factor from k times the share of five probes on it seen from k's centre. Counts its rays.
double constantCover(const PatchMesh& mesh, const Occlusion& occlusion, size_t k, size_t l, double tolerance, bool backsOnly,
                     size_t& rays) {
  const Patch& pk = mesh.patches[k];
  const auto qk = corners(mesh, pk);
  const uint32_t twin = pk.twin >= 0 ? uint32_t(pk.twin) : uint32_t(k);
  // Covering is geometry: a double-sided surface covers once (its front), and a patch's twin
  // covers nothing of it.
  if (l == k || l == twin || mesh.patches[l].backSide) return 0;
  auto ql = corners(mesh, mesh.patches[l]);
  // Nothing of l above k's plane, or k in l's plane: l covers nothing of k's hemisphere (the
  // factor is 0; the transport's own rejections, without which the coplanar patches of a
  // plate took most of the pass: 126 s against 26 s for the transport at 1,152 patches).
  bool above = false, inPlane = true;
  for (const Vec3& c : ql) above |= dot(pk.normal, c - qk[0]) > occlusion.epsilon();
  for (const Vec3& c : qk) inPlane &= std::abs(dot(mesh.patches[l].normal, c - ql[0])) <= occlusion.epsilon();
  if (!above || inPlane) return 0;
  Vec3 toward = mesh.patches[l].normal;  // l's side that k sees
  const bool behind = dot(mesh.patches[l].normal, pointOnPatch(qk, 0, 0) - ql[0]) < 0;
  // With `backsOnly`, l seen from its front covers nothing here: the hierarchical transport's rows
  // hold it (skyFromRows).
  if (backsOnly && !behind) return 0;
  if (behind) {
    std::swap(ql[1], ql[3]);
    toward = -toward;
  }
  const double f = constantPatchFactor(qk, ql, tolerance);
  if (!(f > 0)) return 0;
  int seen = 0;
  const uint32_t ignore[3] = {uint32_t(k), uint32_t(l), twin};
  const uint32_t self[1] = {uint32_t(k)};
  const Sight sight{occlusion, mesh, pointOnPatch(qk, 0, 0) + pk.normal * (occlusion.epsilon() * 10), ignore, self};
  // The probes lifted off l on k's side, as in the transport: on l's plane itself they ended
  // on l's double-sided twin, which blocked some of them by rounding (a white double-sided
  // tray under a sky of 1 went 1.9% too bright at N = 2, 3.6% at N = 4).
  const Vec3 lift = toward * (occlusion.epsilon() * 10);
  for (const auto& b : kProbe) seen += sight.visible(pointOnPatch(ql, b[0], b[1]) + lift);
  rays += 5;
  return f * seen / 5.0;
}

// The relative tolerance of the near kernels (bilinear) or patch factors (constant) of a walk at
// `accuracy`, or of the exact transport (accuracy 0): a share of the accuracy, never finer than
// the exact transport's (the constant method's factors to a tenth of kernelTolerance).
double pairTolerance(Method method, double kernelTolerance, double accuracy) {
  return std::max(method == Method::kConstant ? 0.1 * kernelTolerance : kernelTolerance, accuracy * kNearKernelShare);
}

// The (receiver, patch) pairs of either method, for the exact transport (accuracy 0) or a walk at
// `accuracy`: kernels or factors to pairTolerance, and for a walk one ray for a faint bilinear pair
// (pairVisibility). The functions keep references to mesh, occlusion and recv.
NearPair nearPairs(const PatchMesh& mesh, const Occlusion& occlusion, const Receivers& recv, Method method,
                   double kernelTolerance, double accuracy) {
  const double tolerance = pairTolerance(method, kernelTolerance, accuracy), faint = accuracy * kFaintPairShare;
  if (method == Method::kConstant)
    return [&mesh, &occlusion, tolerance](uint32_t k, uint32_t patch, std::vector<uint32_t>&, Row& row, const SharedSight*) {
      size_t rays = 0;
      const double f = constantPairFactor(mesh, occlusion, k, patch, tolerance, rays);
      if (f > 0) row.emplace_back(patch, f);
      return rays;
    };
  KernelOptions kernel;
  kernel.relativeTolerance = tolerance;
  return [&mesh, &occlusion, &recv, kernel, faint, emission = meanEmission(mesh)](uint32_t v, uint32_t patch, std::vector<uint32_t>& ignore,
                                                                                  Row& row, const SharedSight* shared) {
    const double weight = emissionWeight(mesh.patches[patch], emission);
    return addPatchKernel(mesh, occlusion, recv, kernel, v, patch, ignore, row, {faint / weight, kVisibilityPiece / weight}, shared);
  };
}

CoverPair coverPairs(const PatchMesh& mesh, const Occlusion& occlusion, const Receivers& recv, Method method,
                     double kernelTolerance, double accuracy, bool backsOnly) {
  const double tolerance = pairTolerance(method, kernelTolerance, accuracy), faint = accuracy * kFaintPairShare;
  if (method == Method::kConstant)
    return [&mesh, &occlusion, tolerance, backsOnly](uint32_t k, uint32_t patch, std::vector<uint32_t>&, size_t& rays) {
      return constantCover(mesh, occlusion, k, patch, tolerance, backsOnly, rays);
    };
  KernelOptions kernel;
  kernel.relativeTolerance = tolerance;
  return [&mesh, &occlusion, &recv, kernel, faint, backsOnly](uint32_t v, uint32_t patch, std::vector<uint32_t>& ignore,
                                                              size_t& rays) {
    return skyCover(mesh, occlusion, recv, kernel, v, patch, ignore, {faint, kVisibilityPiece}, backsOnly, rays);
  };
}

// The exact transport: row i holds what receiver i takes from every patch on its side of every
// closed surface (nearPair: the bilinear method's K_ij, the constant method's F_kl).
Transport exactTransport(const PatchMesh& mesh, const Occlusion& occlusion, std::shared_ptr<const Receivers> recv,
                         std::shared_ptr<const Closure> closure, NearPair nearPair) {
  Transport t;
  t.rows = recv->point.size();
  const Bounds bounds = sceneBounds(mesh);
  t.build = [&mesh, &occlusion, recv, closure, bounds, nearPair](size_t i, Row& row) {
    if (facesNothing(bounds, recv->point[i], recv->normal[i], occlusion.epsilon())) return;
    std::vector<uint32_t> ignore(recv->ignored(i).begin(), recv->ignored(i).end());
    ignore.push_back(0);  // the source patch, set per source
    for (size_t source = 0; source < mesh.patches.size(); ++source)
      if (!closure->separates(i, source)) nearPair(uint32_t(i), uint32_t(source), ignore, row, nullptr);
    canonicalize(row);
  };
  return t;
}

// The part of each receiver's projected solid angle that no surface covers, front or back: what a
// uniform sky lights. Every patch's cover (coverPair), summed.
std::vector<double> exactSkyFractions(const PatchMesh& mesh, const Receivers& recv, const std::vector<bool>& enclosed,
                                      const CoverPair& coverPair, Ticker& ticker) {
  std::vector<double> sky(recv.point.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, sky.size(), 8), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t i = range.begin(); i != range.end(); ++i) {
      if (enclosed[i]) continue;  // covered whole: no sky
      double covered = 0;
      std::vector<uint32_t> ignore(recv.ignored(i).begin(), recv.ignored(i).end());
      ignore.push_back(0);
      size_t rays = 0;  // not reported by the exact transport
      for (size_t source = 0; source < mesh.patches.size(); ++source) covered += coverPair(uint32_t(i), uint32_t(source), ignore, rays);
      sky[i] = std::max(0.0, 1 - covered);
    }
    ticker.add(range.size());
  });
  return sky;
}

// What every unknown gathers from the current L: (K L)_i, into `gathered`.
using Gather = std::function<void(const std::vector<Vec3>& L, std::vector<Vec3>& gathered)>;

Gather exactGather(const Transport& K) {
  return [&K](const std::vector<Vec3>& L, std::vector<Vec3>& gathered) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, gathered.size(), K.stored() ? 256 : 8), [&](const tbb::blocked_range<size_t>& range) {
      Row row;
      for (size_t i = range.begin(); i != range.end(); ++i) {
        Vec3 h{};
        if (K.stored()) {
          for (size_t e = K.start[i]; e < K.start[i + 1]; ++e) h += L[K.column[e]] * K.value[e];
        } else {
          row.clear();
          K.build(i, row);
          for (const auto& [c, v] : row) h += L[c] * v;
        }
        gathered[i] = h;
      }
    });
  };
}

Gather hierarchicalGather(const Hierarchical& H, const PatchMesh& mesh) {
  return [&H, &mesh](const std::vector<Vec3>& L, std::vector<Vec3>& gathered) {
    const std::vector<Vec3> far = gatherFar(H, clusterMoments(H, mesh, L));
    tbb::parallel_for(tbb::blocked_range<size_t>(0, gathered.size(), 256), [&](const tbb::blocked_range<size_t>& range) {
      for (size_t i = range.begin(); i != range.end(); ++i) {
        Vec3 h = far[i] * H.farScale[i];
        for (const auto& [column, value] : H.near[i]) h += L[column] * value;
        // Never below zero: a far field's first-order expansion errs a little at a receiver that
        // sees almost nothing, and went to -0.8% of the mean radiance at floor vertices deep under
        // the Cornell box's blocks once refinement made patches there (the exact rows give 0).
        gathered[i] = Vec3{std::max(h.x, 0.0), std::max(h.y, 0.0), std::max(h.z, 0.0)} * H.rowScale[i];
      }
    });
  };
}

// The hierarchical transport's sky fractions: what each unknown's row leaves of its hemisphere,
// 1 − (K 1)_i, less what one-sided patches seen from behind cover (hierarchicalCover). The sky
// and K then agree on what covers a receiver to rounding, whatever the links err: a white scene
// under a sky of 1 is 1, and a row's error moves its sky the other way, so the two mostly cancel.
// Until the seventeenth session the sky was a walk of its own over every patch, two thirds of the
// whole 2CylinderEngine's bake. Enclosed unknowns see no sky; traced ones what their rays leave by.
std::vector<double> skyFromRows(const Gather& gather, const std::vector<double>& backCover, const std::vector<bool>& enclosed,
                                const std::vector<bool>& traced, const std::vector<double>& open) {
  const size_t n = enclosed.size();
  std::vector<Vec3> rowSum(n);
  gather(std::vector<Vec3>(n, Vec3{1, 1, 1}), rowSum);
  std::vector<double> sky(n, 0.0);
  for (size_t i = 0; i < n; ++i) {
    if (enclosed[i]) continue;
    sky[i] = !traced.empty() && traced[i] ? open[i] : std::max(0.0, 1 - rowSum[i].x - backCover[i]);
  }
  return sky;
}

// Σ_i a_i · b_i over the three channels, summed in fixed blocks and then in block order, so that
// it has the same bits for any thread count.
double blockDot(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  constexpr size_t kBlock = 4096;
  std::vector<double> part((a.size() + kBlock - 1) / kBlock, 0.0);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, part.size()), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t k = range.begin(); k != range.end(); ++k) {
      double s = 0;
      for (size_t i = k * kBlock; i < std::min(a.size(), (k + 1) * kBlock); ++i) s += dot(a[i], b[i]);
      part[k] = s;
    }
  });
  double sum = 0;
  for (double s : part) sum += s;
  return sum;
}

// The Jacobi image G(L) = L⁰ + ρ ⊙ (K L) mixed with the last kMixDepth images (Anderson
// acceleration, Walker & Ni 2011): L ← G(L) − Σ_j γ_j ΔG_j, with γ the least-squares fit of the
// residual G(L) − L by the residuals' last changes ΔF_j. On a linear map it is GMRES in disguise:
// Jacobi's error falls as the light's slowest mode (the spectral radius of ρK, 0.7–0.9 in rooms),
// the mixing takes that mode out. Issue 16's Blender room: 45 gathers → 23 (the bake 104.5 → 95.6 s,
// fastest of two alternating runs); Cornell box N = 20: 18 → 11. It keeps 2 kMixDepth + 3 more
// vectors of the unknowns (216 MB at a million). The stop test is unchanged (each residual is
// G(L) − L of the L it was taken at), and what is returned is a plain Jacobi image, G(L) of the
// last L: never below L⁰, whatever the mixing did.
constexpr int kMixDepth = 3;
// A history whose normal equations are this ill-conditioned (relative pivot) is dropped and begun
// again: its changes have become nearly parallel and the fit would amplify rounding.
constexpr double kMixPivot = 1e-10;

// Jacobi iteration L ← L⁰ + ρ ⊙ (K L), mixed as above: every row independent, so parallel, and the
// mixing's sums in a fixed order, so bit-identical for any thread count. Converges for ρ < 1 (each
// row of K sums to at most 1).
// Starts from L where it holds one value per unknown (a warm start), else from the emission; stops at
// a relative residual of `residualGoal` and reports progress from `from` to `to`. Stops early,
// not converged, once the residual's fall over the last kRateWindow iterations, kept up, would not
// reach the goal within maxIterations: the fall only slows toward the spectral radius, so that
// forecast is optimistic and a solve that would converge is never cut. A closed box of ρ = 1 (no
// steady state) ran all 10,000 iterations, minutes once refinement gave it 20k patches.
constexpr int kRateWindow = 100;
void iterate(const Gather& gather, const std::vector<Vec3>& emission, const std::vector<Vec3>& reflectance,
             const RadiosityOptions& options, double residualGoal, double from, double to, std::vector<Vec3>& L,
             std::vector<Vec3>& gathered, Solution& solution) {
  const size_t n = emission.size();
  if (L.size() != n) L = emission;
  gathered.assign(n, Vec3{});
  double scale = 0;
  for (const Vec3& e : emission) scale = std::max({scale, std::abs(e.x), std::abs(e.y), std::abs(e.z)});
  if (scale == 0) return;  // no emitter: black is the answer
  std::vector<Vec3> next(n), f(n), lastImage, lastResidual;
  std::vector<double> rowChange(n);
  std::vector<double> history;  // the residual after each iteration
  // The last kMixDepth changes of the residual and of the image, oldest first.
  std::vector<std::vector<Vec3>> dF, dG;
  for (int it = 1; it <= options.maxIterations; ++it) {
    gather(L, gathered);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1024), [&](const tbb::blocked_range<size_t>& range) {
      for (size_t i = range.begin(); i != range.end(); ++i) {
        const Vec3& h = gathered[i];
        next[i] = emission[i] + Vec3{reflectance[i].x * h.x, reflectance[i].y * h.y, reflectance[i].z * h.z};
        f[i] = next[i] - L[i];
        rowChange[i] = std::max({std::abs(f[i].x), std::abs(f[i].y), std::abs(f[i].z)});
      }
    });
    const double residual = *std::max_element(rowChange.begin(), rowChange.end()) / scale;
    ++solution.iterations;
    solution.residual = residual;
    if (options.progress) options.progress(from + (to - from) * std::min(1.0, std::log(residual) / std::log(residualGoal)));
    bool stop = residual <= residualGoal || it == options.maxIterations;
    history.push_back(residual);
    if (!stop && it > kRateWindow && residual > 0) {
      const double rate = std::pow(residual / history[size_t(it - 1 - kRateWindow)], 1.0 / kRateWindow);
      stop = !(rate < 1) || it + std::log(residualGoal / residual) / std::log(rate) > options.maxIterations;
    }
    if (stop) {
      L.swap(next);
      break;
    }
    // The history's newest changes (a full history drops its oldest and reuses its storage), then
    // the fit of f by them (the normal equations, by Gaussian elimination: kMixDepth unknowns).
    if (!lastImage.empty()) {
      if (dF.size() == size_t(kMixDepth)) {
        std::rotate(dF.begin(), dF.begin() + 1, dF.end());
        std::rotate(dG.begin(), dG.begin() + 1, dG.end());
      } else {
        dF.emplace_back(n);
        dG.emplace_back(n);
      }
      tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1024), [&](const tbb::blocked_range<size_t>& range) {
        for (size_t i = range.begin(); i != range.end(); ++i) {
          dF.back()[i] = f[i] - lastResidual[i];
          dG.back()[i] = next[i] - lastImage[i];
        }
      });
    }
    lastImage = next;
    lastResidual = f;
    const size_t m = dF.size();
    std::array<double, kMixDepth> gamma{};
    bool mixed = m > 0;
    if (mixed) {
      std::array<std::array<double, kMixDepth + 1>, kMixDepth> a{};
      for (size_t j = 0; j < m; ++j) {
        for (size_t k = j; k < m; ++k) a[j][k] = a[k][j] = blockDot(dF[j], dF[k]);
        a[j][m] = blockDot(dF[j], f);
      }
      double largest = 0;
      for (size_t j = 0; j < m; ++j) largest = std::max(largest, a[j][j]);
      for (size_t j = 0; j < m && mixed; ++j) {
        if (!(a[j][j] > kMixPivot * largest)) {
          mixed = false;
          break;
        }
        for (size_t k = j + 1; k < m; ++k) {
          const double r = a[k][j] / a[j][j];
          for (size_t c = j; c <= m; ++c) a[k][c] -= r * a[j][c];
        }
      }
      for (size_t j = m; mixed && j-- > 0;) {
        double s = a[j][m];
        for (size_t k = j + 1; k < m; ++k) s -= a[j][k] * gamma[k];
        gamma[j] = s / a[j][j];
      }
    }
    if (!mixed) {
      dF.clear();
      dG.clear();
    }
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1024), [&](const tbb::blocked_range<size_t>& range) {
      for (size_t i = range.begin(); i != range.end(); ++i) {
        Vec3 x = next[i];
        if (mixed)
          for (size_t j = 0; j < m; ++j) x -= dG[j][i] * gamma[j];
        L[i] = x;
      }
    });
  }
  solution.converged = solution.residual <= residualGoal;
}

// Irradiance at x (normal n) from the punctual lights, shadowed (KHR_lights_punctual: intensity
// in candela for point and spot lights, illuminance in lux for directional ones; the spec's spot
// cone and range falloff).
Vec3 directIrradiance(const std::vector<PunctualLight>& lights, const Sight& sight, const Vec3& x, const Vec3& n) {
  Vec3 e{};
  for (const PunctualLight& light : lights) {
    Vec3 toLight;
    double falloff = 1;
    if (light.type == PunctualLight::Type::kDirectional) {
      toLight = -light.direction;
    } else {
      const Vec3 d = light.position - x;
      const double r2 = dot(d, d);
      if (!(r2 > 0)) continue;
      toLight = d / std::sqrt(r2);
      falloff = 1 / r2;
      if (light.range > 0) {
        const double q = r2 * r2 / std::pow(light.range, 4);
        falloff *= std::pow(std::clamp(1 - q, 0.0, 1.0), 2);
      }
      if (light.type == PunctualLight::Type::kSpot) {
        const double cosOuter = std::cos(light.outerCone), cosInner = std::cos(light.innerCone);
        const double scale = 1 / std::max(0.001, cosInner - cosOuter);
        const double t = std::clamp((dot(-toLight, light.direction) - cosOuter) * scale, 0.0, 1.0);
        falloff *= t * t;
      }
    }
    const double cosine = dot(n, toLight);
    if (!(cosine > 0) || !(falloff > 0)) continue;
    const Vec3 target = light.type == PunctualLight::Type::kDirectional
                            ? sight.from + toLight * (10 * sight.occlusion.sceneSize())
                            : light.position;
    if (!sight.visible(target)) continue;
    e += light.intensity * (cosine * falloff);
  }
  return e;
}

// Direct light from the punctual lights, as the radiance it adds: ρ E / π per unknown.
std::vector<Vec3> bilinearDirectLight(const Scene& scene, const PatchMesh& mesh, const Occlusion& occlusion,
                                      const Receivers& recv) {
  std::vector<Vec3> e(mesh.positions.size());
  if (scene.lights.empty()) return e;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, e.size(), 64), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t i = range.begin(); i != range.end(); ++i)
      e[i] = directIrradiance(scene.lights, Sight{occlusion, mesh, recv.origin[i], recv.ignored(i), recv.own(i)},
                              recv.point[i], recv.normal[i]);
  });
  return e;
}

std::vector<Vec3> constantDirectLight(const Scene& scene, const PatchMesh& mesh, const Occlusion& occlusion) {
  std::vector<Vec3> e(mesh.patches.size());
  if (scene.lights.empty()) return e;
  constexpr double kNode[3] = {-0.7745966692414834, 0, 0.7745966692414834};
  constexpr double kWeight[3] = {5.0 / 9, 8.0 / 9, 5.0 / 9};
  tbb::parallel_for(tbb::blocked_range<size_t>(0, e.size(), 16), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t k = range.begin(); k != range.end(); ++k) {
      const Patch& patch = mesh.patches[k];
      const auto q = corners(mesh, patch);
      const uint32_t self[1] = {uint32_t(k)};
      Vec3 sum{};
      double area = 0;
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) {
          const double s = kNode[a], t = kNode[b];
          const Vec3 ds = (q[1] - q[0]) * (1 - t) / 4 + (q[2] - q[3]) * (1 + t) / 4;
          const Vec3 dt = (q[3] - q[0]) * (1 - s) / 4 + (q[2] - q[1]) * (1 + s) / 4;
          const double w = kWeight[a] * kWeight[b] * length(cross(ds, dt));
          const Vec3 x = pointOnPatch(q, s, t);
          const Sight sight{occlusion, mesh, x + patch.normal * (occlusion.epsilon() * 10), self, self};
          sum += directIrradiance(scene.lights, sight, x, patch.normal) * w;
          area += w;
        }
      e[k] = area > 0 ? sum / area : Vec3{};
    }
  });
  return e;
}

std::vector<Vec3> withDirectLight(std::vector<Vec3> source, const std::vector<Vec3>& reflectance,
                                  const std::vector<Vec3>& irradiance) {
  for (size_t i = 0; i < source.size(); ++i)
    source[i] += Vec3{reflectance[i].x * irradiance[i].x, reflectance[i].y * irradiance[i].y,
                      reflectance[i].z * irradiance[i].z} / kPi;
  return source;
}

// The share of the progress that the sky pass takes, before the transport's: the exact transport's
// (every pair once more) and the constant method's (a cover walk over every patch), the bilinear
// method's hierarchical one (the walk of the backs, hierarchicalCover).
constexpr double kSkyProgress = 0.3;
constexpr double kBackCoverProgress = 0.1;
// The hierarchical transport's progress: its walk ends at the first, the first solve at the second,
// the refinement's walk at the third; the final solve takes the rest.
constexpr double kRefineProgress[3] = {0.7, 0.8, 0.9};
// The first solve, which only needs to show where the light is, stops at this relative residual.
constexpr double kFirstResidual = 1e-2;

// The source term: emission plus, with a sky, the reflected sky light ρ · (uncovered fraction) · sky.
std::vector<Vec3> withSky(const std::vector<Vec3>& emission, const std::vector<Vec3>& reflectance,
                          const RadiosityOptions& options, const std::vector<double>& sky) {
  if (!hasSky(options) || sky.empty()) return emission;
  std::vector<Vec3> source = emission;
  for (size_t i = 0; i < source.size(); ++i)
    source[i] += Vec3{reflectance[i].x * options.sky.x, reflectance[i].y * options.sky.y, reflectance[i].z * options.sky.z} * sky[i];
  return source;
}

bool anyLight(const std::vector<Vec3>& source) {
  return std::any_of(source.begin(), source.end(), [](const Vec3& v) { return v.x != 0 || v.y != 0 || v.z != 0; });
}

// Whether light passes a cut-out patch at Embree's quad coordinates (u, v): the base color alpha
// (factor × texture at the interpolated UV) below the material's cutoff.
bool passesCutout(const Scene& scene, const PatchMesh& mesh, uint32_t patch, double u, double v) {
  if (patch >= mesh.patches.size() || mesh.patches[patch].mask < 0) return false;
  const PatchMask& mask = mesh.masks[mesh.patches[patch].mask];
  double w[4];
  if (u + v <= 1) {  // triangle v0 v1 v3
    w[0] = 1 - u - v; w[1] = u; w[2] = 0; w[3] = v;
  } else {           // triangle v2 v3 v1
    w[0] = 0; w[1] = 1 - v; w[2] = u + v - 1; w[3] = 1 - u;
  }
  double tu = 0, tv = 0;
  for (int k = 0; k < 4; ++k) {
    tu += w[k] * mask.uv[k][0];
    tv += w[k] * mask.uv[k][1];
  }
  return mask.baseAlpha * sampleAlpha(scene, mask.texture, tu, tv) < mask.cutoff;
}

// What refinement measures of a patch: how far the bilinear interpolation of the direct light
// (emitting patches: exact factors, visibility in pieces of a tenth of the transport's; punctual
// lights, shadowed; a uniform sky, skyOpenness) between points just inside its corners misses it at its centre
// and edge midpoints (the largest, times ρ, channels averaged), and the light's mean over it.
// Visibility at the transport's piece size left the measure's own estimation error (a few per
// cent) above a 1% target forever.
struct PatchLight {
  double error = 0, level = 0;
  double nearError = 0;  // the same for the open share of the near hemisphere (nearOpenness), times ρ
  // Second phase: the same for the direct light plus the first bounce's light gathered by rays
  // (less twice their noise), and their mean.
  double bounceError = 0, bounceLevel = 0;
  std::array<double, 4> corner{};  // the direct light's values at the corners (covered ones filled in)
  bool dark = false;     // inside a dark room (the inside of a closed double-sided object) or covered: never seen lit
  // What was measured at each sample (direct light times ρ, near openness times ρ, covered): the
  // second phase gathers the first bounce at the same points and takes these from the first
  // phase's measure of the same patch instead of measuring them again (its first round measures
  // every patch the first phase left: a third of the second phase's measure on the Cornell box).
  std::array<double, 9> value{}, open{};
  std::array<bool, 9> hidden{};
  bool sampled = false;
};

// The indirect light a point takes is lowest where nearby surfaces close its hemisphere: at a
// block's foot, in a corner, under a ledge. So the measure also interpolates the share of 16
// fixed, cosine-distributed directions that leave a radius of kNearRadius × the scene size
// without hitting anything: a floor cell straddling the footprint of a block standing in shadow
// has no direct light on either side, and only this sees it (Cornell box, floor points 1.3 cm
// from a block in its shadow: −37% refined by the direct light alone, −2% at a uniform N = 24).
constexpr double kNearRadius = 0.05;
// The share of S × S such directions that leave `radius` without hitting anything or, with
// `glowIsOpen`, hit an emitting surface first (it brings light, not shade).
template <int S>
double openness(const Sight& sight, const Vec3& n, double radius, bool glowIsOpen) {
  const auto [t, b] = tangentFrame(n);
  constexpr int kRays = S * S;
  std::array<Vec3, kRays> to;
  for (int k = 0; k < kRays; ++k) to[k] = sight.from + malleyDirection<S>(k, t, b, n) * radius;
  int through = 0;
  for (int first = 0; first < kRays; first += 16) {  // visibleAll takes up to 16
    bool seen[16];
    sight.visibleAll(std::span(to.data() + first, 16), seen);
    for (int k = 0; k < 16; ++k) {
      if (!seen[k] && glowIsOpen) {
        const Vec3& end = to[first + k];
        int64_t hit = sight.occlusion.firstHit(sight.from, end, sight.ignore);
        if (hit >= 0) hit = facingSide(sight.mesh, hit, end - sight.from);
        seen[k] = hit >= 0 && luminance(sight.mesh.patches[hit].emission) > 0;
      }
      through += seen[k];
    }
  }
  return double(through) / kRays;
}
// The near hemisphere counts a direction closed by an emitting surface as open: without that every
// edge of a furnace (a closed box, all of it emitting, uniform in its light) was split to the
// finest cells, and the 12-triangle test cube took 120 s to reach 20k patches for nothing.
double nearOpenness(const Sight& sight, const Vec3& n, double radius) { return openness<4>(sight, n, radius, true); }

// An emitting polygon as the measure sees it: a whole uniformly emitting face (its n × n grid of
// level-0 cells, one polygon: a Cornell box light at --subdivide 8 is one source instead of 64, and
// visibleFraction's pieces resolve it as finely), or a single emitting patch. Taken from the mesh
// refinement starts from: splitting an emitter does not change its light, and a lamp split to the
// finest cells along its rim was hundreds of polygons for every sample (97 of 110 s on the lamp
// room in the second phase; its first phase measured every patch again each time the emitters
// changed).
struct Emitter {
  std::array<Vec3, 4> q;
  Vec3 normal;
  double emission = 0;  // luminance
};

std::vector<Emitter> measuredEmitters(const PatchMesh& mesh) {
  // Group emitting patches by face and side; a group becomes one polygon when it is exactly the
  // face's n × n grid at level 0 with one emission (its corners from the grid's corner cells).
  std::map<std::tuple<int, int, bool>, std::vector<uint32_t>> faces;
  std::vector<Emitter> out;
  for (size_t k = 0; k < mesh.patches.size(); ++k) {
    const Patch& p = mesh.patches[k];
    if (!(luminance(p.emission) > 0)) continue;
    if (p.cell.primitive >= 0) faces[{p.cell.primitive, p.cell.face, p.backSide}].push_back(uint32_t(k));
    else out.push_back({corners(mesh, p), p.normal, luminance(p.emission)});
  }
  for (const auto& [key, group] : faces) {
    int n = 0;
    bool grid = true;
    for (uint32_t k : group) {
      const Patch& p = mesh.patches[k];
      grid &= p.cell.level == 0 && p.emission == mesh.patches[group[0]].emission;
      n = std::max({n, p.cell.i + 1, p.cell.j + 1});
    }
    grid &= group.size() == size_t(n) * size_t(n);
    std::array<uint32_t, 4> corner{};  // the patches at the grid's four corners
    int found = 0;
    for (uint32_t k : group) {
      const Cell& c = mesh.patches[k].cell;
      for (int e = 0; e < 4; ++e)
        if (c.i == (e == 1 || e == 2 ? n - 1 : 0) && c.j == (e >= 2 ? n - 1 : 0)) {
          corner[e] = k;
          found |= 1 << e;
        }
    }
    const bool backSide = std::get<2>(key);
    if (grid && found == 15 && !backSide) {
      const Patch& first = mesh.patches[group[0]];
      std::array<Vec3, 4> q;
      for (int e = 0; e < 4; ++e) q[e] = mesh.positions[mesh.patches[corner[e]].v[e]];
      out.push_back({q, first.normal, luminance(first.emission)});
    } else {
      for (uint32_t k : group) out.push_back({corners(mesh, mesh.patches[k]), mesh.patches[k].normal, luminance(mesh.patches[k].emission)});
    }
  }
  return out;
}

// The sky's direct light at a point, as the measure sees it: the sky's luminance times the share
// of 64 cosine-distributed directions that leave the scene (a step of 1/64 between neighbouring
// samples stays below a 2% target on a floor that sees most of the sky; 16 directions' 1/16 did not).
double skyOpenness(const Sight& sight, const Vec3& n) { return openness<8>(sight, n, 2 * sight.occlusion.sceneSize(), false); }

// The light surfaces reflect once (the direct light, times ρ) as refinement's second phase sees
// it: the corner values of each patch of the mesh the first phase left (PatchLight::corner), and
// an occlusion over that mesh. Later rounds go on splitting it; the samples of a new patch lie on
// the same surfaces, so rays from them (a little off the surface, without an ignore list) meet
// that mesh where they would meet the new one.
struct BounceField {
  const PatchMesh& mesh;
  const Occlusion& occlusion;
  std::vector<std::array<double, 4>> corner;
};
// That light gathered at a point: its mean where 64 fixed cosine-distributed rays first meet a
// surface (bilinear over the patch met), and the variance of that mean (the rays taken as
// independent: they are stratified, so it errs on the safe side).
struct Gathered {
  double mean = 0, variance = 0;
};

Gathered gatherBounce(const BounceField& field, const Vec3& from, const Vec3& n) {
  const PatchMesh& mesh = field.mesh;
  const auto [t, b] = tangentFrame(n);
  constexpr int S = 8, kRays = S * S;
  const double reach = 2 * field.occlusion.sceneSize();
  double sum = 0, squares = 0;
  std::array<Vec3, kRays> dirs, ends;
  std::array<int64_t, kRays> hits;
  for (int k = 0; k < kRays; ++k) {
    dirs[k] = malleyDirection<S>(k, t, b, n);
    ends[k] = from + dirs[k] * reach;
  }
  field.occlusion.firstHits(from, ends, {}, hits.data());
  for (int k = 0; k < kRays; ++k) {
    const Vec3& d = dirs[k];
    int64_t hit = hits[k];
    if (hit < 0) continue;  // the sky is direct light
    hit = facingSide(mesh, hit, d);
    if (hit < 0) continue;
    const auto w = shapeFunctionsAlong(mesh, mesh.patches[hit], from, d);
    double value = 0;
    for (int j = 0; j < 4; ++j) value += w[j] * field.corner[hit][j];
    value = std::max(0.0, value);
    sum += value;
    squares += value * value;
  }
  const double mean = sum / kRays;
  return {mean, std::max(0.0, squares / kRays - mean * mean) / (kRays - 1)};
}

// `prior` (the second phase): per patch of `which`, the first phase's measure of it, or null.
// `ticker` counts the patches measured.
std::vector<PatchLight> measureLight(const Scene& scene, const PatchMesh& mesh, const std::vector<uint32_t>& which,
                                     const std::vector<Emitter>& emitters, double sky, const BounceField* bounce,
                                     const std::vector<const PatchLight*>& prior, Ticker& ticker) {
  std::vector<PatchLight> out(which.size());
  if ((emitters.empty() && scene.lights.empty() && !(sky > 0)) || which.empty()) return out;
  Occlusion occlusion(mesh);
  if (!mesh.masks.empty()) occlusion.setCutouts([&](uint32_t patch, double u, double v) { return passesCutout(scene, mesh, patch, u, v); });
  const auto closure = makeClosure(scene, mesh, Method::kBilinear);
  // Points just inside the patch (a corner's value as its patch sees it: a vertex at a block's foot
  // is lit from one side and dark from the other), corners first, then the centre and the edge
  // midpoints, in the parameters [-1, 1]² of pointOnPatch.
  constexpr double kIn = 1 - 1e-3;
  constexpr double kSample[9][2] = {{-kIn, -kIn}, {kIn, -kIn}, {kIn, kIn}, {-kIn, kIn}, {0, 0},
                                    {0, -kIn},    {kIn, 0},    {0, kIn},   {-kIn, 0}};
  enum Shaft : uint8_t { kUnasked, kClear, kUnclear };
  tbb::parallel_for(tbb::blocked_range<size_t>(0, which.size(), 16), [&](const tbb::blocked_range<size_t>& range) {
    std::vector<Shaft> shaft;
    for (size_t w = range.begin(); w != range.end(); ++w) {
      const uint32_t k = which[w];
      // The solve leaves a dark room black; its walls' rays near a seam with another surface (a
      // cube's bottom on a floor) gave a few per cent of light there, and under a sky, refinement
      // spent its budget inside Blender's double-sided cubes.
      if (closure->darkPatches[k]) {
        out[w].dark = true;
        continue;
      }
      const Patch& patch = mesh.patches[k];
      const auto q = corners(mesh, patch);
      const uint32_t self[2] = {k, uint32_t(patch.twin)};
      const std::span<const uint32_t> ignore(self, patch.twin >= 0 ? 2 : 1);
      // Per sample: the direct light, in the second phase plus the light gathered from the first
      // bounce (and its variance), and the near hemisphere's open share, each times ρ.
      const PatchLight* known = prior.empty() ? nullptr : prior[w];
      double value[9], gathered[9] = {}, variance[9] = {}, open[9];
      bool hidden[9];
      size_t rays = 0;
      shaft.assign(emitters.size(), kUnasked);  // per emitter, whether the whole patch's shaft is clear
      const double rho = luminance(patch.reflectance);
      for (int i = 0; i < 9; ++i) {
        const Vec3 x = pointOnPatch(q, kSample[i][0], kSample[i][1]);
        const Sight sight{occlusion, mesh, x + patch.normal * (occlusion.epsilon() * 10), ignore, {}};
        if (known) {
          value[i] = known->value[i], open[i] = known->open[i], hidden[i] = known->hidden[i];
        } else {
          value[i] = 0;
          hidden[i] = covered(mesh, occlusion, *closure, sight.from, patch.normal, ignore);
          open[i] = rho * nearOpenness(sight, patch.normal, kNearRadius * occlusion.sceneSize());
        }
        if (hidden[i]) continue;
        if (!known) {
          double d = luminance(directIrradiance(scene.lights, sight, x, patch.normal)) / kPi;
          if (sky > 0) d += sky * skyOpenness(sight, patch.normal);
          for (const Emitter& source : emitters) {
            const auto& qe = source.q;
            // Behind the emitter it sends nothing, and a patch in its plane is a piece of it (or of
            // its twin): a patch does not light itself.
            if (!(dot(source.normal, x - qe[0]) > occlusion.epsilon())) continue;
            const double factor = pointPolygonFactor(x, patch.normal, qe.data(), 4);
            if (!(factor > 0)) continue;
            // Where the sample's own shaft would be asked (visibleFraction), the whole patch's is
            // asked first, once for its nine samples: the hull of its corners (lifted as the samples
            // are) and the emitter's. In issue 16's Blender room the ceiling cells around the lamp
            // asked 66k shafts, each visiting some 5,800 ceiling patches, a quarter of refinement.
            // (visibleFraction asks a shaft above kShaftPieces pieces.)
            const size_t e = size_t(&source - emitters.data());
            const bool shaftAsked = factor > kVisibilityPiece / 10 * kShaftPieces;
            if (shaftAsked && shaft[e] == kUnasked) {
              const double lift = occlusion.epsilon() * 10;
              std::array<Vec3, 8> hull;
              for (int c = 0; c < 4; ++c) hull[c] = q[c] + patch.normal * lift, hull[4 + c] = qe[c] + source.normal * lift;
              shaft[e] = hullClear(occlusion, mesh, hull, {}, ignore) ? kClear : kUnclear;
            }
            const auto seen = shaftAsked && shaft[e] == kClear
                                  ? std::array<double, 4>{1, 1, 1, 1}
                                  : visibleFraction(sight, patch.normal, qe, source.normal, kVisibilityPiece / 10, rays);
            d += source.emission * factor * (seen[0] + seen[1] + seen[2] + seen[3]) / 4;
          }
          value[i] = rho * d;
        }
        if (bounce) {
          const Gathered g = gatherBounce(*bounce, sight.from, patch.normal);
          gathered[i] = value[i] + rho * g.mean;
          variance[i] = rho * rho * g.variance;
        }
      }
      // A patch under an object standing on its surface (its inner samples all covered: with faces
      // cut along the footprint, every patch under it) is seen by nothing: never split, as a dark one.
      if (std::all_of(hidden + 4, hidden + 9, [](bool h) { return h; })) {
        out[w] = {};
        out[w].dark = true;
        continue;
      }
      PatchLight measured;
      measured.sampled = true;
      std::copy(value, value + 9, measured.value.begin());
      std::copy(open, open + 9, measured.open.begin());
      std::copy(hidden, hidden + 9, measured.hidden.begin());
      // A covered corner (under an object standing on the patch) takes, as its vertex does in the
      // solve (relocateCovered), the light beside the object: the mean of its uncovered neighbours
      // on the patch's edges, else the centre's. Covered inner samples miss nothing anyone sees.
      constexpr int kNeighbours[4][2] = {{5, 8}, {5, 6}, {6, 7}, {7, 8}};
      for (int c = 0; c < 4; ++c) {
        if (!hidden[c]) continue;
        int from[2], count = 0;
        for (int i : kNeighbours[c])
          if (!hidden[i]) from[count++] = i;
        if (count == 0 && !hidden[4]) from[count++] = 4;
        if (count == 0) continue;
        double v = 0, g = 0, var = 0;
        for (int j = 0; j < count; ++j) v += value[from[j]], g += gathered[from[j]], var += variance[from[j]];
        value[c] = v / count, gathered[c] = g / count, variance[c] = var / (count * count);
      }
      // How far the bilinear interpolation of the corner samples misses the inner ones, less twice
      // the noise of that difference (second phase: the gather's rays alone must not split a cell).
      auto missed = [&](const double* v, const double* noise, bool skipHidden) {
        double worst = 0;
        for (int i = 4; i < 9; ++i) {
          if (skipHidden && hidden[i]) continue;
          const auto n = shapeFunctions(kSample[i][0], kSample[i][1]);
          double var = noise[i];
          for (int c = 0; c < 4; ++c) var += n[c] * n[c] * noise[c];
          worst = std::max(worst, std::abs(v[i] - (n[0] * v[0] + n[1] * v[1] + n[2] * v[2] + n[3] * v[3])) - 2 * std::sqrt(var));
        }
        return worst;
      };
      auto mean = [](const double* v) { return (v[0] + v[1] + v[2] + v[3] + 4 * v[4]) / 8; };
      const double none[9] = {};
      measured.error = missed(value, none, true);
      measured.level = mean(value);
      measured.nearError = missed(open, none, false);
      measured.bounceError = bounce ? missed(gathered, variance, true) : 0;
      measured.bounceLevel = bounce ? mean(gathered) : 0;
      measured.corner = {value[0], value[1], value[2], value[3]};
      out[w] = measured;
    }
    ticker.add(range.size());
  });
  return out;
}

// A patch as refinement's rounds see it: its corners' bits and its side. A patch that comes back
// unchanged from the next tessellation keeps its measure (the emitters do not move), so each round
// measures only the new patches: the measure was 24 of the Cornell box's 32 s at --refine 0.2.
using PatchKey = std::array<uint64_t, 13>;
PatchKey patchKey(const PatchMesh& mesh, const Patch& patch) {
  PatchKey key{};
  for (int c = 0; c < 4; ++c) {
    const Vec3& x = mesh.positions[patch.v[c]];
    key[3 * c] = std::bit_cast<uint64_t>(x.x);
    key[3 * c + 1] = std::bit_cast<uint64_t>(x.y);
    key[3 * c + 2] = std::bit_cast<uint64_t>(x.z);
  }
  key[12] = patch.backSide;
  return key;
}

// One round's choice: the cells of patches whose error (relative to the mean; negative: not
// measured) is above the target, by what those patches add to the squared error integrated over
// the area (e² A), so the budget goes first where the field is most wrong over the most area; the
// worst that hold half of that mass, at most a quarter of what is left of the budget in cells (a
// split makes three more patches, more where fans and balance follow). A hot spot (a
// lamp 2 cm under a ceiling, 70 times the mean) then goes down a level every round, instead of
// waiting while each round spends a quarter of the budget on everything above the target (a
// Blender room spent its whole budget in 4 rounds and its ceiling kept 3-m cells over the hot
// spot). Cells at the finest level are left out (also of `worst`): along a sharp shadow their
// error stays near 1 at any size. False when nothing is split (none above, or no budget left).
size_t budgetRoom(size_t patches, size_t maxPatches) { return patches < maxPatches ? (maxPatches - patches) / 4 : 0; }

bool splitWorst(const PatchMesh& mesh, const std::vector<double>& error, double target, TessellateOptions& options,
                Refinement& summary) {
  std::map<Cell, double> above;  // a double-sided patch and its twin share their cell
  summary.worst = 0;
  for (size_t k = 0; k < mesh.patches.size(); ++k) {
    const Cell& cell = mesh.patches[k].cell;
    if (cell.primitive < 0 || cell.level >= kMaxRefineLevel || error[k] < 0) continue;
    summary.worst = std::max(summary.worst, error[k]);
    if (error[k] > target) above[cell] += error[k] * error[k] * mesh.patches[k].area;
  }
  if (above.empty()) return false;
  const size_t room = budgetRoom(mesh.patches.size(), summary.maxPatches);
  if (room == 0) {
    summary.budgetReached = true;
    return false;
  }
  std::vector<std::pair<double, Cell>> worstFirst;
  double mass = 0;
  for (const auto& [cell, e] : above) {
    worstFirst.push_back({e, cell});
    mass += e;
  }
  std::stable_sort(worstFirst.begin(), worstFirst.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  size_t take = 0;
  for (double taken = 0; take < worstFirst.size() && take < room && taken < mass / 2; ++take) taken += worstFirst[take].first;
  worstFirst.resize(take);
  for (const auto& [e, cell] : worstFirst) options.split.insert(cell);
  summary.splitCells += worstFirst.size();
  ++summary.rounds;
  return true;
}

// Refinement's first phase (the direct light) takes this share of the patches the budget adds;
// the second (the first bounce gathered too) the rest. 0.3 and 0.7 measured alike on the level-0
// Blender room (1.7% of its light lost either way) and on the Cornell box (docs/radiosity.md).
constexpr double kDirectShare = 0.5;

// The default budget: this many patches more than the start. A fixed number, not a multiple of the
// start, because refinement is the default and its cost is the solve's: issue 16's Blender room
// starts at 24k patches; 4× that took 12 minutes (1.5% of its light lost), 44k 137 s (1.4%).
constexpr size_t kDefaultRefineBudget = 20000;

double areaMean(const PatchMesh& mesh, const std::vector<PatchLight>& light, double PatchLight::*level) {
  double sum = 0, area = 0;
  for (size_t k = 0; k < mesh.patches.size(); ++k) {
    if (light[k].dark) continue;
    sum += light[k].*level * mesh.patches[k].area;
    area += mesh.patches[k].area;
  }
  return area > 0 ? sum / area : 0;
}

// Rounds of measuring the patches not seen before and splitting the worst cells, until none is
// above the target, `maxPatches` are reached, or 40 rounds; returns the measure of the mesh's
// patches as they are at the end (the first phase's: the bounce field is made of it). The second
// phase's measure serves only its splits, so it stops unmeasured once the budget leaves no room:
// measuring the last round's patches (two fifths of them new) only to split none was 0.5 of the
// Cornell box's 4.5 s at --max-patches 4000.
// `known` collects the measure of every patch seen, by its key; the second phase passes the
// first's as `prior`.
using MeasuredPatches = std::unordered_map<PatchKey, PatchLight, WordsHash<13>>;
std::vector<PatchLight> refineRounds(const Scene& scene, TessellateOptions& options, PatchMesh& mesh, double target,
                                     size_t maxPatches, const std::vector<Emitter>& emitters, double sky,
                                     const BounceField* bounce, MeasuredPatches& known, const MeasuredPatches* prior,
                                     Refinement& summary, Ticker& ticker) {
  constexpr int kMaxRounds = 4 * kMaxRefineLevel;
  Refinement phase;
  phase.maxPatches = maxPatches;
  std::vector<PatchLight> light;  // empty until a round measures
  for (int round = 0;; ++round) {
    if (bounce && budgetRoom(mesh.patches.size(), maxPatches) == 0) {
      phase.budgetReached = true;
      break;
    }
    // Measure the patches not seen before.
    std::vector<PatchKey> keys(mesh.patches.size());
    std::vector<uint32_t> fresh;
    for (size_t k = 0; k < mesh.patches.size(); ++k) {
      keys[k] = patchKey(mesh, mesh.patches[k]);
      if (!known.count(keys[k])) fresh.push_back(uint32_t(k));
    }
    std::vector<const PatchLight*> before;
    if (prior)
      for (uint32_t k : fresh) {
        const auto it = prior->find(keys[k]);
        before.push_back(it != prior->end() && it->second.sampled ? &it->second : nullptr);
      }
    const std::vector<PatchLight> measured = measureLight(scene, mesh, fresh, emitters, sky, bounce, before, ticker);
    for (size_t w = 0; w < fresh.size(); ++w) known[keys[fresh[w]]] = measured[w];
    light.assign(mesh.patches.size(), {});
    for (size_t k = 0; k < mesh.patches.size(); ++k) light[k] = known[keys[k]];
    const double mean = areaMean(mesh, light, &PatchLight::level), bounceMean = areaMean(mesh, light, &PatchLight::bounceLevel);
    std::vector<double> error(mesh.patches.size(), -1);
    // The near hemisphere's share stands for the indirect light, at the scale of the mean direct
    // light. In the second phase the first bounce is gathered too (relative to its own mean), and
    // a cell is judged by the worse of the two: the gathered light is noisier (a contact's few per
    // cent are below its noise), but it sees what the direct light does not (a lamp's back 2 cm
    // under a ceiling, lit by the ceiling only).
    for (size_t k = 0; k < mesh.patches.size(); ++k) {
      if (!(mean > 0) || light[k].dark) continue;
      error[k] = light[k].error / mean + light[k].nearError;
      if (bounce && bounceMean > 0) error[k] = std::max(error[k], light[k].bounceError / bounceMean);
    }
    if (round == kMaxRounds || !splitWorst(mesh, error, target, options, phase)) break;
    mesh = tessellate(scene, options, &mesh);
    options.split = mesh.split;
  }
  summary.rounds += phase.rounds;
  summary.splitCells += phase.splitCells;
  if (!light.empty()) summary.worst = phase.worst;
  summary.budgetReached = phase.budgetReached;
  return light;
}

}  // namespace

Refinement refineMesh(const Scene& scene, TessellateOptions& options, PatchMesh& mesh, double target, size_t maxPatches,
                      const Vec3& sky, const std::function<void(double)>& progress) {
  Refinement summary;
  summary.maxPatches = maxPatches > 0 ? maxPatches : mesh.patches.size() + kDefaultRefineBudget;
  // First the direct light, to a share of the patches the budget adds (kDirectShare; of the adds,
  // not the total: a 24k-patch room given 44k would otherwise split nothing for its direct light);
  // then the first bounce of the mesh it left is gathered at the samples too, for the rest.
  const std::vector<Emitter> emitters = measuredEmitters(mesh);
  const size_t start = std::min(mesh.patches.size(), summary.maxPatches);
  const size_t directBudget = start + size_t(double(summary.maxPatches - start) * kDirectShare);
  MeasuredPatches firstPhase, secondPhase;
  // Progress by patches measured, nearly all of the time: each phase measures about as many as its
  // budget allows (the first its share, the second every patch again and its new ones), and an
  // eighth more for the parents split in the same rounds (issue 16's room: 44.1k and 46.2k
  // against budgets of 35.3k and 45.3k). Held below 1 until the end.
  std::function<void(double)> held;
  if (progress) held = [&progress](double f) { progress(std::min(f, 0.99)); };
  Ticker ticker(held, (directBudget + summary.maxPatches) * 9 / 8, 0, 1);
  const std::vector<PatchLight> direct = refineRounds(scene, options, mesh, target, directBudget, emitters, luminance(sky), nullptr,
                                                      firstPhase, nullptr, summary, ticker);
  const PatchMesh first = mesh;
  Occlusion occlusion(first);
  if (!first.masks.empty()) occlusion.setCutouts([&](uint32_t patch, double u, double v) { return passesCutout(scene, first, patch, u, v); });
  BounceField field{first, occlusion, {}};
  for (const PatchLight& l : direct) field.corner.push_back(l.corner);
  refineRounds(scene, options, mesh, target, summary.maxPatches, emitters, luminance(sky), &field, secondPhase, &firstPhase,
               summary, ticker);
  if (progress) progress(1);
  return summary;
}

Solution solveRadiosity(const Scene& scene, const PatchMesh& mesh, const RadiosityOptions& asked) {
  // Under a sky the hierarchical transport's rows are also its sky's cover (skyFromRows), whose
  // errors weigh by the sky's radiance: its links are made at kSkyAccuracy of --accuracy (the
  // constant method's and its cover walk's too, which that walk's quarter once was).
  RadiosityOptions options = asked;
  if (hasSky(options) && options.transport == TransportMode::kHierarchical) options.accuracy *= kSkyAccuracy;
  Solution solution;
  solution.method = options.method;
  solution.interreflection = true;
  Occlusion occlusion(mesh);
  if (!mesh.masks.empty()) occlusion.setCutouts([&](uint32_t patch, double u, double v) { return passesCutout(scene, mesh, patch, u, v); });
  const auto closure = makeClosure(scene, mesh, options.method);
  // The unknowns: vertices (bilinear) or patches (constant), with their emission and reflectance.
  const bool bilinear = options.method == Method::kBilinear;
  const size_t n = bilinear ? mesh.positions.size() : mesh.patches.size();
  std::vector<Vec3> emission(n), reflectance(n);
  for (size_t i = 0; i < n; ++i) {
    emission[i] = bilinear ? mesh.vertexEmission[i] : mesh.patches[i].emission;
    reflectance[i] = bilinear ? mesh.vertexReflectance[i] : mesh.patches[i].reflectance;
  }
  const double offset = occlusion.epsilon() * 10;
  const auto recv = std::make_shared<const Receivers>([&] {
    if (!bilinear) return patchReceivers(mesh, offset);
    Receivers r = receivers(mesh, offset);
    snapToTouching(mesh, occlusion, r, offset);
    relocateCovered(mesh, occlusion, *closure, r, offset);
    return r;
  }());
  const bool hierarchical = options.transport == TransportMode::kHierarchical;
  // The traced back sides take the first share of the progress (hierarchical, bilinear).
  const double tracedTo = hierarchical && bilinear ? kTracedProgress : 0;
  ReceiverGroups groups;
  TracedBackSides traced;
  std::vector<bool> bright;  // per patch: brighter than the scene's mean emission (emissionWeight)
  if (hierarchical) {
    const std::vector<bool> gathers = gatheringReceivers(mesh, *recv, *closure, occlusion.epsilon());
    std::vector<TreeItem> items = receiverItems(mesh, *recv, *closure, options.method);
    if (bilinear) {
      const double meanEmitted = meanEmission(mesh);
      bright.resize(mesh.patches.size());
      for (size_t p = 0; p < bright.size(); ++p) bright[p] = emissionWeight(mesh.patches[p], meanEmitted) > 1;
      Ticker tracedTicker(options.progress, n, 0, tracedTo);
      traced = tracedBackSides(mesh, occlusion, *recv, *closure, gathers, bright,
                               nearPairs(mesh, occlusion, *recv, options.method, options.kernelTolerance, options.accuracy), tracedTicker);
      for (size_t v = 0; v < items.size(); ++v) items[v].part = traced.traced[v];
      solution.tracedUnknowns = size_t(std::count(traced.traced.begin(), traced.traced.end(), true));
    }
    groups = receiverGroups(items, gathers, receiverSites(mesh, occlusion, *recv, options.method));
  }
  // With a sky, its pass takes the first part of the progress: for the exact transport one more
  // pass over every pair; for the hierarchical one the walk of what patches seen from behind cover
  // (the rest of its sky is what the transport's rows leave open, skyFromRows).
  const bool skyFromTheRows = hierarchical && bilinear;
  const double transportFrom = !hasSky(options) ? tracedTo : skyFromTheRows ? tracedTo + kBackCoverProgress : kSkyProgress;
  Ticker skyTicker(options.progress, n, tracedTo, transportFrom);
  std::vector<double> sky, covered, tracedOpen;  // the sky, or what the cover walk found (skyFromRows)
  if (hasSky(options) && !hierarchical) {
    sky = exactSkyFractions(mesh, *recv, closure->rows, coverPairs(mesh, occlusion, *recv, options.method, options.kernelTolerance, 0, false),
                            skyTicker);
  } else if (hasSky(options)) {
    // The bilinear method's sky is what its rows leave open less what backs cover. The constant
    // method's is what every patch covers: its patch factors and its covers judge a patch
    // straddling another's plane differently (from any corner, from the centre), and its rows
    // would have left a floor patch under a block's foot half open.
    MemoryBudget memory;  // the cover walk keeps its links until its cover is summed
    memory.limit = options.transportMemoryBytes;
    covered = hierarchicalCover(mesh, occlusion, *recv, *closure, groups, options.accuracy,
                                  coverPairs(mesh, occlusion, *recv, options.method, options.kernelTolerance, options.accuracy, skyFromTheRows),
                                  skyFromTheRows, traced.traced, memory, skyTicker, solution.clusterRays, solution.nearRays);
    tracedOpen = traced.open;
    if (!skyFromTheRows) {
      sky.assign(n, 0.0);
      for (size_t i = 0; i < n; ++i) sky[i] = closure->rows[i] ? 0 : std::max(0.0, 1 - covered[i]);
    }
  }
  const std::vector<Vec3> direct = bilinear ? bilinearDirectLight(scene, mesh, occlusion, *recv) : constantDirectLight(scene, mesh, occlusion);
  // (The hierarchical transport's sky joins once its rows are walked.)
  auto sourceWith = [&](const std::vector<double>& fractions) {
    return withDirectLight(withSky(emission, reflectance, options, fractions), reflectance, direct);
  };
  std::vector<Vec3> source = sourceWith(sky);
  Transport K;
  Hierarchical H;
  Gather gather = exactGather(K);
  // The radiance of the unknowns (a vertex's or a patch's), what each gathers, and where the
  // progress of the final solve starts.
  std::vector<Vec3>& L = bilinear ? solution.vertexRadiance : solution.patchRadiance;
  std::vector<Vec3> gathered;
  double solveFrom = 0.8;
  // No light at all: black is the exact answer, no transport needed.
  if (anyLight(source) || (skyFromTheRows && hasSky(options))) {
    if (hierarchical) {
      // The near kernels to a tenth of --accuracy, not to the exact transport's 1e-6: a row's near
      // entries then err by at most that share of its total, below what each link may, and the
      // graded quadrature (KernelIntegrator) was a fifth of the engine part's time at 1e-6 (12–15%
      // less time at 1e-4 on the Cornell box, the Blender room and the engine part, errors against
      // exact unchanged to 0.001%). The constant method's patch factors likewise.
      const NearPair nearPair = nearPairs(mesh, occlusion, *recv, options.method, options.kernelTolerance, options.accuracy);
      Ticker ticker(options.progress, n, transportFrom, kRefineProgress[0]);
      H = hierarchicalTransport(mesh, occlusion, options, *recv, *closure, std::move(groups), nearPair, std::move(traced), std::move(bright), ticker);
      gather = hierarchicalGather(H, mesh);
      auto rowSky = [&] { return skyFromRows(gather, covered, closure->rows, H.traced, tracedOpen); };
      if (hasSky(options) && skyFromTheRows) source = sourceWith(rowSky());
      // A first solve to kFirstResidual shows where the light is; the links that carry too much of
      // it for their error estimate are walked again (refineByLight), and the solve goes on from
      // there.
      iterate(gather, source, reflectance, options, std::max(options.relativeResidual, kFirstResidual), kRefineProgress[0],
              kRefineProgress[1], L, gathered, solution);
      Ticker refineTicker(options.progress, n, kRefineProgress[1], kRefineProgress[2]);
      solution.refinedLinks = refineByLight(H, mesh, occlusion, options, *recv, nearPair, L, refineTicker);
      closeRows(H, *recv, *closure);  // after pairs walked again (links, or pairs once called hidden)
      if (hasSky(options) && skyFromTheRows) {
        sky = rowSky();  // the rows as the final solve gathers them
        source = sourceWith(sky);
      }
      solveFrom = kRefineProgress[2];
      solution.matrixEntries = H.nearEntries;
      solution.farLinks = H.linkCount;
      solution.clusterRays += H.rays;
      solution.nearRays += H.nearRays;
      solution.clusters = H.source.nodes.size() + H.groups.tree.nodes.size();
      solution.linkErrorBound = H.worstError;
      solution.transportBytes = H.bytes();
    } else {
      K = exactTransport(mesh, occlusion, recv, closure, nearPairs(mesh, occlusion, *recv, options.method, options.kernelTolerance, 0));
      applyClosure(K, closure);
      storeIfItFits(K, options, transportFrom, solution.matrixEntries);
      solution.matrixFree = !K.stored();
      solution.transportBytes = K.stored() ? solution.matrixEntries * kBytesPerEntry : 0;
    }
  }
  iterate(gather, source, reflectance, options, options.relativeResidual, solveFrom, 1, L, gathered, solution);
  solution.skyFraction = std::move(sky);  // under a sky every path above has set it
  if (bilinear) {
    // Power balance: each vertex stands for ∫ N_v dA of the patches around it.
    for (const Patch& patch : mesh.patches) {
      const auto a = shapeFunctionAreas(corners(mesh, patch));
      for (int j = 0; j < 4; ++j) {
        const uint32_t v = patch.v[j];
        const Vec3& rho = reflectance[v];
        solution.emittedPower += kPi * a[j] * (emission[v].x + emission[v].y + emission[v].z) / 3;
        solution.absorbedPower += kPi * a[j] *
            ((1 - rho.x) * gathered[v].x + (1 - rho.y) * gathered[v].y + (1 - rho.z) * gathered[v].z) / 3;
      }
    }
    // Per patch, the mean of the bilinear field (what a constant patch would hold).
    solution.patchRadiance.resize(mesh.patches.size());
    for (size_t p = 0; p < mesh.patches.size(); ++p) {
      const auto a = shapeFunctionAreas(corners(mesh, mesh.patches[p]));
      Vec3 sum{};
      for (int j = 0; j < 4; ++j) sum += solution.vertexRadiance[mesh.patches[p].v[j]] * a[j];
      solution.patchRadiance[p] = sum / (a[0] + a[1] + a[2] + a[3]);
    }
  } else {
    for (size_t p = 0; p < mesh.patches.size(); ++p) {
      const Vec3& rho = reflectance[p];
      solution.emittedPower += kPi * mesh.patches[p].area * (emission[p].x + emission[p].y + emission[p].z) / 3;
      solution.absorbedPower += kPi * mesh.patches[p].area *
          ((1 - rho.x) * gathered[p].x + (1 - rho.y) * gathered[p].y + (1 - rho.z) * gathered[p].z) / 3;
    }
    // Vertex values for smooth display: area-weighted mean of the patches around each vertex.
    std::vector<Vec3> sum(mesh.positions.size());
    std::vector<double> weight(mesh.positions.size());
    for (size_t p = 0; p < mesh.patches.size(); ++p)
      for (int j = 0; j < 4; ++j) {
        if (j == 3 && mesh.patches[p].v[3] == mesh.patches[p].v[2]) continue;
        sum[mesh.patches[p].v[j]] += solution.patchRadiance[p] * mesh.patches[p].area;
        weight[mesh.patches[p].v[j]] += mesh.patches[p].area;
      }
    solution.vertexRadiance.resize(mesh.positions.size());
    for (size_t v = 0; v < sum.size(); ++v) solution.vertexRadiance[v] = weight[v] > 0 ? sum[v] / weight[v] : Vec3{};
  }
  bool emits = false, enclosedEmitters = true;
  for (size_t p = 0; p < mesh.patches.size(); ++p) {
    const Vec3& e = mesh.patches[p].emission;
    if (e.x > 0 || e.y > 0 || e.z > 0) emits = true, enclosedEmitters = enclosedEmitters && closure->patches[p];
  }
  solution.lightEnclosed = emits && enclosedEmitters && !hasSky(options) && scene.lights.empty();
  solution.enclosedUnknowns = size_t(std::count(closure->rows.begin(), closure->rows.end(), true));
  solution.closureCorrection = closure->largest.load();
  solution.darkUnknowns = size_t(std::count(closure->dark.begin(), closure->dark.end(), true));
  solution.contactUnknowns = recv->moved;
  return solution;
}

Vec3 evaluateRadiance(const Solution& solution, const PatchMesh& mesh, const Vec3& point, const Vec3& normal) {
  double best = std::numeric_limits<double>::infinity();
  Vec3 value{};
  for (size_t p = 0; p < mesh.patches.size(); ++p) {
    const Patch& patch = mesh.patches[p];
    if (!(dot(patch.normal, normal) > 0)) continue;
    const auto q = corners(mesh, patch);
    const QuadPoint qp = nearestQuadPoint(q, point);
    if (qp.distance >= best) continue;
    best = qp.distance;
    if (solution.method == Method::kConstant) {
      value = solution.patchRadiance[p];
    } else {
      const auto n = shapeFunctions(qp.s, qp.t);
      value = Vec3{};
      for (int j = 0; j < 4; ++j) value += solution.vertexRadiance[patch.v[j]] * n[j];
    }
  }
  return value;
}

}  // namespace radbake

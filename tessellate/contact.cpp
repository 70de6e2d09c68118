#include "tessellate/contact.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <map>
#include <optional>
#include <set>
#include <tuple>
#include <unordered_map>

namespace radbake {
namespace {

// ---- Which triangles can meet: a bounding volume hierarchy over their boxes ------------------

bool overlaps(const Bounds& a, const Bounds& b) {
  return a.lo.x <= b.hi.x && b.lo.x <= a.hi.x && a.lo.y <= b.hi.y && b.lo.y <= a.hi.y && a.lo.z <= b.hi.z && b.lo.z <= a.hi.z;
}

struct Bvh {
  struct Node {
    Bounds box;
    uint32_t start = 0, count = 0, right = 0;  // a leaf holds order[start, start + count); else its children are next and `right`
  };
  std::vector<Node> nodes;
  std::vector<uint32_t> order;
};

void buildNode(Bvh& bvh, const std::vector<Bounds>& boxes, const std::vector<Vec3>& centres, uint32_t start, uint32_t count) {
  const uint32_t index = uint32_t(bvh.nodes.size());
  bvh.nodes.emplace_back();
  Bounds box, spread;
  for (uint32_t k = start; k < start + count; ++k) {
    box.add(boxes[bvh.order[k]].lo);
    box.add(boxes[bvh.order[k]].hi);
    spread.add(centres[bvh.order[k]]);
  }
  bvh.nodes[index].box = box;
  if (count <= 4) {
    bvh.nodes[index].start = start;
    bvh.nodes[index].count = count;
    return;
  }
  const Vec3 extent = spread.hi - spread.lo;
  const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
  const uint32_t mid = start + count / 2;
  std::nth_element(bvh.order.begin() + start, bvh.order.begin() + mid, bvh.order.begin() + start + count,
                   [&](uint32_t a, uint32_t b) { return centres[a][axis] < centres[b][axis]; });
  buildNode(bvh, boxes, centres, start, mid - start);
  bvh.nodes[index].right = uint32_t(bvh.nodes.size());
  buildNode(bvh, boxes, centres, mid, start + count - mid);
}

template <typename Visit>
void query(const Bvh& bvh, const Bounds& box, const Visit& visit) {
  if (bvh.nodes.empty()) return;
  std::vector<uint32_t> stack{0};
  while (!stack.empty()) {
    const Bvh::Node& node = bvh.nodes[stack.back()];
    const uint32_t at = stack.back();
    stack.pop_back();
    if (!overlaps(node.box, box)) continue;
    if (node.count > 0) {
      for (uint32_t k = node.start; k < node.start + node.count; ++k) visit(bvh.order[k]);
    } else {
      stack.push_back(node.right);
      stack.push_back(at + 1);
    }
  }
}

// ---- A convex polygon (a source triangle, a patch) in its own plane ------------------------------

struct P2 {
  double x = 0, y = 0;
};
P2 operator-(const P2& a, const P2& b) { return {a.x - b.x, a.y - b.y}; }
double cross2(const P2& a, const P2& b) { return a.x * b.y - a.y * b.x; }
double orient(const P2& a, const P2& b, const P2& c) { return cross2(b - a, c - a); }
double dist2(const P2& a, const P2& b) { return std::hypot(a.x - b.x, a.y - b.y); }
P2 lerp2(const P2& a, const P2& b, double t) { return {a.x + (b.x - a.x) * t, a.y + (b.y - a.y) * t}; }
// Where x projects on the line a→b, as a fraction of a→b.
double along(const P2& a, const P2& b, const P2& x) {
  const P2 d = b - a;
  return ((x.x - a.x) * d.x + (x.y - a.y) * d.y) / (d.x * d.x + d.y * d.y);
}

struct Frame {
  Vec3 origin, u, v, n;
  std::vector<P2> corner;  // counter-clockwise, 3 or 4
  Frame(const std::vector<Vec3>& x, const Vec3& normal) : origin(x[0]), n(normal) {
    u = normalize(x[1] - x[0]);
    u = normalize(u - n * dot(u, n));
    v = cross(n, u);
    for (const Vec3& p : x) corner.push_back(at(p));
  }
  P2 at(const Vec3& p) const { return {dot(p - origin, u), dot(p - origin, v)}; }
  Vec3 back(const P2& p) const { return origin + u * p.x + v * p.y; }
};

// Where a cut segment ends on its polygon: a corner, a point on edge `edge` at t from its first
// corner, or inside.
struct End {
  P2 p;
  int corner = -1, edge = -1;
  double t = 0;
};

struct Segment {
  End a, b;
};

// The segment where triangle x touches or crosses the plane (origin, n); points within `eps` of
// the plane are on it.
std::vector<ContactSegment> meeting(const Vec3& origin, const Vec3& n, const std::array<Vec3, 3>& x, double eps) {
  std::array<double, 3> s;
  std::array<bool, 3> on;
  for (int k = 0; k < 3; ++k) {
    s[k] = dot(x[k] - origin, n);
    on[k] = std::abs(s[k]) <= eps;
  }
  // In the plane: no cut. A box's bottom on a floor adds nothing its sides do not cut (and the
  // floor's edges cut the box's covered bottom, whose pieces then stood within rounding of the
  // floor's vertices and pulled their light, up to 21% too bright); a coincident copy of a surface
  // (the 2CylinderEngine has many) cut it into slivers along every edge of the other (215k patches
  // from 88k, and minutes where vertices gathered among thousands of touching slivers).
  if (on[0] && on[1] && on[2]) return {};
  std::vector<Vec3> points;
  for (int k = 0; k < 3; ++k) {
    if (on[k]) points.push_back(x[k]);
    const int l = (k + 1) % 3;
    if (!on[k] && !on[l] && (s[k] > 0) != (s[l] > 0)) points.push_back(x[k] + (x[l] - x[k]) * (s[k] / (s[k] - s[l])));
  }
  if (points.size() != 2) return {};
  return {{points[0], points[1]}};
}

// The part of segment (p, q) inside the polygon, its ends snapped to corners and edges within eps;
// none if it is shorter than eps or runs along one edge.
std::optional<Segment> clip(const Frame& f, P2 p, P2 q, double eps) {
  const int k = int(f.corner.size());
  double t0 = 0, t1 = 1;
  for (int e = 0; e < k; ++e) {
    const P2 a = f.corner[e], b = f.corner[(e + 1) % k];
    const double len = dist2(a, b);
    const double fp = orient(a, b, p) / len, fq = orient(a, b, q) / len;  // distances inside
    if (fp < -eps && fq < -eps) return std::nullopt;
    if (fp < 0 && fq > fp) t0 = std::max(t0, fp / (fp - fq));
    if (fq < 0 && fp > fq) t1 = std::min(t1, fp / (fp - fq));
  }
  if (t1 - t0 <= 0) return std::nullopt;
  Segment s{{lerp2(p, q, t0)}, {lerp2(p, q, t1)}};
  if (dist2(s.a.p, s.b.p) <= eps) return std::nullopt;
  for (End* end : {&s.a, &s.b}) {
    for (int c = 0; c < k && end->corner < 0; ++c)
      if (dist2(end->p, f.corner[c]) <= eps) {
        end->corner = c;
        end->p = f.corner[c];
      }
    for (int e = 0; e < k && end->corner < 0; ++e) {
      const P2 a = f.corner[e], b = f.corner[(e + 1) % k];
      if (std::abs(orient(a, b, end->p)) / dist2(a, b) <= eps) {
        end->edge = e;
        end->t = std::clamp(along(a, b, end->p), 0.0, 1.0);
        end->p = lerp2(a, b, end->t);
        break;
      }
    }
  }
  // Along an edge of the polygon: nothing to cut.
  auto onEdge = [k](const End& x, int e) { return x.edge == e || x.corner == e || x.corner == (e + 1) % k; };
  for (int e = 0; e < k; ++e)
    if (onEdge(s.a, e) && onEdge(s.b, e)) return std::nullopt;
  return s;
}

// An edge keyed by its endpoints' position bits (smaller first), so the patches on either side
// find the same points on it.
using EdgeKey = std::array<uint64_t, 6>;
bool before(const Vec3& a, const Vec3& b) { return std::tie(a.x, a.y, a.z) < std::tie(b.x, b.y, b.z); }
EdgeKey edgeKey(Vec3 a, Vec3 b) {
  if (before(b, a)) std::swap(a, b);
  const auto ka = positionKey(a), kb = positionKey(b);
  return {ka[0], ka[1], ka[2], kb[0], kb[1], kb[2]};
}

// ---- Triangulating a patch with its cuts -------------------------------------------------------

using Weights = std::array<double, 4>;

// The most cuts a patch is cut by (a block's four sides, a leg's eight, a few crossing walls).
constexpr size_t kMaxCuts = 32;

// The patch's triangulation in its plane: points with their weights on the patch's corners,
// triangles counter-clockwise, and the cut segments as constrained edges. Small (a patch has a
// few cuts), so searches are linear.
struct Triangulation {
  double eps;
  int corners;  // points 0 .. corners - 1 are the polygon's corners
  std::vector<P2> p;
  std::vector<Weights> weights;
  std::vector<std::array<int, 3>> triangles;
  std::set<std::pair<int, int>> fixed;

  int add(const P2& x, const Weights& w) {
    p.push_back(x);
    weights.push_back(w);
    return int(p.size()) - 1;
  }

  static std::pair<int, int> key(int a, int b) { return {std::min(a, b), std::max(a, b)}; }

  // Splits edge (i, j) at new point k in the triangles on both sides.
  void splitEdge(int i, int j, int k) {
    const size_t n = triangles.size();
    for (size_t t = 0; t < n; ++t)
      for (int e = 0; e < 3; ++e) {
        const int a = triangles[t][e], b = triangles[t][(e + 1) % 3], c = triangles[t][(e + 2) % 3];
        if (key(a, b) != key(i, j)) continue;
        triangles[t] = {a, k, c};
        triangles.push_back({k, b, c});
        break;
      }
    if (fixed.erase(key(i, j))) {
      fixed.insert(key(i, k));
      fixed.insert(key(k, j));
    }
  }

  // The weights of a point inside: barycentric on the corner triangle (0, 1, 2) or (0, 2, 3) that
  // holds it (the corners' weights are affine in the plane; the pieces' triangles can be slivers,
  // whose barycentric weights blew up to points 1e17 away).
  Weights weightsAt(const P2& x) const {
    const int n = corners;
    Weights best{};
    double bestInside = -1e300;
    for (int t = 0; t + 2 < n; ++t) {
      const int a = 0, b = t + 1, c = t + 2;
      const double area = orient(p[a], p[b], p[c]);
      const double wa = orient(p[b], p[c], x) / area, wb = orient(p[c], p[a], x) / area, wc = 1 - wa - wb;
      const double inside = std::min({wa, wb, wc});
      if (inside <= bestInside) continue;
      bestInside = inside;
      best = {};
      best[a] = wa;
      best[b] = wb;
      best[c] = wc;
    }
    return best;
  }

  // The point at x: an existing one within eps, else a new one on the edge or in the triangle it
  // falls on. -1 if x lies outside (rounding past the polygon's edge).
  int insert(const P2& x, const std::optional<Weights>& given = std::nullopt) {
    for (size_t k = 0; k < p.size(); ++k)
      if (dist2(p[k], x) <= eps) return int(k);
    const Weights w = given ? *given : weightsAt(x);
    for (const auto& t : triangles)
      for (int e = 0; e < 3; ++e) {
        const P2 a = p[t[e]], b = p[t[(e + 1) % 3]];
        const double s = along(a, b, x);
        if (std::abs(orient(a, b, x)) / dist2(a, b) <= eps && s > 0 && s < 1) {
          const int i = t[e], j = t[(e + 1) % 3], k = add(x, w);
          splitEdge(i, j, k);
          return k;
        }
      }
    for (size_t t = 0; t < triangles.size(); ++t) {
      const auto [a, b, c] = triangles[t];
      if (orient(p[a], p[b], x) > 0 && orient(p[b], p[c], x) > 0 && orient(p[c], p[a], x) > 0) {
        const int k = add(x, w);
        triangles[t] = {a, b, k};
        triangles.push_back({b, c, k});
        triangles.push_back({c, a, k});
        return k;
      }
    }
    return -1;
  }

  // Makes (a, b) a chain of edges: split where it passes a point or crosses an edge. False when
  // rounding leaves it undecided (the patch then stays whole).
  bool insertSegment(int a, int b, int depth = 0) {
    if (a == b) return true;
    if (depth > 64) return false;
    const P2 pa = p[a], pb = p[b];
    const double len = dist2(pa, pb);
    for (size_t k = 0; k < p.size(); ++k) {
      if (int(k) == a || int(k) == b) continue;
      const double s = along(pa, pb, p[k]);
      if (std::abs(orient(pa, pb, p[k])) / len <= eps && s > 0 && s < 1)
        return insertSegment(a, int(k), depth + 1) && insertSegment(int(k), b, depth + 1);
    }
    for (const auto& t : triangles)
      for (int e = 0; e < 3; ++e) {
        const int i = t[e], j = t[(e + 1) % 3];
        if (i == a || i == b || j == a || j == b) continue;
        const double si = orient(pa, pb, p[i]), sj = orient(pa, pb, p[j]);
        const double sa = orient(p[i], p[j], pa), sb = orient(p[i], p[j], pb);
        if ((si > 0) == (sj > 0) || (sa > 0) == (sb > 0)) continue;
        const double s = si / (si - sj);
        Weights w;
        for (int c = 0; c < 4; ++c) w[c] = weights[i][c] + (weights[j][c] - weights[i][c]) * s;
        const int k = add(lerp2(p[i], p[j], s), w);
        splitEdge(i, j, k);
        return insertSegment(a, k, depth + 1) && insertSegment(k, b, depth + 1);
      }
    fixed.insert(key(a, b));
    return true;
  }

  // Each edge between two triangles that is not a cut, once, in (i, j) order: the triangle on its
  // left (i → j) with its third point c, and the one on its right with its third point d.
  struct FreeEdge {
    int i, j;
    size_t left, right;
    int c, d;
  };
  std::vector<FreeEdge> freeEdges() const {
    std::map<std::pair<int, int>, std::pair<size_t, int>> owner;  // directed edge → triangle, third point
    for (size_t t = 0; t < triangles.size(); ++t)
      for (int e = 0; e < 3; ++e) owner[{triangles[t][e], triangles[t][(e + 1) % 3]}] = {t, triangles[t][(e + 2) % 3]};
    std::vector<FreeEdge> out;
    for (const auto& [edge, first] : owner) {
      const auto [i, j] = edge;
      if (i > j || fixed.count(key(i, j))) continue;
      const auto other = owner.find({j, i});
      if (other != owner.end()) out.push_back({i, j, first.first, other->second.first, first.second, other->second.second});
    }
    return out;
  }

  // Lawson's flips of the edges not constrained (cuts, the polygon's edges): the Delaunay
  // triangulation of the pieces, whose triangles are as round as the cuts allow.
  void improve() {
    auto incircle = [&](int a, int b, int c, int d) {
      const P2 A = p[a] - p[d], B = p[b] - p[d], C = p[c] - p[d];
      return (A.x * A.x + A.y * A.y) * cross2(B, C) - (B.x * B.x + B.y * B.y) * cross2(A, C) + (C.x * C.x + C.y * C.y) * cross2(A, B);
    };
    // Rounds of flips of disjoint pairs: a patch crossed by hundreds of cuts (parts of an engine
    // pressed into each other) made one flip a round with the edge map rebuilt, cubic in the cuts.
    for (int round = 0; round < 256; ++round) {
      std::vector<char> flippedNow(triangles.size(), 0);
      bool flipped = false;
      for (const auto& [i, j, left, right, c, d] : freeEdges()) {
        if (flippedNow[left] || flippedNow[right]) continue;
        const double len = dist2(p[i], p[j]);
        if (incircle(i, j, c, d) <= 1e-12 * len * len * len * len) continue;
        if (orient(p[c], p[i], p[d]) <= len * eps || orient(p[d], p[j], p[c]) <= len * eps) continue;
        triangles[left] = {c, i, d};
        triangles[right] = {d, j, c};
        flippedNow[left] = flippedNow[right] = 1;
        flipped = true;
      }
      if (!flipped) return;
    }
  }

  // The triangles paired across edges that are not cuts into convex quads, the rest as triangles
  // (d = c): every piece is a patch, with its kernels and its share of the refinement budget, and a
  // patch cut once across from edge to edge is two quads again instead of four triangles. Greedy,
  // roundest quads first: a quad's worst corner has sin(angle) above kMinSine, so no corner is
  // nearly straight (a point on an edge is not a corner the bilinear map can stand).
  std::vector<std::array<int, 4>> pieces() const {
    constexpr double kMinSine = 0.2;
    auto sine = [&](int a, int b, int c) {  // at b, of the corner a-b-c (counter-clockwise: positive)
      return orient(p[a], p[b], p[c]) / (dist2(p[a], p[b]) * dist2(p[b], p[c]));
    };
    struct Pair {
      double worst;
      size_t first, second;
      std::array<int, 4> quad;
    };
    std::vector<Pair> pairs;
    for (const auto& [i, j, left, right, c, d] : freeEdges()) {
      const std::array<int, 4> quad{i, d, j, c};
      double worst = 1;
      for (int k = 0; k < 4; ++k) worst = std::min(worst, sine(quad[(k + 3) % 4], quad[k], quad[(k + 1) % 4]));
      if (worst > kMinSine) pairs.push_back({worst, left, right, quad});
    }
    std::stable_sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) { return a.worst > b.worst; });
    std::vector<char> used(triangles.size(), 0);
    std::vector<std::array<int, 4>> out;
    for (const Pair& q : pairs) {
      if (used[q.first] || used[q.second]) continue;
      used[q.first] = used[q.second] = 1;
      out.push_back(q.quad);
    }
    for (size_t t = 0; t < triangles.size(); ++t)
      if (!used[t]) out.push_back({triangles[t][0], triangles[t][1], triangles[t][2], triangles[t][2]});
    return out;
  }
};

std::vector<Vec3> patchCorners(const PatchMesh& mesh, const Patch& patch) {
  std::vector<Vec3> x;
  for (int k = 0; k < 4; ++k)
    if (k < 3 || patch.v[3] != patch.v[2]) x.push_back(mesh.positions[patch.v[k]]);
  return x;
}

// A patch the cut can work on: a proper polygon (distinct corners, its area well above rounding).
bool cuttableShape(const std::vector<Vec3>& x, const Patch& patch) {
  const size_t n = x.size();
  double perimeter = 0;
  for (size_t c = 0; c < n; ++c) {
    const double edge = length(x[(c + 1) % n] - x[c]);
    if (!(edge > 0)) return false;
    perimeter += edge;
  }
  return patch.area > 1e-9 * perimeter * perimeter && isFinite(patch.normal) && length(patch.normal) > 0.5;
}

}  // namespace

Contacts findContacts(const Scene& scene, const std::vector<bool>& cuttable) {
  Contacts contacts;
  contacts.cuttable = cuttable;
  contacts.segments.resize(scene.primitives.size());
  contacts.touched.assign(scene.primitives.size(), false);
  struct Ref {
    uint32_t primitive, triangle;
  };
  std::vector<Ref> refs;
  std::vector<Bounds> boxes;
  std::vector<Vec3> centres;
  Bounds all;
  auto corners = [&](const Ref& r) {
    const Primitive& prim = scene.primitives[r.primitive];
    const auto& t = prim.triangles[r.triangle];
    return std::array<Vec3, 3>{prim.positions[t[0]], prim.positions[t[1]], prim.positions[t[2]]};
  };
  for (size_t p = 0; p < scene.primitives.size(); ++p) {
    if (!cuttable[p]) continue;
    for (size_t t = 0; t < scene.primitives[p].triangles.size(); ++t) {
      const Ref r{uint32_t(p), uint32_t(t)};
      const auto x = corners(r);
      if (!(length(cross(x[1] - x[0], x[2] - x[0])) > 0)) continue;
      Bounds b;
      for (const Vec3& c : x) b.add(c);
      refs.push_back(r);
      boxes.push_back(b);
      centres.push_back((x[0] + x[1] + x[2]) / 3);
      all.add(b.lo);
      all.add(b.hi);
    }
  }
  if (refs.empty()) return contacts;
  // The rounding of a file's positions: Blender writes single precision, so a cube standing on a
  // floor meets it within about 1e-7 of the scene's size (the rays' offset is 1e-6 of it too).
  const double eps = 1e-6 * all.diagonal();
  contacts.epsilon = eps;
  Bvh bvh;
  bvh.order.resize(refs.size());
  for (uint32_t k = 0; k < refs.size(); ++k) bvh.order[k] = k;
  buildNode(bvh, boxes, centres, 0, uint32_t(refs.size()));

  std::set<EdgeKey> endsOn;  // source edges with a cut ending on them
  for (uint32_t r = 0; r < refs.size(); ++r) {
    const auto x = corners(refs[r]);
    const Frame f({x[0], x[1], x[2]}, normalize(cross(x[1] - x[0], x[2] - x[0])));
    Bounds box = boxes[r];
    box.lo -= Vec3{eps, eps, eps};
    box.hi += Vec3{eps, eps, eps};
    std::vector<ContactSegment> found;
    query(bvh, box, [&](uint32_t c) {
      if (c == r) return;
      for (const auto& [a, b] : meeting(f.origin, f.n, corners(refs[c]), eps))
        if (auto s = clip(f, f.at(a), f.at(b), eps)) {
          found.push_back({f.back(s->a.p), f.back(s->b.p)});
          for (const End& e : {s->a, s->b})
            if (e.edge >= 0) endsOn.insert(edgeKey(x[e.edge], x[(e.edge + 1) % 3]));
        }
    });
    if (found.empty()) continue;
    contacts.count += found.size();
    contacts.touched[refs[r].primitive] = true;
    contacts.segments[refs[r].primitive][refs[r].triangle] = std::move(found);
  }
  // A primitive across an edge where a cut ends gets the point on that edge.
  for (size_t p = 0; p < scene.primitives.size(); ++p) {
    const Primitive& prim = scene.primitives[p];
    for (size_t t = 0; t < prim.triangles.size() && cuttable[p] && !contacts.touched[p]; ++t)
      for (int e = 0; e < 3; ++e)
        if (endsOn.count(edgeKey(prim.positions[prim.triangles[t][e]], prim.positions[prim.triangles[t][(e + 1) % 3]])))
          contacts.touched[p] = true;
  }
  return contacts;
}

std::vector<PatchPieces> cutPatches(const PatchMesh& mesh, const std::vector<bool>& cuttable,
                                    const std::vector<std::vector<ContactSegment>>& segments, double eps) {
  // First each patch's cuts, and the points where they end on its edges (for the patch across).
  std::unordered_map<uint32_t, std::vector<Segment>> clipped;
  std::map<EdgeKey, std::vector<double>> edgePoints;  // t from the smaller endpoint
  for (size_t k = 0; k < mesh.patches.size(); ++k) {
    if (!cuttable[k] || segments[k].empty()) continue;
    const Patch& patch = mesh.patches[k];
    const std::vector<Vec3> x = patchCorners(mesh, patch);
    if (!cuttableShape(x, patch)) continue;
    const Frame f(x, patch.normal);
    std::vector<Segment> found;
    for (const auto& [a, b] : segments[k]) {
      const auto s = clip(f, f.at(a), f.at(b), eps);
      // Once only (a coplanar surface's inner edges come from both triangles beside them).
      auto same = [&](const Segment& o) {
        return (dist2(o.a.p, s->a.p) <= eps && dist2(o.b.p, s->b.p) <= eps) || (dist2(o.a.p, s->b.p) <= eps && dist2(o.b.p, s->a.p) <= eps);
      };
      if (s && std::none_of(found.begin(), found.end(), same)) found.push_back(*s);
      if (found.size() > kMaxCuts) break;
    }
    // A patch crossed by more cuts is in an assembly of parts pressed into each other, or under a
    // coincident copy of its own surface: it stays whole (cutting the 2CylinderEngine's took hours).
    if (found.empty() || found.size() > kMaxCuts) continue;
    const int n = int(x.size());
    for (const Segment& s : found)
      for (const End& e : {s.a, s.b}) {
        if (e.edge < 0) continue;
        const Vec3 a = x[e.edge], b = x[(e.edge + 1) % n];
        edgePoints[edgeKey(a, b)].push_back(before(b, a) ? 1 - e.t : e.t);
      }
    clipped.emplace(uint32_t(k), std::move(found));
  }
  // Points closer than eps along an edge are one (two patches clip the same wall to their edge).
  for (auto& [key, ts] : edgePoints) {
    std::sort(ts.begin(), ts.end());
    const double len = length(Vec3{std::bit_cast<double>(key[3]) - std::bit_cast<double>(key[0]),
                                   std::bit_cast<double>(key[4]) - std::bit_cast<double>(key[1]),
                                   std::bit_cast<double>(key[5]) - std::bit_cast<double>(key[2])});
    std::vector<double> kept;
    for (double t : ts)
      if (t * len > eps && (1 - t) * len > eps && (kept.empty() || (t - kept.back()) * len > eps)) kept.push_back(t);
    ts = std::move(kept);
  }

  // Then every patch with a cut or a point on an edge, triangulated.
  std::vector<PatchPieces> out;
  for (size_t k = 0; k < mesh.patches.size(); ++k) {
    if (!cuttable[k]) continue;
    const Patch& patch = mesh.patches[k];
    const std::vector<Vec3> x = patchCorners(mesh, patch);
    if (!cuttableShape(x, patch)) continue;
    const int n = int(x.size());
    const auto cuts = clipped.find(uint32_t(k));
    std::array<const std::vector<double>*, 4> onEdge{};
    bool any = cuts != clipped.end();
    for (int e = 0; e < n; ++e) {
      const auto it = edgePoints.find(edgeKey(x[e], x[(e + 1) % n]));
      if (it != edgePoints.end() && !it->second.empty()) onEdge[e] = &it->second, any = true;
    }
    if (!any) continue;
    const Frame f(x, patch.normal);
    Triangulation tr{eps, n, {}, {}, {}, {}};
    for (int c = 0; c < n; ++c) {
      Weights w{};
      w[c] = 1;
      tr.add(f.corner[c], w);
    }
    tr.triangles.push_back({0, 1, 2});
    if (n == 4) tr.triangles.push_back({0, 2, 3});
    PatchPieces pieces;
    pieces.patch = uint32_t(k);
    pieces.position = x;
    bool ok = true;
    // The points on the edges, each computed from the edge's endpoints in position order, so the
    // patches on both sides get the same bits.
    std::vector<std::pair<int, Vec3>> exact;  // point → its position
    for (int e = 0; e < n && ok; ++e) {
      if (!onEdge[e]) continue;
      const Vec3 a = x[e], b = x[(e + 1) % n];
      const bool flipped = before(b, a);
      const Vec3 lo = flipped ? b : a, hi = flipped ? a : b;
      for (double tc : *onEdge[e]) {
        const double te = flipped ? 1 - tc : tc;  // from corner e
        Weights w{};
        w[e] = 1 - te;
        w[(e + 1) % n] = te;
        const int id = tr.insert(lerp2(f.corner[e], f.corner[(e + 1) % n], te), w);
        ok &= id >= 0;
        if (id >= n) exact.push_back({id, lo + (hi - lo) * tc});
      }
    }
    if (cuts != clipped.end())
      for (const Segment& s : cuts->second) {
        if (!ok) break;
        const int a = tr.insert(s.a.p), b = tr.insert(s.b.p);
        ok = a >= 0 && b >= 0 && tr.insertSegment(a, b);
      }
    if (!ok) continue;  // rounding left a cut undecided: the patch stays whole rather than wrong
    tr.improve();
    for (size_t i = size_t(n); i < tr.p.size(); ++i) {
      Vec3 at{};
      for (int c = 0; c < n; ++c) at += x[c] * tr.weights[i][c];
      pieces.position.push_back(at);
      ok &= isFinite(at);
    }
    if (!ok) continue;
    for (const auto& [id, at] : exact) pieces.position[id] = at;
    pieces.weights = tr.weights;
    pieces.polygons = tr.pieces();
    out.push_back(std::move(pieces));
  }
  return out;
}

}  // namespace radbake

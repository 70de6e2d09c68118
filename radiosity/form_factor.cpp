#include "radiosity/form_factor.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace radbake {
namespace {

// A point closer than this (relative to the polygon's size) to the polygon's
// plane counts as "in the plane", and as "on the boundary" when that close to
// an edge. Shared vertices come from the same float data, so a vertex on a
// crease is on it to ~1e-16; 1e-10 leaves room for derived points while a
// genuine near-edge receiver (1e-6 away, say) is still integrated as such.
constexpr double kPlaneTolerance = 1e-10;

// An approach direction within this (cosine) of a source's plane is taken as lying in it.
constexpr double kGrazingApproach = 1e-6;

// Consecutive vertices closer than this (relative to size) are one vertex.
constexpr double kDuplicateTolerance = 1e-12;

// A polygon (or quadrature cell) smaller than this share of its coordinates' magnitude is rounding,
// not geometry: its corners are at most a few thousand ulps apart, so its normal, its area and the
// distances to it are noise. Contact cuts left such a triangle in the 2CylinderEngine (1.2e-12
// across at x = -159, a receiver vertex one ulp from its corner): its cells' distance ratios never
// settled and the quadrature split every cell to depth 48, stalling the whole engine's walk for hours.
constexpr double kRoundingSize = 1e-12;

double magnitude(const Bounds& b) {
  return std::max({std::abs(b.lo.x), std::abs(b.lo.y), std::abs(b.lo.z), std::abs(b.hi.x), std::abs(b.hi.y), std::abs(b.hi.z)});
}

// A quadrature cell is integrated directly once its distance to the receiver
// is at least kCellRatio times its size; otherwise it is split in four. With
// the order rule below a ratio of 1 needs 6 points per direction at 1e-6;
// a smaller ratio would trade fewer cells for higher orders, about even.
constexpr double kCellRatio = 1.0;
// Split depth limit: 2^-48 of the source is far below double resolution of
// any physically meaningful receiver distance.
constexpr int kMaxDepth = 48;
constexpr int kMaxGaussOrder = 32;
// Projected solid angles below this are rounding noise (slivers left by horizon clipping), not
// light: a bake never resolves them, and keeping them leaks 1e-33 through closed shells.
constexpr double kNegligibleLimitFactor = 1e-13;

// ---------------------------------------------------------------------------
// Polygons

struct Polygon {
  std::vector<Vec3> v;  // distinct consecutive vertices, original order
  Vec3 normal;          // unit, right-hand rule on the vertex order
  double size = 0;      // bounding-box diagonal: the length scale for tolerances
};

// Cleans the vertex list (drops consecutive duplicates, so a triangle stored
// as a quad becomes a triangle) and computes the normal with Newell's method,
// which is exact for planar polygons and robust to near-collinear vertices.
bool makePolygon(const Vec3* pts, int count, Polygon& out) {
  out.v.clear();
  if (count < 3) return false;
  Bounds bounds;
  for (int i = 0; i < count; ++i) bounds.add(pts[i]);
  out.size = bounds.diagonal();
  if (!(out.size > kRoundingSize * magnitude(bounds))) return false;
  const double dup = kDuplicateTolerance * out.size;
  for (int i = 0; i < count; ++i) {
    if (out.v.empty() || length(pts[i] - out.v.back()) > dup) out.v.push_back(pts[i]);
  }
  while (out.v.size() > 1 && length(out.v.front() - out.v.back()) <= dup) out.v.pop_back();
  if (out.v.size() < 3) return false;
  Vec3 c{};
  for (const Vec3& q : out.v) c += q;
  c = c / static_cast<double>(out.v.size());
  Vec3 area{};
  for (size_t i = 0; i < out.v.size(); ++i) {
    area += cross(out.v[i] - c, out.v[(i + 1) % out.v.size()] - c);
  }
  // |area| is twice the polygon's area, so |area| / size is about its width. A polygon narrower
  // than kRoundingSize of its coordinates' magnitude is a line to rounding, however long: its
  // normal is noise. Contact cuts left such triangles in a 2CylinderEngine part (corners in a line,
  // 8 long, 1.6e-14 wide at x = 300): their cells' horizons were noise, and one receiver touching
  // one spent 4.3 s in its quadrature for a kernel of 1e-11.
  const double len = length(area);
  if (!(len > 1e-24 * out.size * out.size) || !(len > kRoundingSize * magnitude(bounds) * out.size)) return false;
  out.normal = area / len;
  return true;
}

// Sutherland-Hodgman clip of a polygon given relative to the receiver against
// the receiver's horizon half-space n·r >= 0. Works for points and for unit
// directions alike: an arc between two directions (< pi) is the radial
// projection of their chord, and the sign of n·r is linear along the chord.
//
// `directions`: the polygon is a spherical one (the tangent cone of a crease). There the clipped
// boundary runs along the horizon great circle from where the polygon leaves it to where it comes
// back, and when those two points are antipodal (a crease edge lying in the horizon, its apex
// behind it by rounding only) the arc between them is a semicircle whose side is undetermined. A
// vertex that is behind by rounding only is moved onto the horizon instead of dropped.
void clipToHorizon(const std::vector<Vec3>& in, const Vec3& n, std::vector<Vec3>& out, bool directions = false) {
  out.clear();
  const size_t k = in.size();
  for (size_t i = 0; i < k; ++i) {
    const Vec3& a = in[i];
    const Vec3& b = in[(i + 1) % k];
    const double ga = dot(n, a);
    const double gb = dot(n, b);
    if (ga >= 0) {
      out.push_back(a);
    } else if (directions && ga > -1e-6 * length(a)) {
      out.push_back(a - n * ga);  // behind by rounding only: onto the horizon
    }
    if ((ga > 0 && gb < 0) || (ga < 0 && gb > 0)) out.push_back(a + (b - a) * (ga / (ga - gb)));
  }
}

// Lambert's contour formula on the hemisphere projection of a polygon given
// relative to the receiver (any lengths; only directions matter):
// F = (1/2π) Σ γ_i n·unit(r_{i+1} × r_i), γ_i the angle between r_i and
// r_{i+1}. Each term is the (signed) area of the projection of the edge's
// great-circle sector onto the tangent plane, i.e. the paper's elliptical
// sector of eq. 7. r_i × r_{i+1} is formed as r_i × (r_{i+1} − r_i), which
// keeps full relative precision for tiny distant polygons.
double contourSum(const std::vector<Vec3>& r, const Vec3& n) {
  const size_t k = r.size();
  if (k < 3) return 0;
  double sum = 0;
  for (size_t i = 0; i < k; ++i) {
    const Vec3& a = r[i];
    const Vec3& b = r[(i + 1) % k];
    const Vec3 c = cross(a, b - a);
    const double cl = length(c);
    if (!(cl > 0)) continue;
    const double gamma = std::atan2(cl, dot(a, b));
    sum += gamma * dot(n, c) / cl;
  }
  return std::max(0.0, -sum / (2 * kPi));
}

// Reusable buffers: the patch-patch integral evaluates the point factor
// thousands of times against the same polygon.
struct Scratch {
  std::vector<Vec3> a, b;
};

double pointFactor(const Polygon& poly, const Vec3& p, const Vec3& n, Scratch& scratch) {
  const double h = dot(poly.normal, p - poly.v[0]);
  if (!(h > kPlaneTolerance * poly.size)) return 0;  // behind or in the plane: one-sided
  scratch.a.resize(poly.v.size());
  for (size_t i = 0; i < poly.v.size(); ++i) scratch.a[i] = poly.v[i] - p;
  clipToHorizon(scratch.a, n, scratch.b);
  return contourSum(scratch.b, n);
}

// Where p touches a polygon's boundary: at a corner, inside an edge, or not at all. Measured in
// 3D against the corners and edge segments, not against the polygon's plane: a quad whose corners
// come from float data is planar only to ~1e-8 of its size, so a corner of the quad can sit that
// far off the plane fitted through it. A shared corner or edge point still coincides to the bit
// (the welder and the tessellator produce them from the same numbers), and that is what counts.
struct BoundaryFeature {
  int corner = -1, edge = -1;
  bool touches() const { return corner >= 0 || edge >= 0; }
};

BoundaryFeature boundaryFeature(const Polygon& poly, const Vec3& p, double tol) {
  BoundaryFeature f;
  const int k = static_cast<int>(poly.v.size());
  for (int i = 0; i < k && f.corner < 0; ++i) {
    if (length(p - poly.v[i]) <= tol) f.corner = i;
  }
  if (f.corner >= 0) return f;
  for (int i = 0; i < k && f.edge < 0; ++i) {
    const Vec3& a = poly.v[i];
    const Vec3 d = poly.v[(i + 1) % k] - a;
    const double lambda = std::clamp(dot(p - a, d) / dot(d, d), 0.0, 1.0);
    if (length(p - (a + d * lambda)) <= tol) f.edge = i;
  }
  return f;
}

double limitFactor(const Polygon& poly, const Vec3& p, const Vec3& n, const Vec3& approach, Scratch& scratch) {
  const BoundaryFeature feature = boundaryFeature(poly, p, kPlaneTolerance * poly.size);
  if (!feature.touches()) return pointFactor(poly, p, n, scratch);
  const int k = static_cast<int>(poly.v.size());
  const int corner = feature.corner, edge = feature.edge;
  const Vec3 a = normalize(approach);
  // Approaching from behind or within the plane. Within means up to float noise: a face and a
  // coincident face of opposite orientation (a plate modelled from both sides) differ from exactly
  // coplanar by ~1e-8 of their size, and a wedge that thin holds a negligible factor anyway.
  if (!(dot(poly.normal, a) > kGrazingApproach)) return 0;

  // Tangent cone at p: boundary rays along d1 and d2 (in the order of the
  // polygon's winding), closed at infinity by the arc of in-plane directions
  // from d1 to d2 swept counter-clockwise about the normal (the interior).
  auto inPlane = [&](const Vec3& d) { return normalize(d - poly.normal * dot(poly.normal, d)); };
  Vec3 d1, d2;
  double phi;
  if (corner >= 0) {
    d1 = inPlane(poly.v[(corner + 1) % k] - poly.v[corner]);
    d2 = inPlane(poly.v[(corner + k - 1) % k] - poly.v[corner]);
    phi = std::atan2(dot(poly.normal, cross(d1, d2)), dot(d1, d2));
    if (phi <= 0) phi += 2 * kPi;
  } else {
    d1 = inPlane(poly.v[(edge + 1) % k] - poly.v[edge]);
    d2 = -d1;
    phi = kPi;
  }
  // Seen from p + a: the apex at direction −a, the rays' far ends at d1, d2.
  // Arcs of pi or more are split so every arc is a proper (< pi) great arc.
  const int pieces = std::max(1, static_cast<int>(std::ceil(phi / (kPi / 2) - 1e-9)));
  const Vec3 e = cross(poly.normal, d1);
  std::vector<Vec3>& dirs = scratch.a;
  dirs.clear();
  dirs.push_back(-a);
  dirs.push_back(d1);
  for (int j = 1; j < pieces; ++j) {
    const double ang = phi * j / pieces;
    dirs.push_back(d1 * std::cos(ang) + e * std::sin(ang));
  }
  dirs.push_back(d2);
  clipToHorizon(dirs, n, scratch.b, true);
  return contourSum(scratch.b, n);
}

// ---------------------------------------------------------------------------
// Isoparametric quads

struct QuadMap {
  std::array<Vec3, 4> q;
  Vec3 at(double s, double t) const {
    const auto nj = shapeFunctions(s, t);
    return q[0] * nj[0] + q[1] * nj[1] + q[2] * nj[2] + q[3] * nj[3];
  }
  Vec3 ds(double t) const { return ((q[1] - q[0]) * (1 - t) + (q[2] - q[3]) * (1 + t)) * 0.25; }
  Vec3 dt(double s) const { return ((q[3] - q[0]) * (1 - s) + (q[2] - q[1]) * (1 + s)) * 0.25; }
};

// (s,t) of a point x in the quad's plane and inside it: Newton on the
// bilinear map (least squares, as x need not be exactly in the plane).
void invertBilinear(const QuadMap& m, const Vec3& x, double& s, double& t) {
  s = 0;
  t = 0;
  for (int it = 0; it < 60; ++it) {
    const Vec3 r = m.at(s, t) - x;
    const Vec3 a = m.ds(t);
    const Vec3 b = m.dt(s);
    const double aa = dot(a, a), ab = dot(a, b), bb = dot(b, b);
    const double ra = dot(r, a), rb = dot(r, b);
    const double det = aa * bb - ab * ab;
    if (!(std::abs(det) > 0)) break;
    const double dS = -(bb * ra - ab * rb) / det;
    const double dT = -(aa * rb - ab * ra) / det;
    s = std::clamp(s + dS, -1.0, 1.0);
    t = std::clamp(t + dT, -1.0, 1.0);
    if (std::abs(dS) + std::abs(dT) < 1e-15) break;
  }
}

struct NearestPoint {
  double s = 0, t = 0;
  double distance = 0;          // |p − x(s,t)|
  double boundaryDistance = 0;  // distance from p to the nearest boundary point
  bool inside = false;          // p's projection falls inside the quad
};

// The source point nearest to p, in (s,t). Edges of the bilinear map are
// straight, with s or t varying linearly along them, so the nearest boundary
// point's parameters follow from the segment parameter directly.
NearestPoint nearestPoint(const QuadMap& m, const Vec3& normal, const Vec3& p) {
  NearestPoint best;
  best.boundaryDistance = INFINITY;
  for (int e = 0; e < 4; ++e) {
    const Vec3& a = m.q[e];
    const Vec3& b = m.q[(e + 1) % 4];
    const Vec3 d = b - a;
    const double dd = dot(d, d);
    const double lambda = dd > 0 ? std::clamp(dot(p - a, d) / dd, 0.0, 1.0) : 0.0;
    const double dist = length(p - (a + d * lambda));
    if (dist < best.boundaryDistance) {
      best.boundaryDistance = dist;
      const double u = -1 + 2 * lambda;
      switch (e) {
        case 0: best.s = u; best.t = -1; break;
        case 1: best.s = 1; best.t = u; break;
        case 2: best.s = -u; best.t = 1; break;
        default: best.s = -1; best.t = -u; break;
      }
    }
  }
  best.distance = best.boundaryDistance;
  const Vec3 proj = p - normal * dot(normal, p - m.q[0]);
  bool inside = true;
  for (int e = 0; e < 4 && inside; ++e) {
    const Vec3 d = m.q[(e + 1) % 4] - m.q[e];
    if (dot(cross(d, proj - m.q[e]), normal) < 0) inside = false;
  }
  if (inside) {
    best.inside = true;
    invertBilinear(m, proj, best.s, best.t);
    best.distance = std::abs(dot(normal, p - m.q[0]));
  }
  return best;
}

// ---------------------------------------------------------------------------
// Gauss-Legendre rules (nodes on [-1,1]), built once by Newton iteration on
// the Legendre recurrence.

// P_n(x) and its derivative, by the three-term recurrence.
void legendre(int n, double x, double& p, double& dp) {
  double p0 = 1, p1 = x;
  for (int k = 2; k <= n; ++k) {
    const double p2 = ((2 * k - 1) * x * p1 - (k - 1) * p0) / k;
    p0 = p1;
    p1 = p2;
  }
  p = p1;
  dp = n * (x * p1 - p0) / (x * x - 1);
}

struct GaussRule {
  std::vector<double> x, w;
};

const GaussRule& gaussRule(int m) {
  static const std::vector<GaussRule> rules = [] {
    std::vector<GaussRule> all(kMaxGaussOrder + 1);
    for (int n = 1; n <= kMaxGaussOrder; ++n) {
      GaussRule& r = all[n];
      r.x.resize(n);
      r.w.resize(n);
      for (int i = 0; i < n; ++i) {
        double x = std::cos(kPi * (i + 0.75) / (n + 0.5));
        double p = 0, dp = 1;
        for (int it = 0; it < 100; ++it) {
          legendre(n, x, p, dp);
          const double dx = p / dp;
          x -= dx;
          if (std::abs(dx) < 1e-16) break;
        }
        legendre(n, x, p, dp);
        r.x[i] = x;
        r.w[i] = 2 / ((1 - x * x) * dp * dp);
      }
    }
    return all;
  }();
  return rules[std::clamp(m, 1, kMaxGaussOrder)];
}

// ---------------------------------------------------------------------------
// Cell quadrature of the vertex kernel over the (s,t) square.

struct KernelIntegrator {
  QuadMap map;
  Vec3 p, n;
  double tolerance = 1e-6;
  // Horizon function g(s,t) = n·(x(s,t) − p) = a + b s + c t + d s t.
  double ga = 0, gb = 0, gc = 0, gd = 0;
  std::array<double, 4> nStar{};  // subtracted shape-function values
  std::array<double, 4> acc{};    // ∫ (N_j − nStar_j) k
  double total = 0;               // ∫ k
  long evaluations = 0;

  KernelIntegrator(const std::array<Vec3, 4>& quad, const Vec3& p_, const Vec3& n_, double tol)
      : map{quad}, p(p_), n(n_), tolerance(tol) {
    double g[4];
    for (int j = 0; j < 4; ++j) g[j] = dot(n, quad[j] - p);
    ga = (g[0] + g[1] + g[2] + g[3]) / 4;
    gb = (-g[0] + g[1] + g[2] - g[3]) / 4;
    gc = (-g[0] - g[1] + g[2] + g[3]) / 4;
    gd = (g[0] - g[1] + g[2] - g[3]) / 4;
  }

  double horizon(double s, double t) const { return ga + gb * s + gc * t + gd * s * t; }

  // The integrand with both cosines clamped at 0 (one-sided source, receiver
  // horizon). The vector area element x_s × x_t carries det J and the source
  // normal together.
  void point(double s, double t, double w) {
    ++evaluations;
    const Vec3 x = map.at(s, t);
    const Vec3 r = x - p;
    const double cp = dot(n, r);
    if (!(cp > 0)) return;
    const double cq = -dot(cross(map.ds(t), map.dt(s)), r);
    if (!(cq > 0)) return;
    const double rr = dot(r, r);
    const double k = w * cp * cq / (kPi * rr * rr);
    const auto nj = shapeFunctions(s, t);
    for (int j = 0; j < 4; ++j) acc[j] += k * (nj[j] - nStar[j]);
    total += k;
  }

  // One cell, tensor Gauss-Legendre of order m. If the horizon crosses the
  // cell, integrate only its visible part: breakpoints in s where the horizon
  // curve meets t = t0, t = t1 (g is linear in s there) or where ∂g/∂t
  // vanishes, then for each s-node the visible t-interval in closed form (g is
  // linear in t). The integrand is smooth on each piece, so Gauss keeps its
  // fast convergence instead of stalling on the kink of max(0, cosθp).
  void leaf(double s0, double s1, double t0, double t1, int m) {
    const GaussRule& rule = gaussRule(m);
    const double g00 = horizon(s0, t0), g10 = horizon(s1, t0), g11 = horizon(s1, t1), g01 = horizon(s0, t1);
    const double hs = (s1 - s0) / 2, ht = (t1 - t0) / 2;
    if (g00 > 0 && g10 > 0 && g11 > 0 && g01 > 0) {
      for (int i = 0; i < m; ++i) {
        const double s = s0 + hs * (rule.x[i] + 1);
        for (int j = 0; j < m; ++j) point(s, t0 + ht * (rule.x[j] + 1), rule.w[i] * rule.w[j] * hs * ht);
      }
      return;
    }
    double br[5];
    int nb = 0;
    br[nb++] = s0;
    auto addRoot = [&](double A, double B) {  // A + B s = 0
      if (B != 0) {
        const double r = -A / B;
        if (r > s0 && r < s1) br[nb++] = r;
      }
    };
    addRoot(ga + gc * t0, gb + gd * t0);
    addRoot(ga + gc * t1, gb + gd * t1);
    addRoot(gc, gd);
    br[nb++] = s1;
    for (int i = 1; i < nb; ++i) {  // insertion sort of at most 5 values
      for (int j = i; j > 0 && br[j] < br[j - 1]; --j) std::swap(br[j], br[j - 1]);
    }
    for (int k = 0; k + 1 < nb; ++k) {
      const double sa = br[k], sb = br[k + 1];
      if (!(sb > sa)) continue;
      const double hk = (sb - sa) / 2;
      for (int i = 0; i < m; ++i) {
        const double s = sa + hk * (rule.x[i] + 1);
        const double alpha = ga + gb * s, beta = gc + gd * s;
        double lo = t0, hi = t1;
        if (beta == 0) {
          if (!(alpha > 0)) continue;
        } else {
          const double tr = -alpha / beta;
          if (beta > 0) lo = std::max(lo, tr);
          else hi = std::min(hi, tr);
        }
        if (!(hi > lo)) continue;
        const double hh = (hi - lo) / 2;
        for (int j = 0; j < m; ++j) point(s, lo + hh * (rule.x[j] + 1), rule.w[i] * rule.w[j] * hk * hh);
      }
    }
  }

  // Split toward the receiver until every cell is at least kCellRatio of its
  // own size away from p (a conservative bounding-sphere distance), which
  // grades the cells geometrically toward the nearest source point; cells
  // entirely below the horizon are skipped (g is bilinear, so its extremes
  // over a cell are at the corners).
  void cell(double s0, double s1, double t0, double t1, int depth) {
    if (!(horizon(s0, t0) > 0 || horizon(s1, t0) > 0 || horizon(s1, t1) > 0 || horizon(s0, t1) > 0)) return;
    const Vec3 c = map.at((s0 + s1) / 2, (t0 + t1) / 2);
    const double rad = std::max(std::max(length(map.at(s0, t0) - c), length(map.at(s1, t0) - c)),
                                std::max(length(map.at(s1, t1) - c), length(map.at(s0, t1) - c)));
    if (!(rad > 0)) return;
    const double ratio = (length(p - c) - rad) / (2 * rad);
    // (A cell at the rounding of its coordinates is not split further: its ratio is noise.)
    if (ratio >= kCellRatio || depth >= kMaxDepth || rad < kRoundingSize * std::max(length(c), length(p))) {
      leaf(s0, s1, t0, t1, gaussOrderForRatio(ratio, tolerance));
      return;
    }
    const double sm = (s0 + s1) / 2, tm = (t0 + t1) / 2;
    // A long, thin cell (a sliver patch's) is halved across its length only: halved both ways its
    // children were thinner than their distance needs, twice the cells for nothing.
    const double along = length(map.at(s1, tm) - map.at(s0, tm)), across = length(map.at(sm, t1) - map.at(sm, t0));
    if (along > 2 * across) {
      cell(s0, sm, t0, t1, depth + 1);
      cell(sm, s1, t0, t1, depth + 1);
      return;
    }
    if (across > 2 * along) {
      cell(s0, s1, t0, tm, depth + 1);
      cell(s0, s1, tm, t1, depth + 1);
      return;
    }
    cell(s0, sm, t0, tm, depth + 1);
    cell(sm, s1, t0, tm, depth + 1);
    cell(sm, s1, tm, t1, depth + 1);
    cell(s0, sm, tm, t1, depth + 1);
  }
};

// The bilinear map of a convex polygon with 3 or 4 vertices (a triangle as a
// quad with its last vertex repeated).
std::array<Vec3, 4> asQuad(const std::vector<Vec3>& v) {
  return {v[0], v[1], v[2], v.size() > 3 ? v[3] : v[2]};
}

// ---------------------------------------------------------------------------
// tanh-sinh (double exponential) rule on [-1,1]: nodes cluster doubly
// exponentially at both ends, so endpoint singularities of the integrand
// (x log x at an edge shared with the other patch) cost nothing extra.
// Nodes are returned as distance to the nearer end (`comp`) to keep their
// full precision there.
struct TanhSinhNode {
  double x, w;
  bool odd;  // node index odd: not a node of the next coarser level
};

std::vector<TanhSinhNode> tanhSinhNodes(double h) {
  std::vector<TanhSinhNode> nodes;
  // Beyond t = 3.2 the weights are below 2e-15 h and the nodes are within
  // 1e-16 of the ends: nothing left to add for a bounded integrand.
  const double tMax = 3.2;
  const int kMax = static_cast<int>(std::ceil(tMax / h));
  for (int k = -kMax; k <= kMax; ++k) {
    const double t = k * h;
    const double u = kPi / 2 * std::sinh(t);
    const double comp = 2 / (std::exp(2 * std::abs(u)) + 1);  // 1 − tanh|u|
    const double cu = std::cosh(u);
    const double w = h * kPi / 2 * std::cosh(t) / (cu * cu);
    nodes.push_back({u >= 0 ? 1 - comp : -1 + comp, w, (k % 2) != 0});
  }
  return nodes;
}

}  // namespace

// ---------------------------------------------------------------------------

std::array<double, 4> shapeFunctions(double s, double t) {
  return {(1 - s) * (1 - t) / 4, (1 + s) * (1 - t) / 4, (1 + s) * (1 + t) / 4, (1 - s) * (1 + t) / 4};
}

double pointPolygonFactor(const Vec3& p, const Vec3& n, const Vec3* polygon, int count) {
  Polygon poly;
  if (!makePolygon(polygon, count, poly)) return 0;
  Scratch scratch;
  return pointFactor(poly, p, n, scratch);
}

double pointPolygonFactorLimit(const Vec3& p, const Vec3& n, const Vec3& approach, const Vec3* polygon,
                               int count) {
  Polygon poly;
  if (!makePolygon(polygon, count, poly)) return 0;
  Scratch scratch;
  return limitFactor(poly, p, n, approach, scratch);
}

int gaussOrderForRatio(double ratio, double relativeTolerance) {
  // Measured rule. For one cell whose bounding sphere is `ratio` of its
  // diameter away from the receiver, the worst relative error of the m x m
  // rule over random receiver directions (facing and grazing) and random
  // receiver normals (so the horizon clips the cell) behaves like
  //   err(m) ~ C(ratio) rho^(-2m),  rho = a + sqrt(a^2 - 1),  a = 1 + 2 ratio,
  // rho being the Bernstein ellipse through the kernel's nearest complex
  // singularity. Measured per-m decay matched rho^-2 within ~20% for ratio
  // 0.5..32; the constant grows with ratio (clipped cells carry the extra
  // polynomial factor of the visible fraction), C ~ 25 (1+ratio)^2 worst seen,
  // and C = 50 (1+ratio)^2 is used as a margin. Resulting orders at 1e-6:
  // ratio 0.5 -> 8, 1 -> 6, 2 -> 5, 4..8 -> 4, 16..32 -> 3, measured worst
  // errors there 3e-8, 5e-8, 2e-8, 5e-8, 8e-8 (relative to the cell's total).
  const double r = std::max(ratio, 0.0);
  const double a = 1 + 2 * r;
  const double rho = a + std::sqrt(a * a - 1);
  const double tol = std::clamp(relativeTolerance, 1e-15, 1e-1);
  const double c = 50 * (1 + r) * (1 + r);
  const double m = std::log(c / tol) / (2 * std::log(std::max(rho, 1.0001)));
  return std::clamp(static_cast<int>(std::ceil(m)), 2, kMaxGaussOrder);
}

namespace {

std::array<double, 4> quadKernel(const Vec3& p, const Vec3& n, const Vec3& approach, const std::array<Vec3, 4>& quad,
                                 const KernelOptions& options) {
  std::array<double, 4> k{};
  Polygon poly;
  if (!makePolygon(quad.data(), 4, poly)) return k;
  const double tol = kPlaneTolerance * poly.size;
  const QuadMap map{quad};
  Scratch scratch;
  if (boundaryFeature(poly, p, tol).touches()) {
    // On the source's boundary (a crease or corner shared with the receiver's face): the limit
    // factor concentrates at p.
    const double f = limitFactor(poly, p, n, approach, scratch);
    // A cone lying behind the receiver's horizon clips to a sliver of rounding size; a crease
    // factor that small is no light at all (and would leak 1e-35 through closed corners).
    if (!(f > kNegligibleLimitFactor)) return k;
    const NearestPoint np = nearestPoint(map, poly.normal, p);
    const auto nj = shapeFunctions(np.s, np.t);
    for (int j = 0; j < 4; ++j) k[j] = nj[j] * f;
    return k;
  }
  const double h = dot(poly.normal, p - poly.v[0]);
  if (!(h > tol)) {
    if (h < -tol) return k;  // behind the source
    // In the source's plane, off its boundary: either inside it (a block standing on a floor
    // patch: approached from its own face, the source is the whole plane seen from just above
    // it, whose horizon-clipped projected solid angle is (1 − n·m)/2, all at p) or beside it,
    // seeing it edge-on.
    const NearestPoint np = nearestPoint(map, poly.normal, p);
    if (!np.inside || !(dot(approach, poly.normal) > 0)) return k;
    const double f = 0.5 * (1 - dot(n, poly.normal));
    const auto nj = shapeFunctions(np.s, np.t);
    for (int j = 0; j < 4; ++j) k[j] = nj[j] * f;
    return k;
  }
  const double f = pointFactor(poly, p, n, scratch);
  // Below this the factor is a horizon-clipping sliver of rounding size, not light.
  if (!(f > kNegligibleLimitFactor)) return k;
  const NearestPoint np = nearestPoint(map, poly.normal, p);
  KernelIntegrator integ(quad, p, n, options.relativeTolerance);
  integ.nStar = shapeFunctions(np.s, np.t);
  integ.cell(-1, 1, -1, 1, 0);
  for (int j = 0; j < 4; ++j) k[j] = integ.nStar[j] * f + integ.acc[j];
  return k;
}

}  // namespace

// A triangle comes as a quad whose last corner repeats the third. Its bilinear map's weights are the
// triangle's barycentric coordinates whichever corner is the repeated one, so each vertex's
// K is the same; but the cells' shapes are not. Repeated at a blunt corner of a sliver (a contact
// cut's, 100 long and 1e-5 wide), the map shears every cell along the whole length, and the cells
// graded toward a receiver near the long edge never get far enough from it: 1 s at 1e-3 away, 9 s
// at 1e-4, minutes closer (the whole 2CylinderEngine's walk stalled on such pairs for over half an
// hour). Repeated at the sharpest corner, the cells are thin wedges that halve along the length
// like a sliver quad's (0.5 ms). So the corner opposite the shortest edge is the repeated one.
std::array<double, 4> vertexQuadKernel(const Vec3& p, const Vec3& n, const Vec3& approach,
                                       const std::array<Vec3, 4>& quad, const KernelOptions& options) {
  if (!(quad[3] == quad[2])) return quadKernel(p, n, approach, quad, options);
  const double opposite[3] = {length(quad[1] - quad[2]), length(quad[2] - quad[0]), length(quad[0] - quad[1])};
  const int sharp = opposite[0] < opposite[1] ? (opposite[0] < opposite[2] ? 0 : 2) : (opposite[1] < opposite[2] ? 1 : 2);
  if (sharp == 2) return quadKernel(p, n, approach, quad, options);
  // The same winding, the sharp corner repeated last.
  const int a = (sharp + 1) % 3, b = (sharp + 2) % 3;
  const auto r = quadKernel(p, n, approach, {quad[a], quad[b], quad[sharp], quad[sharp]}, options);
  std::array<double, 4> k{};
  k[a] = r[0];
  k[b] = r[1];
  k[sharp] = r[2] + r[3];
  return k;
}

double quadratureQuadFactor(const Vec3& p, const Vec3& n, const std::array<Vec3, 4>& quad,
                            const KernelOptions& options) {
  Polygon poly;
  if (!makePolygon(quad.data(), 4, poly)) return 0;
  if (!(dot(poly.normal, p - poly.v[0]) > kPlaneTolerance * poly.size)) return 0;
  KernelIntegrator integ(quad, p, n, options.relativeTolerance);
  integ.cell(-1, 1, -1, 1, 0);
  return integ.total;
}

double patchPatchFactor(const Vec3* from, int fromCount, const Vec3* to, int toCount, double change) {
  Polygon a, b;
  if (!makePolygon(from, fromCount, a) || !makePolygon(to, toCount, b)) return 0;
  const double areaA = polygonArea(a.v.data(), static_cast<int>(a.v.size()));
  // Only the part of A in front of B's plane sees B; clipping A there keeps
  // the integrand smooth inside each piece (it vanishes with a kink on B's
  // plane otherwise).
  std::vector<Vec3> rel(a.v.size()), clippedRel;
  for (size_t i = 0; i < a.v.size(); ++i) rel[i] = a.v[i] - b.v[0];
  clipToHorizon(rel, b.normal, clippedRel);
  std::vector<Vec3> front;
  for (const Vec3& r : clippedRel) front.push_back(r + b.v[0]);
  Polygon part;
  if (!makePolygon(front.data(), static_cast<int>(front.size()), part)) return 0;

  // Where A touches B (a shared edge, or B standing on A's interior like a
  // box on a floor) the integrand has its x log x singularity, along an edge
  // of `part` lying in B's plane. Tanh-sinh only absorbs singularities at the
  // ends of its parameter ranges, so if the contact covers part of such an
  // edge, cut `part` across the edge at the contact's end points: every
  // singular point is then a corner of a piece and every singular segment a
  // whole edge.
  const double tol = kPlaneTolerance * std::max(a.size, b.size);
  std::vector<std::pair<Vec3, Vec3>> cuts;  // (point, cut-plane normal)
  for (size_t i = 0; i < part.v.size(); ++i) {
    const Vec3& e0 = part.v[i];
    const Vec3& e1 = part.v[(i + 1) % part.v.size()];
    if (std::abs(dot(b.normal, e0 - b.v[0])) > tol || std::abs(dot(b.normal, e1 - b.v[0])) > tol) continue;
    const Vec3 d = e1 - e0;
    double lo = 0, hi = 1;  // the part of the edge inside B (B is convex)
    for (size_t j = 0; j < b.v.size() && lo <= hi; ++j) {
      const Vec3& b0 = b.v[j];
      const Vec3 inward = normalize(cross(b.normal, b.v[(j + 1) % b.v.size()] - b0));
      const double f0 = dot(inward, e0 - b0), fd = dot(inward, d);
      if (std::abs(fd) <= 1e-12 * length(d)) {  // parallel to B's edge (e.g. the shared edge itself)
        if (f0 < -tol) hi = -1;
      } else if (fd > 0) {
        lo = std::max(lo, -f0 / fd);
      } else {
        hi = std::min(hi, -f0 / fd);
      }
    }
    if (!(hi >= lo - 1e-9)) continue;  // the edge misses B
    const double eps = 1e-9;
    for (double lambda : {lo, hi}) {
      if (lambda > eps && lambda < 1 - eps) cuts.push_back({e0 + d * lambda, normalize(d)});
    }
  }
  std::vector<std::vector<Vec3>> parts{part.v};
  for (const auto& [point, normal] : cuts) {
    std::vector<std::vector<Vec3>> next;
    for (const auto& poly : parts) {
      std::vector<Vec3> r(poly.size()), side;
      for (size_t i = 0; i < poly.size(); ++i) r[i] = poly[i] - point;
      for (double sign : {1.0, -1.0}) {
        clipToHorizon(r, normal * sign, side);
        std::vector<Vec3> piece;
        for (const Vec3& q : side) piece.push_back(q + point);
        Polygon check;
        if (makePolygon(piece.data(), static_cast<int>(piece.size()), check)) next.push_back(check.v);
      }
    }
    parts = std::move(next);
  }

  // Pieces with a bilinear parameterisation: the polygon itself if it has 3
  // or 4 vertices, else a fan of triangles (the diagonals are not singular).
  std::vector<std::array<Vec3, 4>> pieces;
  for (const auto& poly : parts) {
    if (poly.size() <= 4) {
      pieces.push_back(asQuad(poly));
    } else {
      for (size_t i = 1; i + 1 < poly.size(); ++i) pieces.push_back({poly[0], poly[i], poly[i + 1], poly[i + 1]});
    }
  }
  Vec3 centroid{};
  for (const Vec3& q : part.v) centroid += q;
  centroid = centroid / static_cast<double>(part.v.size());

  Scratch scratch;
  double total = 0;
  for (const auto& piece : pieces) {
    const QuadMap map{piece};
    // One tanh-sinh level; levels are nested (halving h keeps every old
    // node), so a finer level adds only the nodes with an odd index.
    auto level = [&](double h, bool onlyNew) {
      const auto nodes = tanhSinhNodes(h);
      double sum = 0;
      for (const auto& ns : nodes) {
        for (const auto& nt : nodes) {
          if (onlyNew && !ns.odd && !nt.odd) continue;
          const Vec3 x = map.at(ns.x, nt.x);
          const double jac = length(cross(map.ds(nt.x), map.dt(ns.x)));
          if (!(jac > 0)) continue;
          // Nodes that round onto an edge shared with B take the limit from
          // inside A (the plain factor would be 0 there, B being edge-on).
          sum += ns.w * nt.w * jac * limitFactor(b, x, a.normal, centroid - x, scratch);
        }
      }
      return sum;
    };
    double h = 0.5;
    double cur = level(h, false);
    for (int refinements = 0; refinements < 5; ++refinements) {
      h /= 2;
      const double next = cur / 4 + level(h, true);
      const double diff = std::abs(next - cur);
      cur = next;
      // Double-exponential convergence: the error of the finer level is of
      // the order of the square of the relative change (1e-8 -> ~1e-16);
      // observed 1e-9..1e-10 changes at h = 1/8 with ~1e-15 actual error.
      if (diff <= change * std::abs(cur)) break;
    }
    total += cur;
  }
  return total / areaA;
}

std::array<double, 4> shapeFunctionAreas(const std::array<Vec3, 4>& quad) {
  const QuadMap map{quad};
  const double g = 1 / std::sqrt(3.0);
  std::array<double, 4> areas{};
  for (double s : {-g, g}) {
    for (double t : {-g, g}) {
      const double jac = length(cross(map.ds(t), map.dt(s)));
      const auto nj = shapeFunctions(s, t);
      for (int j = 0; j < 4; ++j) areas[j] += nj[j] * jac;
    }
  }
  return areas;
}

double quadArea(const std::array<Vec3, 4>& quad) { return polygonArea(quad.data(), 4); }

double polygonArea(const Vec3* polygon, int count) {
  if (count < 3) return 0;
  Vec3 area{};
  for (int i = 1; i + 1 < count; ++i) area += cross(polygon[i] - polygon[0], polygon[i + 1] - polygon[0]);
  return length(area) / 2;
}

QuadPoint nearestQuadPoint(const std::array<Vec3, 4>& quad, const Vec3& p) {
  const QuadMap map{quad};
  const Vec3 normal = normalize(cross(quad[2] - quad[0], quad[3] - quad[1]));
  const NearestPoint np = nearestPoint(map, normal, p);
  return {np.s, np.t, np.distance};
}

double constantPatchFactor(const std::array<Vec3, 4>& from, const std::array<Vec3, 4>& to, double relativeTolerance) {
  Vec3 ca{}, cb{};
  for (int k = 0; k < 4; ++k) {
    ca += from[k] / 4;
    cb += to[k] / 4;
  }
  double ra = 0, rb = 0;
  for (int k = 0; k < 4; ++k) {
    ra = std::max(ra, length(from[k] - ca));
    rb = std::max(rb, length(to[k] - cb));
  }
  const double gap = length(cb - ca) - ra - rb;
  const double ratio = gap / (2 * ra);
  // Apart: the point factor is smooth over `from`; a tensor Gauss rule of the order the kernel rule
  // gives for this distance/size ratio (measured from ratio 0.5 up). Below a ratio of 1 only where
  // that order is at most 6 (36 points; at the exact transport's 1e-7 it is 7 or more there): a
  // hierarchical walk's near pairs at 1e-4, which tanh-sinh took hundreds of points for.
  const int order = gaussOrderForRatio(ratio, relativeTolerance);
  // Near: tanh-sinh, to a relative change of a hundredth of the tolerance (its error is about the
  // change squared), never finer than 1e-8.
  if (!(ratio >= 1 || (ratio >= 0.5 && order <= 6)))
    return patchPatchFactor(from.data(), 4, to.data(), 4, std::max(1e-8, relativeTolerance * 1e-2));
  const Vec3 normal = normalize(cross(from[2] - from[0], from[3] - from[1]));
  const GaussRule& rule = gaussRule(order);
  if (ratio < 1) {
    // So close, `to`'s plane may cut `from`, and the point factor vanishes there with a kink that
    // a low-order rule misses (2% off tanh-sinh on such pairs): the rule runs over the part in
    // front of that plane only, as patchPatchFactor's does, split into quads and triangles.
    const Vec3 toNormal = normalize(cross(to[2] - to[0], to[3] - to[1]));
    std::vector<Vec3> rel(4), front;
    for (int k = 0; k < 4; ++k) rel[k] = from[k] - to[0];
    clipToHorizon(rel, toNormal, front);
    if (front.size() < 3) return 0;
    for (Vec3& v : front) v += to[0];
    std::vector<std::array<Vec3, 4>> pieces;
    if (front.size() <= 4) pieces.push_back(asQuad(front));
    else for (size_t i = 1; i + 1 < front.size(); ++i) pieces.push_back({front[0], front[i], front[i + 1], front[i + 1]});
    double sum = 0;
    for (const auto& piece : pieces) {
      const QuadMap map{piece};
      for (size_t a = 0; a < rule.x.size(); ++a)
        for (size_t b = 0; b < rule.x.size(); ++b) {
          const double w = rule.w[a] * rule.w[b] * length(cross(map.ds(rule.x[b]), map.dt(rule.x[a])));
          sum += w * pointPolygonFactor(map.at(rule.x[a], rule.x[b]), normal, to.data(), 4);
        }
    }
    return sum / polygonArea(from.data(), 4);
  }
  double sum = 0, area = 0;
  for (size_t a = 0; a < rule.x.size(); ++a)
    for (size_t b = 0; b < rule.x.size(); ++b) {
      const double s = rule.x[a], t = rule.x[b];
      const auto nj = shapeFunctions(s, t);
      const Vec3 x = from[0] * nj[0] + from[1] * nj[1] + from[2] * nj[2] + from[3] * nj[3];
      const Vec3 ds = (from[1] - from[0]) * (1 - t) / 4 + (from[2] - from[3]) * (1 + t) / 4;
      const Vec3 dt = (from[3] - from[0]) * (1 - s) / 4 + (from[2] - from[1]) * (1 + s) / 4;
      const double w = rule.w[a] * rule.w[b] * length(cross(ds, dt));
      sum += w * pointPolygonFactor(x, normal, to.data(), 4);
      area += w;
    }
  return sum / area;
}

}  // namespace radbake

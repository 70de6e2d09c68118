#include "exporters/lightmap.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>

#include "core/core.h"

namespace radbake {
namespace {

// A triangle joins a chart while its normal stays within 40° of the chart's average normal so far:
// a flat wall is one chart, a cylinder five or so, and projecting onto the average plane stretches
// texels by at most about 1/cos 40° ≈ 1.3.
constexpr double kChartCos = 0.766044443118978;  // cos 40°

// A triangle whose doubled area is below this fraction of its longest edge squared (the sine of its
// flattest corner, roughly) is degenerate: its normal means nothing.
constexpr double kDegenerate = 1e-10;

constexpr uint32_t kNone = UINT32_MAX;

struct P2 {
  double x, y;
};
double cross2(P2 a, P2 b) { return a.x * b.y - a.y * b.x; }
P2 operator-(P2 a, P2 b) { return {a.x - b.x, a.y - b.y}; }

struct Chart {
  int piece = 0;
  uint32_t seed = 0;   // a triangle of the chart (in its piece)
  Vec3 normalSum;      // Σ of the triangles' cross products: twice the area-weighted normal
  Vec3 u, v;           // the projection plane: u to the right, v up, u × v = average normal
  double minU = 1e300, maxU = -1e300, minV = 1e300, maxV = -1e300;
  double area = 0;     // projected, world units²
  // Once packed: the chart's texel box and its top-left texel.
  long long width = 0, height = 0, x = 0, y = 0;
};

// One id per distinct position, so edges match across the vertices glTF duplicates at seams.
// Non-finite positions never weld (NaN has no order).
std::vector<uint32_t> weldByPosition(const std::vector<Vec3>& positions) {
  std::vector<uint32_t> order;
  for (uint32_t i = 0; i < positions.size(); ++i)
    if (isFinite(positions[i])) order.push_back(i);
  std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
    const Vec3 &p = positions[a], &q = positions[b];
    return p.x != q.x ? p.x < q.x : (p.y != q.y ? p.y < q.y : p.z < q.z);
  });
  std::vector<uint32_t> id(positions.size());
  std::iota(id.begin(), id.end(), 0u);
  for (size_t i = 1; i < order.size(); ++i)
    if (positions[order[i]] == positions[order[i - 1]]) id[order[i]] = id[order[i - 1]];
  return id;
}

// Triangles sharing an edge (by welded position): the triangles of edge group g are
// slots[groupStart[g] .. groupStart[g + 1]) / 3, and slotGroup[3t + k] is the group of t's k-th edge.
struct Adjacency {
  std::vector<uint32_t> slots, groupStart, slotGroup;
};

Adjacency adjacency(const std::vector<std::array<uint32_t, 3>>& triangles, const std::vector<uint32_t>& weld) {
  struct Edge {
    uint32_t a, b, slot;
  };
  std::vector<Edge> edges;
  edges.reserve(triangles.size() * 3);
  for (uint32_t t = 0; t < triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = weld[triangles[t][k]], b = weld[triangles[t][(k + 1) % 3]];
      if (a != b) edges.push_back({std::min(a, b), std::max(a, b), 3 * t + k});  // a collapsed edge joins nothing
    }
  std::sort(edges.begin(), edges.end(),
            [](const Edge& e, const Edge& f) { return e.a != f.a ? e.a < f.a : (e.b != f.b ? e.b < f.b : e.slot < f.slot); });
  Adjacency adj;
  adj.slotGroup.assign(triangles.size() * 3, kNone);
  adj.slots.reserve(edges.size());
  for (size_t i = 0; i < edges.size(); ++i) {
    if (i == 0 || edges[i].a != edges[i - 1].a || edges[i].b != edges[i - 1].b)
      adj.groupStart.push_back(uint32_t(i));
    adj.slotGroup[edges[i].slot] = uint32_t(adj.groupStart.size() - 1);
    adj.slots.push_back(edges[i].slot);
  }
  adj.groupStart.push_back(uint32_t(edges.size()));
  return adj;
}

// Grows the charts of one piece; returns the global chart of each triangle.
std::vector<int> growCharts(const AtlasPiece& piece, int pieceIndex, std::vector<Chart>& charts) {
  const auto& tris = piece.triangles;
  const std::vector<uint32_t> weld = weldByPosition(piece.positions);
  const Adjacency adj = adjacency(tris, weld);
  std::vector<Vec3> crossOf(tris.size());
  std::vector<double> area(tris.size(), 0);  // doubled; 0 for degenerate triangles
  for (size_t t = 0; t < tris.size(); ++t) {
    const Vec3 &a = piece.positions[tris[t][0]], &b = piece.positions[tris[t][1]], &c = piece.positions[tris[t][2]];
    const Vec3 n = cross(b - a, c - a);
    const double longest = std::max({dot(b - a, b - a), dot(c - b, c - b), dot(a - c, a - c)});
    if (length(n) > kDegenerate * longest && isFinite(n)) {  // false for NaN too
      crossOf[t] = n;
      area[t] = length(n);
    }
  }
  // Largest triangles seed first, so big flat faces claim their triangles before small bevels
  // next to them do. Degenerate triangles (area 0) come last: those no chart reached through an edge
  // join a chart they touch at a vertex (they cover nothing, so that costs no room), and only the
  // ones touching none gather into charts of their own.
  std::vector<uint32_t> seeds(tris.size());
  std::iota(seeds.begin(), seeds.end(), 0u);
  std::stable_sort(seeds.begin(), seeds.end(), [&](uint32_t a, uint32_t b) { return area[a] > area[b]; });

  std::vector<int> chartOf(tris.size(), -1);
  std::vector<int> vertexChart;  // per welded vertex, a chart using it; filled at the first degenerate seed
  std::vector<uint32_t> queue;
  for (uint32_t seed : seeds) {
    if (chartOf[seed] >= 0) continue;
    if (area[seed] == 0) {
      if (vertexChart.empty()) {
        vertexChart.assign(weld.size(), -1);
        for (size_t t = 0; t < tris.size(); ++t)
          if (chartOf[t] >= 0)
            for (uint32_t v : tris[t]) vertexChart[weld[v]] = chartOf[t];
      }
      for (uint32_t v : tris[seed])
        if (vertexChart[weld[v]] >= 0) chartOf[seed] = vertexChart[weld[v]];
      if (chartOf[seed] >= 0) {
        for (uint32_t v : tris[seed])
          if (vertexChart[weld[v]] < 0) vertexChart[weld[v]] = chartOf[seed];
        continue;
      }
    }
    const int id = int(charts.size());
    Chart chart;
    chart.piece = pieceIndex;
    chart.seed = seed;
    chart.normalSum = crossOf[seed];
    chartOf[seed] = id;
    queue.assign(1, seed);
    for (size_t head = 0; head < queue.size(); ++head) {
      const uint32_t t = queue[head];
      for (int k = 0; k < 3; ++k) {
        const uint32_t g = adj.slotGroup[3 * t + k];
        if (g == kNone) continue;
        for (uint32_t i = adj.groupStart[g]; i < adj.groupStart[g + 1]; ++i) {
          const uint32_t o = adj.slots[i] / 3;
          if (chartOf[o] >= 0) continue;
          // A degenerate triangle has no normal to disagree with: it goes with its neighbor.
          if (area[o] > 0) {
            if (dot(crossOf[o], chart.normalSum) < kChartCos * area[o] * length(chart.normalSum)) continue;
            chart.normalSum += crossOf[o];
          }
          chartOf[o] = id;
          queue.push_back(o);
        }
      }
    }
    if (!vertexChart.empty())
      for (uint32_t t : queue)
        for (uint32_t v : tris[t]) vertexChart[weld[v]] = id;
    charts.push_back(chart);
  }
  return chartOf;
}

// The projection plane of a chart: its average normal, or for a chart of degenerate triangles only,
// any plane containing its seed's longest edge (so that edge keeps its length).
void choosePlane(Chart& chart, const AtlasPiece& piece) {
  Vec3 n = normalize(chart.normalSum);
  if (n == Vec3{}) {
    const auto& t = piece.triangles[chart.seed];
    Vec3 e;
    for (int k = 0; k < 3; ++k) {
      const Vec3 d = piece.positions[t[(k + 1) % 3]] - piece.positions[t[k]];
      if (isFinite(d) && dot(d, d) > dot(e, e)) e = d;
    }
    const Vec3 axis = std::abs(e.x) <= std::abs(e.y) && std::abs(e.x) <= std::abs(e.z) ? Vec3{1, 0, 0}
                      : std::abs(e.y) <= std::abs(e.z)                                 ? Vec3{0, 1, 0}
                                                                                       : Vec3{0, 0, 1};
    n = normalize(cross(e, axis));
    if (n == Vec3{}) n = {0, 0, 1};  // every point coincides
  }
  // Duff et al., "Building an orthonormal basis, revisited" (2017): exact axes for axis normals.
  const double sign = std::copysign(1.0, n.z);
  const double a = -1 / (sign + n.z), b = n.x * n.y * a;
  chart.u = {1 + sign * n.x * n.x * a, sign * b, -sign * n.x};
  chart.v = cross(n, chart.u);
}

// Convex hull, counter-clockwise (Andrew's monotone chain); sorts `points`.
std::vector<P2> convexHull(std::vector<P2>& points) {
  std::sort(points.begin(), points.end(), [](P2 a, P2 b) { return a.x != b.x ? a.x < b.x : a.y < b.y; });
  points.erase(std::unique(points.begin(), points.end(), [](P2 a, P2 b) { return a.x == b.x && a.y == b.y; }), points.end());
  if (points.size() < 3) return points;
  std::vector<P2> hull(2 * points.size());
  size_t k = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    while (k >= 2 && cross2(hull[k - 1] - hull[k - 2], points[i] - hull[k - 2]) <= 0) --k;
    hull[k++] = points[i];
  }
  for (size_t i = points.size() - 1, lower = k + 1; i-- > 0;) {
    while (k >= lower && cross2(hull[k - 1] - hull[k - 2], points[i] - hull[k - 2]) <= 0) --k;
    hull[k++] = points[i];
  }
  hull.resize(k - 1);
  return hull;
}

// Turns the chart within its plane to its smallest bounding rectangle (which has a side along an
// edge of the hull), lying wider than tall: a curved band or a wall seen at an angle then fills its
// box instead of lying across it diagonally, and shelves of boxes waste less. `points` are the
// chart's vertices in (u, v).
void orient(Chart& chart, std::vector<P2>& points) {
  const std::vector<P2> hull = convexHull(points);
  if (hull.size() < 2) return;
  double best = std::numeric_limits<double>::infinity(), dx = 1, dy = 0, wide = 0, tall = 0;
  for (size_t i = 0; i < hull.size(); ++i) {
    const P2 e = hull[(i + 1) % hull.size()] - hull[i];
    const double len = std::hypot(e.x, e.y);
    if (!(len > 0)) continue;
    const double ex = e.x / len, ey = e.y / len;
    double lo = 1e300, hi = -1e300, lo2 = 1e300, hi2 = -1e300;
    for (const P2& p : hull) {
      const double s = p.x * ex + p.y * ey, r = p.y * ex - p.x * ey;
      lo = std::min(lo, s), hi = std::max(hi, s), lo2 = std::min(lo2, r), hi2 = std::max(hi2, r);
    }
    if ((hi - lo) * (hi2 - lo2) < best) best = (hi - lo) * (hi2 - lo2), dx = ex, dy = ey, wide = hi - lo, tall = hi2 - lo2;
  }
  const Vec3 u = chart.u * dx + chart.v * dy, v = chart.v * dx - chart.u * dy;  // still u × v = normal
  chart.u = tall > wide ? v : u;
  chart.v = tall > wide ? -u : v;
}

// Output vertices of one piece: the distinct (input vertex, chart) pairs, sorted.
uint64_t vertexKey(uint32_t vertex, int chart) { return (uint64_t(vertex) << 32) | uint32_t(chart); }

// Texels a chart spans along one side: its vertices go to the nearest texel centers (at most half a
// texel away), the first one at 0 and the last at round(extent / texelSize). Rounding rather than
// truncating keeps a side that is a whole number of texels long exactly that long when arithmetic
// noise puts its far end a hair short.
double boxSide(double extent, double texelSize) { return std::round(extent / texelSize) + 1; }

// The texel of a vertex `offset` from the chart's edge, kept inside its box.
long long snap(double offset, double texelSize, long long boxSize) {
  const double x = std::round(offset / texelSize);
  return std::isfinite(x) ? std::clamp<long long>((long long)x, 0, boxSize - 1) : 0;
}

struct Packing {
  long long width = 0, height = 0;  // used
  bool fits = false;
};

// First-fit shelf packing `width` texels wide: padded boxes, tallest first (`order`), each go onto
// the first shelf with room, else onto a new shelf below. Sets every chart's position.
long long packShelves(std::vector<Chart>& charts, const std::vector<uint32_t>& order, int padding, long long width) {
  struct Shelf {
    long long y, height, used;
  };
  std::vector<Shelf> shelves;
  long long narrowest = std::numeric_limits<long long>::max(), height = 0;
  for (const Chart& c : charts) narrowest = std::min(narrowest, c.width + padding);
  size_t open = 0;  // shelves before this one have no room left for any box
  for (uint32_t i : order) {
    Chart& c = charts[i];
    const long long w = c.width + padding;
    size_t s = open;
    while (s < shelves.size() && width - shelves[s].used < w) ++s;
    if (s == shelves.size()) {
      shelves.push_back({height, c.height + padding, 0});
      height += c.height + padding;
    }
    c.x = shelves[s].used + padding / 2;
    c.y = shelves[s].y + padding / 2;
    shelves[s].used += w;
    while (open < shelves.size() && width - shelves[open].used < narrowest) ++open;
  }
  return height;
}

// Sets the charts' texel boxes at `texelSize`; false when one alone is larger than `size` (then
// `needed` is its padded size).
bool sizeBoxes(std::vector<Chart>& charts, double texelSize, int padding, int size, double needed[2]) {
  for (Chart& c : charts) {
    const double w = boxSide(c.maxU - c.minU, texelSize), h = boxSide(c.maxV - c.minV, texelSize);
    if (!(w + padding <= size && h + padding <= size)) {
      needed[0] = w + padding;
      needed[1] = h + padding;
      return false;
    }
    c.width = (long long)w;
    c.height = (long long)h;
  }
  return true;
}

// Packs the sized boxes into at most size × size, as square as the packing allows: starting from
// the square of their total area, widening while the result comes out taller than wide.
Packing pack(std::vector<Chart>& charts, const std::vector<uint32_t>& order, int padding, int size) {
  double area = 0;
  long long widest = 0;
  for (const Chart& c : charts) {
    area += double(c.width + padding) * double(c.height + padding);
    widest = std::max(widest, c.width + padding);
  }
  long long width = std::clamp<long long>((long long)std::ceil(std::sqrt(area)), widest, size);
  long long height = 0;
  for (;;) {
    height = packShelves(charts, order, padding, width);
    if (height <= width || width >= size) break;
    width = std::min<long long>(size, std::max<long long>(width + width / 8 + 1, (long long)std::ceil(std::sqrt(double(width) * double(height)))));
  }
  Packing p;
  for (const Chart& c : charts) p.width = std::max(p.width, c.x - padding / 2 + c.width + padding);
  p.height = height;
  p.fits = height <= size;
  return p;
}

[[noreturn]] void tooLarge(const char* what, double texelSize, double w, double h, int size) {
  char line[320];
  std::snprintf(line, sizeof line,
                "radbake: lightmap: at %g world units per texel %s %.0fx%.0f texels, more than the %dx%d allowed; "
                "raise the lightmap size or the texel size",
                texelSize, what, w, h, size, size);
  throw Error(ExitCode::kUsage, line);
}

int tidy(long long used, int size) { return int(std::min<long long>(size, std::max<long long>(4, (used + 3) / 4 * 4))); }

}  // namespace

Atlas buildAtlas(const std::vector<AtlasPiece>& pieces, const AtlasOptions& options) {
  const int size = options.size, padding = options.padding;
  if (size < 1) throw Error(ExitCode::kUsage, "radbake: lightmap: the size must be at least 1 texel");
  if (padding < 0) throw Error(ExitCode::kUsage, "radbake: lightmap: the padding cannot be negative");
  if (!(options.texelSize >= 0) || !std::isfinite(options.texelSize))
    throw Error(ExitCode::kUsage, "radbake: lightmap: the texel size must be a finite number >= 0");

  std::vector<Chart> charts;
  std::vector<std::vector<int>> chartOf(pieces.size());
  std::vector<std::vector<uint64_t>> outputKeys(pieces.size());
  for (size_t p = 0; p < pieces.size(); ++p) {
    chartOf[p] = growCharts(pieces[p], int(p), charts);
    auto& keys = outputKeys[p];
    keys.reserve(pieces[p].triangles.size() * 3);
    for (size_t t = 0; t < pieces[p].triangles.size(); ++t)
      for (uint32_t v : pieces[p].triangles[t]) keys.push_back(vertexKey(v, chartOf[p][t]));
    std::sort(keys.begin(), keys.end());
    keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  }
  for (Chart& c : charts) choosePlane(c, pieces[c.piece]);
  {
    std::vector<std::vector<P2>> flat(charts.size());
    for (size_t p = 0; p < pieces.size(); ++p)
      for (uint64_t key : outputKeys[p]) {
        const Vec3& pos = pieces[p].positions[key >> 32];
        const Chart& c = charts[uint32_t(key)];
        if (isFinite(pos)) flat[uint32_t(key)].push_back({dot(pos, c.u), dot(pos, c.v)});
      }
    for (size_t c = 0; c < charts.size(); ++c) orient(charts[c], flat[c]);
  }
  for (size_t p = 0; p < pieces.size(); ++p) {
    for (uint64_t key : outputKeys[p]) {
      const Vec3& pos = pieces[p].positions[key >> 32];
      if (!isFinite(pos)) continue;
      Chart& c = charts[uint32_t(key)];
      const double u = dot(pos, c.u), v = dot(pos, c.v);
      c.minU = std::min(c.minU, u), c.maxU = std::max(c.maxU, u);
      c.minV = std::min(c.minV, v), c.maxV = std::max(c.maxV, v);
    }
    for (size_t t = 0; t < pieces[p].triangles.size(); ++t) {
      const auto& tri = pieces[p].triangles[t];
      const Vec3 &a = pieces[p].positions[tri[0]], &b = pieces[p].positions[tri[1]], &c = pieces[p].positions[tri[2]];
      Chart& chart = charts[chartOf[p][t]];
      const double projected = std::abs(dot(cross(b - a, c - a), cross(chart.u, chart.v))) / 2;
      if (std::isfinite(projected)) chart.area += projected;
    }
  }
  double area = 0, extent = 0;
  for (Chart& c : charts) {
    if (c.minU > c.maxU) c.minU = c.maxU = c.minV = c.maxV = 0;  // only non-finite positions
    area += c.area;
    extent = std::max({extent, c.maxU - c.minU, c.maxV - c.minV});
  }

  // Tallest boxes first at every texel size: a box's height only grows with its chart's extent.
  std::vector<uint32_t> order(charts.size());
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
    const double ha = charts[a].maxV - charts[a].minV, hb = charts[b].maxV - charts[b].minV;
    return ha != hb ? ha > hb : charts[a].maxU - charts[a].minU > charts[b].maxU - charts[b].minU;
  });

  double texelSize = options.texelSize;
  double needed[2] = {0, 0};
  Packing packing;
  if (texelSize > 0) {
    if (!sizeBoxes(charts, texelSize, padding, size, needed)) tooLarge("one chart needs", texelSize, needed[0], needed[1], size);
    packing = pack(charts, order, padding, size);
    if (!packing.fits) tooLarge("the charts need", texelSize, double(packing.width), double(packing.height), size);
  } else if (!charts.empty()) {
    const auto fitsAt = [&](double t) { return sizeBoxes(charts, t, padding, size, needed) && pack(charts, order, padding, size).fits; };
    // No texel size below the one where the projected area alone fills size × size, or where the
    // largest chart alone spans it, can fit; from there grow until it fits, then bisect.
    double lo = std::max(std::sqrt(area) / size, extent / size);
    if (!(lo > 0) || !std::isfinite(lo)) lo = 1;  // every chart is a point: any texel size works
    double hi = lo;
    if (!fitsAt(hi)) {
      for (;;) {
        lo = hi;
        hi *= 1.25;
        if (fitsAt(hi)) break;
        if (hi > 2 * extent) {  // every chart is down to one texel and they still do not fit
          char line[240];
          std::snprintf(line, sizeof line,
                        "radbake: lightmap: %zu charts need more than %dx%d texels even at one texel each "
                        "(with %d texels of padding); raise the lightmap size or lower the padding",
                        charts.size(), size, size, padding);
          throw Error(ExitCode::kUsage, line);
        }
      }
      for (int i = 0; i < 10; ++i) {  // to within 0.03 % of the finest texel size that fits
        const double mid = std::sqrt(lo * hi);
        (fitsAt(mid) ? hi : lo) = mid;
      }
    }
    texelSize = hi;
    sizeBoxes(charts, texelSize, padding, size, needed);
    packing = pack(charts, order, padding, size);
  }

  Atlas atlas;
  atlas.width = tidy(packing.width, size);
  atlas.height = tidy(packing.height, size);
  atlas.texelSize = texelSize;
  atlas.charts = int(charts.size());
  atlas.pieces.resize(pieces.size());
  double covered = 0;  // texels²
  for (size_t p = 0; p < pieces.size(); ++p) {
    const AtlasPiece& piece = pieces[p];
    const auto& keys = outputKeys[p];
    AtlasPieceLayout& out = atlas.pieces[p];
    std::vector<std::array<long long, 2>> texel(keys.size());
    out.vertexSource.resize(keys.size());
    out.uv.resize(keys.size());
    for (size_t i = 0; i < keys.size(); ++i) {
      const Chart& c = charts[uint32_t(keys[i])];
      const Vec3& pos = piece.positions[keys[i] >> 32];
      // Columns run along u and rows down along −v: the image shows each surface from its front.
      texel[i] = {c.x + snap(dot(pos, c.u) - c.minU, texelSize, c.width),
                  c.y + snap(c.maxV - dot(pos, c.v), texelSize, c.height)};
      out.vertexSource[i] = uint32_t(keys[i] >> 32);
      out.uv[i] = {float((texel[i][0] + 0.5) / atlas.width), float((texel[i][1] + 0.5) / atlas.height)};
    }
    out.triangles.resize(piece.triangles.size());
    out.chart = chartOf[p];
    for (size_t t = 0; t < piece.triangles.size(); ++t) {
      for (int k = 0; k < 3; ++k)
        out.triangles[t][k] = uint32_t(std::lower_bound(keys.begin(), keys.end(), vertexKey(piece.triangles[t][k], out.chart[t])) - keys.begin());
      const auto &a = texel[out.triangles[t][0]], &b = texel[out.triangles[t][1]], &c = texel[out.triangles[t][2]];
      covered += std::abs(double((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))) / 2;
    }
  }
  atlas.fill = covered / (double(atlas.width) * atlas.height);
  return atlas;
}

namespace {

// The point of triangle t nearest to p, as barycentric weights, and its distance (0 inside). Works
// for degenerate triangles too (then the nearest point of their edges).
struct Nearest {
  double distance;
  double w[3];
};

Nearest nearestPoint(const P2 t[3], P2 p) {
  const double d = cross2(t[1] - t[0], t[2] - t[0]);
  if (std::abs(d) > 1e-12) {
    const double s = cross2(p - t[0], t[2] - t[0]) / d, r = cross2(t[1] - t[0], p - t[0]) / d;
    if (s >= -1e-9 && r >= -1e-9 && 1 - s - r >= -1e-9) return {0, {1 - s - r, s, r}};
  }
  Nearest best{std::numeric_limits<double>::infinity(), {0, 0, 0}};
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3;
    const P2 e = t[j] - t[i], q = p - t[i];
    const double len2 = e.x * e.x + e.y * e.y;
    const double f = len2 > 0 ? std::clamp((q.x * e.x + q.y * e.y) / len2, 0.0, 1.0) : 0;
    const double dx = q.x - f * e.x, dy = q.y - f * e.y, dist = std::sqrt(dx * dx + dy * dy);
    if (dist < best.distance) {
      best = {dist, {0, 0, 0}};
      best.w[i] = 1 - f;
      best.w[j] = f;
    }
  }
  return best;
}

// Whether triangle t and the square [x, x+1] × [y, y+1] share some area (separating axes: the
// square's two and the three edge normals; mere contact along a line does not count).
bool overlapsTexel(const P2 t[3], double x, double y) {
  const P2 square[4] = {{x, y}, {x + 1, y}, {x, y + 1}, {x + 1, y + 1}};
  const auto separated = [&](P2 axis) {
    double lo0 = 1e300, hi0 = -1e300, lo1 = 1e300, hi1 = -1e300;
    for (int i = 0; i < 3; ++i) {
      const double s = t[i].x * axis.x + t[i].y * axis.y;
      lo0 = std::min(lo0, s), hi0 = std::max(hi0, s);
    }
    for (const P2& q : square) {
      const double s = q.x * axis.x + q.y * axis.y;
      lo1 = std::min(lo1, s), hi1 = std::max(hi1, s);
    }
    return !(lo0 < hi1 && lo1 < hi0);
  };
  if (separated({1, 0}) || separated({0, 1})) return false;
  for (int i = 0; i < 3; ++i) {
    const P2 e = t[(i + 1) % 3] - t[i];
    if ((e.x != 0 || e.y != 0) && separated({-e.y, e.x})) return false;
  }
  return true;
}

}  // namespace

LightmapImage rasterize(int width, int height, const std::vector<AtlasPieceLayout>& layout,
                        const std::vector<std::vector<Vec3>>& values) {
  LightmapImage image;
  image.width = width;
  image.height = height;
  const size_t texels = size_t(width) * size_t(height);
  image.rgb.assign(texels * 3, 0.0f);
  image.owner.assign(texels, -1);
  // A texel that a triangle only partly covers is within √½ of it; the nearest triangle of such a
  // texel is too, so every triangle looks that far around itself.
  constexpr double kReach = 0.70710678118654752 + 1e-9;
  std::vector<float> nearest(texels, std::numeric_limits<float>::infinity());  // texels
  std::vector<char> covered(texels, 0);
  for (size_t p = 0; p < layout.size(); ++p) {
    const AtlasPieceLayout& piece = layout[p];
    for (size_t i = 0; i < piece.triangles.size(); ++i) {
      P2 t[3];
      Vec3 value[3];
      bool finite = true;
      for (int k = 0; k < 3; ++k) {
        const uint32_t v = piece.triangles[i][k];
        t[k] = {double(piece.uv[v][0]) * width, double(piece.uv[v][1]) * height};
        value[k] = values[p][v];
        finite = finite && std::isfinite(t[k].x) && std::isfinite(t[k].y);
      }
      if (!finite) continue;
      const double minX = std::min({t[0].x, t[1].x, t[2].x}), maxX = std::max({t[0].x, t[1].x, t[2].x});
      const double minY = std::min({t[0].y, t[1].y, t[2].y}), maxY = std::max({t[0].y, t[1].y, t[2].y});
      const int x0 = int(std::clamp(std::floor(minX) - 1, 0.0, double(width))), x1 = int(std::clamp(std::floor(maxX) + 1, -1.0, width - 1.0));
      const int y0 = int(std::clamp(std::floor(minY) - 1, 0.0, double(height))), y1 = int(std::clamp(std::floor(maxY) + 1, -1.0, height - 1.0));
      for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x) {
          const Nearest q = nearestPoint(t, {x + 0.5, y + 0.5});
          if (q.distance > kReach) continue;
          const size_t k = size_t(y) * width + x;
          if (q.distance == 0 || overlapsTexel(t, x, y)) covered[k] = 1;
          if (q.distance < nearest[k]) {
            nearest[k] = float(q.distance);
            const Vec3 c = value[0] * q.w[0] + value[1] * q.w[1] + value[2] * q.w[2];
            image.rgb[3 * k] = float(c.x), image.rgb[3 * k + 1] = float(c.y), image.rgb[3 * k + 2] = float(c.z);
            image.owner[k] = piece.chart[i];
          }
        }
    }
  }
  for (size_t k = 0; k < texels; ++k)
    if (!covered[k] && image.owner[k] >= 0) {  // near a triangle, but no triangle reaches into it
      image.owner[k] = -1;
      image.rgb[3 * k] = image.rgb[3 * k + 1] = image.rgb[3 * k + 2] = 0;
    }
  return image;
}

std::string lightmapLayoutProblem(int width, int height, const std::vector<AtlasPieceLayout>& layout) {
  // Coordinates in 1/256 texel, as GPUs snap vertices: the edge functions below are then exact, and
  // a center on an edge belongs to the triangle on one fixed side of it (a center on a vertex, to
  // the one triangle of the fan that the direction (−1, −ε) leads into), so triangles that only
  // share edges and vertices never claim a texel twice.
  constexpr long long kSub = 256;
  const size_t texels = size_t(width) * size_t(height);
  std::vector<uint64_t> claim(texels, 0);  // (piece << 32 | triangle) + 1; 0: free
  char line[256];
  for (size_t p = 0; p < layout.size(); ++p) {
    const AtlasPieceLayout& piece = layout[p];
    for (size_t i = 0; i < piece.triangles.size(); ++i) {
      long long X[3], Y[3];
      for (int k = 0; k < 3; ++k) {
        const uint32_t v = piece.triangles[i][k];
        const float u = piece.uv[v][0], w = piece.uv[v][1];
        if (!(u >= 0 && u <= 1 && w >= 0 && w <= 1)) {
          std::snprintf(line, sizeof line, "piece %zu vertex %u has UV (%g, %g), outside [0, 1]", p, v, u, w);
          return line;
        }
        X[k] = std::llround(double(u) * width * kSub);
        Y[k] = std::llround(double(w) * height * kSub);
      }
      const long long area = (X[1] - X[0]) * (Y[2] - Y[0]) - (Y[1] - Y[0]) * (X[2] - X[0]);
      if (area == 0) continue;  // claims no texel
      if (area < 0) std::swap(X[1], X[2]), std::swap(Y[1], Y[2]);
      const auto first = [](long long lo) { return (lo - kSub / 2 + kSub - 1) / kSub; };  // lowest center ≥ lo (lo ≥ 0)
      const long long x0 = first(std::min({X[0], X[1], X[2]})), x1 = std::min<long long>(width - 1, (std::max({X[0], X[1], X[2]}) - kSub / 2) / kSub);
      const long long y0 = first(std::min({Y[0], Y[1], Y[2]})), y1 = std::min<long long>(height - 1, (std::max({Y[0], Y[1], Y[2]}) - kSub / 2) / kSub);
      for (long long y = y0; y <= y1; ++y)
        for (long long x = x0; x <= x1; ++x) {
          const long long cx = x * kSub + kSub / 2, cy = y * kSub + kSub / 2;
          bool inside = true;
          for (int k = 0; k < 3 && inside; ++k) {
            const int j = (k + 1) % 3;
            const long long dx = X[j] - X[k], dy = Y[j] - Y[k];
            const long long e = dx * (cy - Y[k]) - dy * (cx - X[k]);
            inside = e > 0 || (e == 0 && (dy > 0 || (dy == 0 && dx < 0)));
          }
          if (!inside) continue;
          uint64_t& c = claim[size_t(y) * width + x];
          const uint64_t mine = ((uint64_t(p) << 32) | i) + 1;
          if (c != 0) {
            std::snprintf(line, sizeof line, "piece %zu triangle %zu overlaps piece %llu triangle %llu at texel (%lld, %lld)",
                          p, i, (unsigned long long)((c - 1) >> 32), (unsigned long long)((c - 1) & 0xffffffffu), x, y);
            return line;
          }
          c = mine;
        }
    }
  }
  return "";
}

void dilate(LightmapImage& image) {
  const int w = image.width, h = image.height;
  std::vector<char> filled(image.owner.size(), 0);
  std::vector<size_t> queue;  // breadth first from every written texel at once; each texel enters once
  queue.reserve(image.owner.size());
  for (size_t k = 0; k < image.owner.size(); ++k)
    if (image.owner[k] >= 0) filled[k] = 1, queue.push_back(k);
  for (size_t head = 0; head < queue.size(); ++head) {
    const size_t k = queue[head];
    const int x = int(k % w), y = int(k / w);
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int nx = x + dx, ny = y + dy;
        if (nx < 0 || ny < 0 || nx >= w || ny >= h) continue;
        const size_t n = size_t(ny) * w + nx;
        if (filled[n]) continue;
        filled[n] = 1;
        std::copy_n(&image.rgb[3 * k], 3, &image.rgb[3 * n]);
        queue.push_back(n);
      }
  }
}

}  // namespace radbake

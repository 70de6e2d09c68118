#include "tessellate/tessellate.h"

#include <algorithm>
#include <limits>
#include <bit>
#include <cmath>
#include <map>
#include <tuple>
#include <unordered_map>

namespace radbake {
namespace {

constexpr uint32_t kUnused = UINT32_MAX;

// Welding key: exact position bits (edge points are computed canonically, so coincident points are
// bit-identical), the normal rounded to 1e-6 (a smooth surface's normals agree to rounding, a crease
// differs by far more), and the material.
struct WeldKey {
  uint64_t px, py, pz;
  int64_t nx, ny, nz;
  int material;
  bool operator==(const WeldKey&) const = default;
};
struct WeldHash {
  size_t operator()(const WeldKey& k) const {
    size_t h = 1469598103934665603ull;
    for (uint64_t v : {k.px, k.py, k.pz, uint64_t(k.nx), uint64_t(k.ny), uint64_t(k.nz), uint64_t(k.material)})
      h = (h ^ v) * 1099511628211ull;
    return h;
  }
};

uint64_t bits(double v) { return std::bit_cast<uint64_t>(v == 0.0 ? 0.0 : v); }  // -0 welds with +0

struct Welder {
  PatchMesh& mesh;
  std::unordered_map<WeldKey, uint32_t, WeldHash> index;

  uint32_t vertex(const Vec3& p, const Vec3& n, int material) {
    const WeldKey key{bits(p.x), bits(p.y), bits(p.z), std::llround(n.x * 1e6), std::llround(n.y * 1e6),
                      std::llround(n.z * 1e6), material};
    auto [it, inserted] = index.try_emplace(key, uint32_t(mesh.positions.size()));
    if (inserted) {
      mesh.positions.push_back(p);
      mesh.normals.push_back(n);
      mesh.vertexMaterial.push_back(material);
    }
    return it->second;
  }
};

// Identity of a grid point on the source primitive, so output vertices stay split wherever the
// glTF vertices were (UV seams) and shared wherever they were shared.
using PointId = std::tuple<int, uint32_t, uint32_t, int, int>;  // kind, a, b, i, j

Vec3 lerp(const Vec3& a, const Vec3& b, double t) { return a + (b - a) * t; }

int subdivisionFor(const Primitive& prim, const TessellateOptions& options) {
  int n = std::max(1, options.subdivide);
  if (options.maxEdgeLength > 0) {
    double longest = 0;
    for (const auto& t : prim.triangles)
      for (int e = 0; e < 3; ++e)
        longest = std::max(longest, length(prim.positions[t[(e + 1) % 3]] - prim.positions[t[e]]));
    n = std::max(n, int(std::ceil(longest / options.maxEdgeLength - 1e-9)));
  }
  return n;
}

Vec3 faceNormal(const Primitive& prim, const std::array<uint32_t, 3>& t) {
  return normalize(cross(prim.positions[t[1]] - prim.positions[t[0]], prim.positions[t[2]] - prim.positions[t[0]]));
}

// A face to tessellate: a quad (q0..q3, counter-clockwise) made of two coplanar triangles, or a
// triangle stored as (a, b, c, c). `triangles` are the source triangles it covers.
struct Face {
  std::array<uint32_t, 4> q;
  std::array<int, 2> triangles{-1, -1};
  Vec3 normal;
};

bool isConvexQuad(const std::array<Vec3, 4>& p, const Vec3& n) {
  for (int i = 0; i < 4; ++i)
    if (dot(cross(p[(i + 1) % 4] - p[i], p[(i + 2) % 4] - p[(i + 1) % 4]), n) <= 0) return false;
  return true;
}

// Pairs coplanar triangles that share an edge and form a convex quad into one patch (the paper's
// quadrilateral element): a square face of two triangles becomes one bilinear patch, so a K×K split
// has (K+1)² unknowns. Flat-shaded primitives (no NORMAL) are paired only when exactly coplanar.
std::vector<Face> buildFaces(const Primitive& prim) {
  constexpr double kCoplanarCos = 1 - 1e-12;
  std::map<std::pair<uint32_t, uint32_t>, int> edgeOwner;  // directed edge → triangle
  for (size_t i = 0; i < prim.triangles.size(); ++i)
    for (int e = 0; e < 3; ++e) edgeOwner[{prim.triangles[i][e], prim.triangles[i][(e + 1) % 3]}] = int(i);
  std::vector<bool> used(prim.triangles.size(), false);
  std::vector<Face> faces;
  for (size_t i = 0; i < prim.triangles.size(); ++i) {
    if (used[i]) continue;
    const auto& t = prim.triangles[i];
    const Vec3 n = faceNormal(prim, t);
    used[i] = true;
    // Try the longest edge first: a quad's diagonal.
    std::array<int, 3> order{0, 1, 2};
    auto edgeLength = [&](int e) { return length(prim.positions[t[(e + 1) % 3]] - prim.positions[t[e]]); };
    std::sort(order.begin(), order.end(), [&](int a, int b) { return edgeLength(a) > edgeLength(b); });
    bool paired = false;
    for (int e : order) {
      const uint32_t a = t[e], b = t[(e + 1) % 3], c = t[(e + 2) % 3];
      auto it = edgeOwner.find({b, a});
      if (it == edgeOwner.end() || used[it->second]) continue;
      const auto& u = prim.triangles[it->second];
      const Vec3 m = faceNormal(prim, u);
      if (dot(n, m) < kCoplanarCos) continue;
      uint32_t d = u[0] == a || u[0] == b ? (u[1] == a || u[1] == b ? u[2] : u[1]) : u[0];
      if (d == a || d == b || d == c) continue;
      // Quad (b, c, a, d) counter-clockwise: triangle (a, b, c) then (b, a, d) across edge a–b.
      const std::array<uint32_t, 4> q{b, c, a, d};
      const std::array<Vec3, 4> p{prim.positions[q[0]], prim.positions[q[1]], prim.positions[q[2]], prim.positions[q[3]]};
      if (!isConvexQuad(p, n)) continue;
      used[it->second] = true;
      faces.push_back({q, {int(i), it->second}, n});
      paired = true;
      break;
    }
    if (!paired) faces.push_back({{t[0], t[1], t[2], t[2]}, {int(i), -1}, n});
  }
  return faces;
}

// Barycentric weights of point x (in the plane) on source triangle t.
SurfacePoint locate(const Primitive& prim, const Face& face, const Vec3& x) {
  SurfacePoint best;
  double bestOutside = std::numeric_limits<double>::infinity();
  for (int ti : face.triangles) {
    if (ti < 0) continue;
    const auto& t = prim.triangles[ti];
    const Vec3 a = prim.positions[t[0]], e1 = prim.positions[t[1]] - a, e2 = prim.positions[t[2]] - a, r = x - a;
    const double d11 = dot(e1, e1), d12 = dot(e1, e2), d22 = dot(e2, e2), r1 = dot(r, e1), r2 = dot(r, e2);
    const double det = d11 * d22 - d12 * d12;
    const double w1 = (d22 * r1 - d12 * r2) / det, w2 = (d11 * r2 - d12 * r1) / det;
    const double outside = std::max({0.0, -w1, -w2, w1 + w2 - 1});
    if (outside < bestOutside) {
      bestOutside = outside;
      best = {uint32_t(ti), std::clamp(w1, 0.0, 1.0), std::clamp(w2, 0.0, 1.0)};
    }
  }
  return best;
}

void tessellatePrimitive(const Scene& scene, int primIndex, int n, bool flat, Welder& welder, PatchMesh& mesh) {
  const Primitive& prim = scene.primitives[primIndex];
  PrimitivePatches& out = mesh.primitives[primIndex];
  const int material = prim.material;
  const std::vector<Face> faces = buildFaces(prim);

  // The receiving normal at a point of a face: the file's vertex normals interpolated on a smooth
  // surface, the face normal where the file has none (glTF: flat shading).
  auto normalAt = [&](const Face& f, const std::array<double, 4>& w) {
    if (!prim.hasNormals) return f.normal;
    Vec3 s{};
    for (int k = 0; k < 4; ++k) s += prim.normals[f.q[k]] * w[k];
    return length(s) > 0 ? normalize(s) : f.normal;
  };
  auto quadArea = [&](const std::array<Vec3, 4>& p) {
    return 0.5 * length(cross(p[2] - p[0], p[3] - p[1]));  // planar quad (or triangle with p2 == p3)
  };

  if (n == 1 && !flat) {
    // Keep the glTF vertices when every vertex welds to exactly one patch vertex.
    out.patchVertex.assign(prim.positions.size(), kUnused);
    bool keeps = true;
    const size_t firstPatch = mesh.patches.size();
    for (const Face& f : faces) {
      Patch patch{{}, material, primIndex, f.normal, 0};
      for (int k = 0; k < 4; ++k) {
        std::array<double, 4> w{};
        w[k] = 1;
        const uint32_t pv = welder.vertex(prim.positions[f.q[k]], normalAt(f, w), material);
        if (out.patchVertex[f.q[k]] != kUnused && out.patchVertex[f.q[k]] != pv) keeps = false;
        out.patchVertex[f.q[k]] = pv;
        patch.v[k] = pv;
      }
      patch.area = quadArea({prim.positions[f.q[0]], prim.positions[f.q[1]], prim.positions[f.q[2]], prim.positions[f.q[3]]});
      mesh.patches.push_back(patch);
    }
    if (keeps) return;
    mesh.patches.resize(firstPatch);  // a flat-shaded vertex split by the normals: new vertices below
    out.patchVertex.clear();
  }

  out.keepsSourceVertices = false;
  // Output vertices: one per source point and patch vertex (a flat-shaded vertex shared by faces
  // of different normals becomes one output vertex per face).
  std::map<std::pair<PointId, uint32_t>, uint32_t> outputIndex;
  std::vector<uint32_t> grid((n + 1) * (n + 1)), outGrid((n + 1) * (n + 1));
  std::vector<SurfacePoint> gridSource((n + 1) * (n + 1));
  for (size_t fi = 0; fi < faces.size(); ++fi) {
    const Face& f = faces[fi];
    const bool triangle = f.q[2] == f.q[3];
    std::array<Vec3, 4> corner;
    for (int k = 0; k < 4; ++k) corner[k] = prim.positions[f.q[k]];
    // Points on a face edge are computed from the edge's endpoints in index order, so the
    // neighbouring face produces the same bits and the two weld.
    auto edgePoint = [&](uint32_t va, uint32_t vb, int k) -> std::pair<Vec3, PointId> {
      if (k == 0 || va == vb) return {prim.positions[va], {0, va, 0, 0, 0}};
      if (k == n) return {prim.positions[vb], {0, vb, 0, 0, 0}};
      if (va > vb) { std::swap(va, vb); k = n - k; }
      return {lerp(prim.positions[va], prim.positions[vb], double(k) / n), {1, va, vb, k, 0}};
    };
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) {
        const double s = double(i) / n, t = double(j) / n;
        const std::array<double, 4> w{(1 - s) * (1 - t), s * (1 - t), s * t, (1 - s) * t};
        std::pair<Vec3, PointId> point;
        if (j == 0) point = edgePoint(f.q[0], f.q[1], i);
        else if (j == n) point = edgePoint(f.q[3], f.q[2], i);
        else if (i == 0) point = edgePoint(f.q[0], f.q[3], j);
        else if (i == n) point = edgePoint(f.q[1], f.q[2], j);
        else point = {corner[0] * w[0] + corner[1] * w[1] + corner[2] * w[2] + corner[3] * w[3], {2, uint32_t(fi), 0, i, j}};
        const uint32_t pv = welder.vertex(point.first, normalAt(f, w), material);
        grid[j * (n + 1) + i] = pv;
        if (flat) {
          gridSource[j * (n + 1) + i] = locate(prim, f, point.first);
          continue;
        }
        auto [it, inserted] = outputIndex.try_emplace({point.second, pv}, uint32_t(out.patchVertex.size()));
        if (inserted) {
          out.patchVertex.push_back(pv);
          out.source.push_back(locate(prim, f, point.first));
        }
        outGrid[j * (n + 1) + i] = it->second;
      }
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const int c0 = j * (n + 1) + i, c1 = c0 + 1, c2 = c0 + n + 2, c3 = c0 + n + 1;
        Patch patch{{grid[c0], grid[c1], grid[c2], grid[c3]}, material, primIndex, f.normal, 0};
        const bool collapsed = triangle && j == n - 1;  // the top row of a triangle: triangles
        patch.area = quadArea({mesh.positions[grid[c0]], mesh.positions[grid[c1]], mesh.positions[grid[c2]],
                               mesh.positions[grid[c3]]});
        mesh.patches.push_back(patch);
        if (flat) {
          // Own output vertices per patch, so a viewer shows the patch's one value flat.
          const uint32_t first = uint32_t(out.patchVertex.size());
          for (int c : {c0, c1, c2, c3}) {
            out.patchVertex.push_back(grid[c]);
            out.source.push_back(gridSource[c]);
            out.patch.push_back(uint32_t(mesh.patches.size() - 1));
          }
          out.triangles.push_back({first, first + 1, first + 2});
          if (!collapsed) out.triangles.push_back({first, first + 2, first + 3});
          continue;
        }
        out.triangles.push_back({outGrid[c0], outGrid[c1], outGrid[c2]});
        if (!collapsed) out.triangles.push_back({outGrid[c0], outGrid[c2], outGrid[c3]});
      }
  }
}

}  // namespace

PatchMesh tessellate(const Scene& scene, const TessellateOptions& options) {
  PatchMesh mesh;
  mesh.primitives.resize(scene.primitives.size());
  Welder welder{mesh, {}};
  for (size_t p = 0; p < scene.primitives.size(); ++p)
    tessellatePrimitive(scene, int(p), subdivisionFor(scene.primitives[p], options), options.flatPatches, welder, mesh);
  return mesh;
}

}  // namespace radbake

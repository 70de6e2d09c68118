#include "tessellate/tessellate.h"
#include "tessellate/contact.h"
#include "tessellate/subdivision.h"

#include <algorithm>
#include <filesystem>
#include <limits>
#include <bit>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <tuple>
#include <unordered_map>
#include <unordered_set>

namespace radbake {
namespace {

constexpr uint32_t kUnused = UINT32_MAX;
constexpr int kMaxRate = 4096;                 // per face edge, as --subdivide allows
constexpr size_t kMaxPatches = size_t(1) << 24;  // 16.7M patches: past this a bake cannot finish
constexpr int kMaxCurvedRate = 256;              // per patch edge, on curved surfaces
// What a patch holds from tessellation to solve (its vertices, the ray-tracing structure, the
// solver's state): the estimate checked against --max-memory before a subdivision is made.
constexpr double kBytesPerPatch = 1024;

// Refuses `patches` past the patch limit or the memory budget; `what` names the surface.
void checkPatchBudget(double patches, const TessellateOptions& options, const std::string& file, const std::string& what) {
  if (patches > double(kMaxPatches))
    throw Error(ExitCode::kUnsupported, file + ": " + what + " would need more than " + std::to_string(kMaxPatches) +
                                            " patches at this subdivision");
  if (patches * kBytesPerPatch > double(options.maxMemoryBytes))
    throw Error(ExitCode::kUnsupported, file + ": " + what + " would need " + std::to_string(uint64_t(patches)) +
                                            " patches, about " + formatBytes(patches * kBytesPerPatch) +
                                            ", past the memory budget of " + formatBytes(double(options.maxMemoryBytes)) +
                                            " (--max-memory)");
}

std::string fileName(const Scene& scene) { return std::filesystem::path(scene.path).filename().string(); }

// A chord the finest curved rate cannot meet is a mistake in the options, not a reason to
// tessellate forever (--max-chord 1e-12 on a teapot).
[[noreturn]] void chordUnreachable(const TessellateOptions& options, double reached, const std::string& what) {
  char asked[32], text[32];
  std::snprintf(asked, sizeof asked, "%g", options.maxChord);
  std::snprintf(text, sizeof text, "%.3g", reached);
  throw Error(ExitCode::kUsage, std::string("radbake: --max-chord ") + asked + " cannot be met: " + what +
                                    " at the finest rate (" + std::to_string(kMaxCurvedRate) + " per patch edge) is still " +
                                    text + " from the surface");
}

// Welding: exact position bits (edge points are computed canonically, so coincident points are
// bit-identical) and the material; among vertices at that point, the first whose normal is within
// the surface's crease angle. glTF faces weld only with equal normals (to rounding); a smooth
// curved surface welds across its patch seams.
struct WeldKey {
  uint64_t px, py, pz;
  int material;
  bool operator==(const WeldKey&) const = default;
};
struct WeldHash {
  size_t operator()(const WeldKey& k) const { return hashWords(std::array<uint64_t, 4>{k.px, k.py, k.pz, uint64_t(k.material)}); }
};

constexpr double kSameNormalCos = 1 - 1e-10;  // glTF vertices: the same normal up to rounding
constexpr double kSmoothSeamCos = 0.98480775301220802;  // cos 10°: a curved surface's seams weld below this

struct Welder {
  PatchMesh& mesh;
  std::unordered_map<WeldKey, std::vector<uint32_t>, WeldHash> index;

  uint32_t vertex(const Vec3& p, const Vec3& n, int material, double minCos = kSameNormalCos) {
    auto& candidates = index[WeldKey{keyBits(p.x), keyBits(p.y), keyBits(p.z), material}];
    for (uint32_t c : candidates)
      if (dot(mesh.normals[c], n) >= minCos) return c;
    candidates.push_back(uint32_t(mesh.positions.size()));
    mesh.positions.push_back(p);
    mesh.normals.push_back(n);
    mesh.vertexMaterial.push_back(material);
    return candidates.back();
  }
};

// Identity of a grid point on the source primitive, so output vertices stay split wherever the
// glTF vertices were (UV seams) and shared wherever they were shared.
using PointId = std::tuple<int, uint32_t, uint32_t, int, int>;  // kind, a, b, i, j

Vec3 lerp(const Vec3& a, const Vec3& b, double t) { return a + (b - a) * t; }

// A primitive's subdivision scheme: its own (flagged in the file), else --subdivision-surfaces.
SubdivisionScheme schemeOf(const Primitive& prim, const TessellateOptions& options) {
  return prim.subdivision != SubdivisionScheme::kNone ? prim.subdivision : options.subdivisionSurfaces;
}

int subdivisionFor(const Primitive& prim, const TessellateOptions& options) {
  int n = std::max(1, options.subdivide);
  if (options.maxEdgeLength > 0) {
    double longest = 0;
    for (const auto& t : prim.triangles)
      for (int e = 0; e < 3; ++e)
        longest = std::max(longest, length(prim.positions[t[(e + 1) % 3]] - prim.positions[t[e]]));
    n = std::max(n, int(std::clamp(std::ceil(longest / options.maxEdgeLength - 1e-9), 1.0, double(kMaxRate))));
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

// ---- Textures ------------------------------------------------------------------------------

using UV = std::array<double, 2>;

// The texture averaged over a patch (corner UVs, bilinear between them): a grid of bilinearly
// filtered samples about one texel apart, each weighted by the patch's area element there (for a
// triangle patch, v2 == v3, the map squeezes toward the apex), so the average is over the area.
Vec3 averageTexture(const Scene& scene, const TextureRef& ref, const std::array<UV, 4>& uv, const std::array<Vec3, 4>& x) {
  const Texture& t = scene.textures[ref.texture];
  double extent = 0;
  for (int a = 0; a < 4; ++a)
    for (int b = a + 1; b < 4; ++b)
      extent = std::max(extent, std::hypot((uv[a][0] - uv[b][0]) * t.width * ref.scale[0], (uv[a][1] - uv[b][1]) * t.height * ref.scale[1]));
  const int m = int(std::clamp(std::ceil(extent), 2.0, 64.0));  // extent may be huge or NaN-free but absurd
  Vec3 sum{};
  double weight = 0;
  for (int j = 0; j < m; ++j)
    for (int i = 0; i < m; ++i) {
      const double s = (i + 0.5) / m, r = (j + 0.5) / m;
      const double w[4] = {(1 - s) * (1 - r), s * (1 - r), s * r, (1 - s) * r};
      double u = 0, v = 0;
      for (int k = 0; k < 4; ++k) {
        u += w[k] * uv[k][0];
        v += w[k] * uv[k][1];
      }
      const Vec3 ds = (x[1] - x[0]) * (1 - r) + (x[2] - x[3]) * r;
      const Vec3 dr = (x[3] - x[0]) * (1 - s) + (x[2] - x[1]) * s;
      const double area = length(cross(ds, dr));
      sum += sampleTexture(scene, ref, u, v) * area;
      weight += area;
    }
  return weight > 0 ? sum / weight : Vec3{1, 1, 1};
}

// A patch's reflectance and emission: the material's factors times its textures averaged over the
// patch. `cornerUV(k, set)` gives corner k's TEXCOORD_set.
template <typename CornerUV>
void shade(const Scene& scene, const Primitive& prim, PatchMesh& mesh, Patch& patch, const CornerUV& cornerUV) {
  const Material& m = scene.materials[patch.material];
  patch.reflectance = m.reflectance;
  patch.emission = m.emission;
  auto textured = [&](const TextureRef& ref) -> std::optional<Vec3> {
    if (ref.texture < 0 || !hasTexcoords(prim, ref.texCoord)) return std::nullopt;
    std::array<UV, 4> uv;
    for (int k = 0; k < 4; ++k) uv[k] = cornerUV(k, ref.texCoord);
    return averageTexture(scene, ref, uv, {mesh.positions[patch.v[0]], mesh.positions[patch.v[1]], mesh.positions[patch.v[2]], mesh.positions[patch.v[3]]});
  };
  if (m.alphaMask) {
    // The cut-out: occlusion tests the mask where rays hit; the patch reflects and emits in
    // proportion to its opaque part (a 4×4 estimate of the covered fraction).
    PatchMask mask;
    mask.texture = m.baseColorTexture;
    mask.baseAlpha = m.baseAlpha;
    mask.cutoff = m.alphaCutoff;
    const bool textured = hasTexcoords(prim, m.baseColorTexture.texCoord) && m.baseColorTexture.texture >= 0;
    for (int k = 0; k < 4; ++k) mask.uv[k] = textured ? cornerUV(k, m.baseColorTexture.texCoord) : UV{0, 0};
    if (!textured) mask.texture.texture = -1;
    int opaque = 0;
    for (int j = 0; j < 4; ++j)
      for (int i = 0; i < 4; ++i) {
        const double s = (i + 0.5) / 4, r = (j + 0.5) / 4;
        const double w[4] = {(1 - s) * (1 - r), s * (1 - r), s * r, (1 - s) * r};
        double u = 0, v = 0;
        for (int k = 0; k < 4; ++k) {
          u += w[k] * mask.uv[k][0];
          v += w[k] * mask.uv[k][1];
        }
        opaque += mask.baseAlpha * sampleAlpha(scene, mask.texture, u, v) >= mask.cutoff;
      }
    patch.coverage = opaque / 16.0;
    patch.mask = int(mesh.masks.size());
    mesh.masks.push_back(mask);
    patch.shaded = true;
  }
  if (auto t = textured(m.baseColorTexture)) {
    patch.reflectance = {m.reflectance.x * t->x, m.reflectance.y * t->y, m.reflectance.z * t->z};
    patch.shaded = true;
  }
  if (auto t = textured(m.emissiveTexture)) {
    patch.emission = {m.emission.x * t->x, m.emission.y * t->y, m.emission.z * t->z};
    patch.shaded = true;
  }
  patch.reflectance *= patch.coverage;
  patch.emission *= patch.coverage;
}

// Patches not shaded by a texture carry their material's values; each vertex gets the
// area-weighted mean of its patches' (exactly the patch value where they all agree).
void finishShading(const Scene& scene, PatchMesh& mesh) {
  for (Patch& p : mesh.patches)
    if (!p.shaded) {
      p.reflectance = scene.materials[p.material].reflectance;
      p.emission = scene.materials[p.material].emission;
    }
  const size_t n = mesh.positions.size();
  std::vector<Vec3> rho(n), emission(n);
  std::vector<double> weight(n);
  std::vector<bool> uniform(n, true);
  mesh.vertexReflectance.assign(n, Vec3{});
  mesh.vertexEmission.assign(n, Vec3{});
  for (const Patch& p : mesh.patches)
    for (int k = 0; k < 4; ++k) {
      if (k == 3 && p.v[3] == p.v[2]) continue;
      const uint32_t v = p.v[k];
      if (weight[v] > 0 && !(mesh.vertexReflectance[v] == p.reflectance && mesh.vertexEmission[v] == p.emission)) uniform[v] = false;
      mesh.vertexReflectance[v] = p.reflectance;
      mesh.vertexEmission[v] = p.emission;
      rho[v] += p.reflectance * p.area;
      emission[v] += p.emission * p.area;
      weight[v] += p.area;
    }
  for (size_t v = 0; v < n; ++v) {
    if (weight[v] == 0) {
      mesh.vertexReflectance[v] = scene.materials[mesh.vertexMaterial[v]].reflectance;
      mesh.vertexEmission[v] = scene.materials[mesh.vertexMaterial[v]].emission;
    } else if (!uniform[v]) {
      mesh.vertexReflectance[v] = rho[v] / weight[v];
      mesh.vertexEmission[v] = emission[v] / weight[v];
    }
  }
}

// A facet of a curved surface as patches. The form factors need planar patches (a non-planar quad
// has no single front side, and a vertex can sit behind its best-fit plane while seeing it), so a
// facet whose corners leave its plane by more than rounding becomes two planar triangles, split
// along the shorter diagonal; the unknowns (its vertices) stay the same. The facet's
// non-planarity is reported. False for a facet of zero area.
bool addCurvedPatch(PatchMesh& mesh, const std::array<uint32_t, 4>& q, int material, int primitive) {
  constexpr double kPlanarTolerance = 1e-9;  // corner offset over diagonal
  const std::array<Vec3, 4> c{mesh.positions[q[0]], mesh.positions[q[1]], mesh.positions[q[2]], mesh.positions[q[3]]};
  const Vec3 area2 = cross(c[2] - c[0], c[3] - c[1]);
  if (!(length(area2) > 0)) return false;
  const Vec3 normal = normalize(area2);
  const Vec3 centre = (c[0] + c[1] + c[2] + c[3]) / 4;
  const double diagonal = std::max(length(c[2] - c[0]), length(c[3] - c[1]));
  double offPlane = 0;
  for (const Vec3& x : c) offPlane = std::max(offPlane, std::abs(dot(x - centre, normal)) / diagonal);
  mesh.worstNonPlanarity = std::max(mesh.worstNonPlanarity, offPlane);
  if (q[2] == q[3] || offPlane <= kPlanarTolerance) {
    mesh.patches.push_back(makePatch(q, material, primitive, normal, 0.5 * length(area2)));
    return true;
  }
  ++mesh.splitFacets;
  const bool alongFirst = length(c[2] - c[0]) <= length(c[3] - c[1]);
  const std::array<std::array<int, 3>, 2> halves =
      alongFirst ? std::array<std::array<int, 3>, 2>{{{0, 1, 2}, {0, 2, 3}}} : std::array<std::array<int, 3>, 2>{{{0, 1, 3}, {1, 2, 3}}};
  for (const auto& h : halves) {
    const Vec3 n2 = cross(c[h[1]] - c[h[0]], c[h[2]] - c[h[0]]);
    if (!(length(n2) > 0)) continue;
    mesh.patches.push_back(makePatch({q[h[0]], q[h[1]], q[h[2]], q[h[2]]}, material, primitive, normalize(n2), 0.5 * length(n2)));
  }
  return true;
}

// A subdivision surface: the primitive's faces (triangle pairs as quads for Catmull-Clark,
// triangles for Loop) on vertices welded by position are the cage; its limit surface is sampled
// at one rate, chosen from the chord tolerance (chord ≈ h²/(8R) for facets of size h on a surface
// of curvature radius R ~ half the cage's size), --subdivide and --max-edge.
void tessellateSubdivided(const Scene& scene, int primIndex, SubdivisionScheme scheme, const TessellateOptions& options,
                          Welder& welder, PatchMesh& mesh) {
  const Primitive& prim = scene.primitives[primIndex];
  PrimitivePatches& out = mesh.primitives[primIndex];
  std::vector<Face> faces;
  if (scheme == SubdivisionScheme::kLoop) {
    for (size_t t = 0; t < prim.triangles.size(); ++t) {
      const auto& tri = prim.triangles[t];
      faces.push_back({{tri[0], tri[1], tri[2], tri[2]}, {int(t), -1}, faceNormal(prim, tri)});
    }
  } else {
    faces = buildFaces(prim);
  }
  std::map<std::tuple<double, double, double>, uint32_t> cageIndex;
  std::vector<Vec3> cage;
  std::vector<std::vector<uint32_t>> cageFaces;
  double longestEdge = 0;
  Bounds bounds;
  for (const Face& f : faces) {
    std::vector<uint32_t> face;
    for (int k = 0; k < 4; ++k) {
      if (k == 3 && f.q[3] == f.q[2]) break;
      const Vec3& p = prim.positions[f.q[k]];
      auto [it, inserted] = cageIndex.try_emplace({p.x, p.y, p.z}, uint32_t(cage.size()));
      if (inserted) cage.push_back(p);
      face.push_back(it->second);
      bounds.add(p);
    }
    for (size_t k = 0; k < face.size(); ++k) longestEdge = std::max(longestEdge, length(cage[face[(k + 1) % face.size()]] - cage[face[k]]));
    cageFaces.push_back(std::move(face));
  }
  const double size = bounds.diagonal();
  const double chord = options.maxChord > 0 ? options.maxChord : 1e-3 * size;
  // Rates are computed in double and clamped before becoming ints: absurd geometry must not overflow.
  double wanted = std::max(double(options.subdivide), std::ceil(longestEdge / std::sqrt(8 * (size / 2) * chord)));
  if (options.maxEdgeLength > 0) wanted = std::max(wanted, std::ceil(longestEdge / options.maxEdgeLength));
  if (options.maxChord > 0 && wanted > kMaxCurvedRate)
    chordUnreachable(options, longestEdge * longestEdge / (8 * kMaxCurvedRate * kMaxCurvedRate * (size / 2)),
                     "mesh " + std::to_string(prim.mesh));
  const int rate = int(std::clamp(wanted, 1.0, double(kMaxCurvedRate)));
  checkPatchBudget(double(cageFaces.size()) * rate * rate * (scheme == SubdivisionScheme::kLoop ? 1.5 : 1.0) + double(mesh.patches.size()),
                   options, fileName(scene), "mesh " + std::to_string(prim.mesh));
  mesh.curvedRate = std::max(mesh.curvedRate, rate);

  const LimitTessellation limit = tessellateLimitSurface(cage, cageFaces, scheme, rate);
  out.keepsSourceVertices = false;
  std::vector<uint32_t> patchVertex(limit.positions.size());
  for (size_t i = 0; i < limit.positions.size(); ++i) {
    patchVertex[i] = welder.vertex(limit.positions[i], limit.normals[i], prim.material, kSmoothSeamCos);
    out.patchVertex.push_back(patchVertex[i]);
    out.source.push_back(locate(prim, faces[limit.face[i]], limit.positions[i]));
    out.positions.push_back(limit.positions[i]);
    out.normals.push_back(limit.normals[i]);
  }
  for (const auto& quad : limit.quads) {
    std::array<uint32_t, 4> q{patchVertex[quad[0]], patchVertex[quad[1]], patchVertex[quad[2]], patchVertex[quad[3]]};
    if (!addCurvedPatch(mesh, q, prim.material, primIndex)) continue;
    out.triangles.push_back({quad[0], quad[1], quad[2]});
    if (quad[3] != quad[2]) out.triangles.push_back({quad[0], quad[2], quad[3]});
  }
}

struct GridPoint {
  Vec3 position;
  PointId id;
  std::array<double, 4> w;  // the face corners' weights (for the normal)
};

// Point (I, J) of face f's grid of n·2^level cells a side (level 0: the uniform n × n grid;
// deeper: adaptive refinement's cells). Points on a face edge are computed from the edge's
// endpoints in the order of their positions (then indices), so the neighbouring face produces the
// same bits: the two weld, and the edge matches for the closedness test (Enclosures) also where
// each face has its own vertices, as in Blender's export of a cube (24 vertices). In index order,
// such a box was found open at every rate but a power of two. Ids are reduced to the coarsest
// level that holds the point, so a point keeps one output vertex whichever cells reach it.
GridPoint gridPoint(const Primitive& prim, const Face& f, uint32_t fi, int n, int level, long I, long J) {
  const long N = long(n) << level;
  const double s = double(I) / double(N), t = double(J) / double(N);
  GridPoint g{{}, {}, {(1 - s) * (1 - t), s * (1 - t), s * t, (1 - s) * t}};
  auto onEdge = [&](uint32_t va, uint32_t vb, long k) {
    if (k == 0 || va == vb) return std::pair{prim.positions[va], PointId{0, va, 0, 0, 0}};
    if (k == N) return std::pair{prim.positions[vb], PointId{0, vb, 0, 0, 0}};
    const Vec3 &a = prim.positions[va], &b = prim.positions[vb];
    if (std::tie(b.x, b.y, b.z, vb) < std::tie(a.x, a.y, a.z, va)) { std::swap(va, vb); k = N - k; }
    const Vec3 x = lerp(prim.positions[va], prim.positions[vb], double(k) / double(N));
    int L = level;
    while (L > 0 && k % 2 == 0) { k /= 2; --L; }
    return std::pair{x, PointId{1, va, vb, int(k), L}};
  };
  std::pair<Vec3, PointId> p;
  if (J == 0) p = onEdge(f.q[0], f.q[1], I);
  else if (J == N) p = onEdge(f.q[3], f.q[2], I);
  else if (I == 0) p = onEdge(f.q[0], f.q[3], J);
  else if (I == N) p = onEdge(f.q[1], f.q[2], J);
  else {
    const std::array<Vec3, 4> c{prim.positions[f.q[0]], prim.positions[f.q[1]], prim.positions[f.q[2]], prim.positions[f.q[3]]};
    int L = level;
    while (L > 0 && I % 2 == 0 && J % 2 == 0) { I /= 2; J /= 2; --L; }
    p = {c[0] * g.w[0] + c[1] * g.w[1] + c[2] * g.w[2] + c[3] * g.w[3], PointId{2, fi, uint32_t(L), int(I), int(J)}};
  }
  g.position = p.first;
  g.id = p.second;
  return g;
}

// The receiving normal at a point of a face (weights of its corners): the file's vertex normals
// interpolated on a smooth surface, the face normal where the file has none (glTF: flat shading).
Vec3 faceNormalAt(const Primitive& prim, const Face& f, const std::array<double, 4>& w) {
  if (!prim.hasNormals) return f.normal;
  Vec3 s{};
  for (int k = 0; k < 4; ++k) s += prim.normals[f.q[k]] * w[k];
  return length(s) > 0 ? normalize(s) : f.normal;
}

double quadArea(const std::array<Vec3, 4>& p) {
  return 0.5 * length(cross(p[2] - p[0], p[3] - p[1]));  // planar quad (or triangle with p2 == p3)
}

// firstTriangle: each patch's first output triangle in its primitive's (the contact cut replaces
// them). mayKeep: whether the file's vertices may be kept (not where patches will be cut).
void tessellatePrimitive(const Scene& scene, int primIndex, int n, bool flat, bool mayKeep, Welder& welder, PatchMesh& mesh,
                         std::vector<uint32_t>& firstTriangle) {
  const Primitive& prim = scene.primitives[primIndex];
  PrimitivePatches& out = mesh.primitives[primIndex];
  const int material = prim.material;
  const std::vector<Face> faces = buildFaces(prim);

  auto normalAt = [&](const Face& f, const std::array<double, 4>& w) { return faceNormalAt(prim, f, w); };

  if (n == 1 && !flat && mayKeep) {
    // Keep the glTF vertices when every vertex welds to exactly one patch vertex.
    out.patchVertex.assign(prim.positions.size(), kUnused);
    bool keeps = true;
    const size_t firstPatch = mesh.patches.size();
    for (const Face& f : faces) {
      Patch patch = makePatch({}, material, primIndex, f.normal, 0);
      patch.cell = {primIndex, int(&f - faces.data()), 0, 0, 0};
      for (int k = 0; k < 4; ++k) {
        std::array<double, 4> w{};
        w[k] = 1;
        const uint32_t pv = welder.vertex(prim.positions[f.q[k]], normalAt(f, w), material);
        if (out.patchVertex[f.q[k]] != kUnused && out.patchVertex[f.q[k]] != pv) keeps = false;
        out.patchVertex[f.q[k]] = pv;
        patch.v[k] = pv;
      }
      patch.area = quadArea({prim.positions[f.q[0]], prim.positions[f.q[1]], prim.positions[f.q[2]], prim.positions[f.q[3]]});
      shade(scene, prim, mesh, patch, [&](int k, int set) { return prim.texcoords[set][f.q[k]]; });
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
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) {
        const GridPoint point = gridPoint(prim, f, uint32_t(fi), n, 0, i, j);
        const uint32_t pv = welder.vertex(point.position, normalAt(f, point.w), material);
        grid[j * (n + 1) + i] = pv;
        gridSource[j * (n + 1) + i] = locate(prim, f, point.position);
        if (flat) continue;
        auto [it, inserted] = outputIndex.try_emplace({point.id, pv}, uint32_t(out.patchVertex.size()));
        if (inserted) {
          out.patchVertex.push_back(pv);
          out.source.push_back(gridSource[j * (n + 1) + i]);
        }
        outGrid[j * (n + 1) + i] = it->second;
      }
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const int c0 = j * (n + 1) + i, c1 = c0 + 1, c2 = c0 + n + 2, c3 = c0 + n + 1;
        Patch patch = makePatch({grid[c0], grid[c1], grid[c2], grid[c3]}, material, primIndex, f.normal, 0);
        patch.cell = {primIndex, int(fi), 0, i, j};
        const bool collapsed = triangle && j == n - 1;  // the top row of a triangle: triangles
        patch.area = quadArea({mesh.positions[grid[c0]], mesh.positions[grid[c1]], mesh.positions[grid[c2]],
                               mesh.positions[grid[c3]]});
        const int cornerGrid[4] = {c0, c1, c2, c3};
        shade(scene, prim, mesh, patch, [&](int k, int set) { return uvAt(prim, set, gridSource[cornerGrid[k]]); });
        mesh.patches.push_back(patch);
        firstTriangle.push_back(uint32_t(out.triangles.size()));
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

// ---- Bezier patches ---------------------------------------------------------------------

// Point of a Bezier curve of control points c[0..d] at t, by de Casteljau (stable, and the same
// arithmetic on both sides of a shared patch edge).
Vec3 deCasteljau(std::vector<Vec3> c, double t) {
  for (size_t r = 1; r < c.size(); ++r)
    for (size_t k = 0; k + r < c.size(); ++k) c[k] = c[k] * (1 - t) + c[k + 1] * t;
  return c[0];
}

struct BezierPoint {
  Vec3 position, du, dv;
};

// S(u, v) and its partial derivatives, from the tensor form: rows in v first, then u.
BezierPoint evaluate(const BezierPatch& patch, double u, double v) {
  const int nu = patch.degreeU + 1, nv = patch.degreeV + 1;
  auto curveAndTangent = [](const std::vector<Vec3>& c, double t) {
    std::vector<Vec3> w = c;
    for (size_t r = 1; r + 1 < w.size(); ++r)
      for (size_t k = 0; k + r < w.size(); ++k) w[k] = w[k] * (1 - t) + w[k + 1] * t;
    // w[0], w[1] are the last two de Casteljau points: tangent = d (w1 − w0)
    const double d = double(c.size() - 1);
    if (c.size() == 1) return std::pair{c[0], Vec3{}};
    return std::pair{w[0] * (1 - t) + w[1] * t, (w[1] - w[0]) * d};
  };
  std::vector<Vec3> alongU(nu), alongUDv(nu);
  for (int i = 0; i < nu; ++i) {
    std::vector<Vec3> row(patch.control.begin() + i * nv, patch.control.begin() + (i + 1) * nv);
    auto [p, dp] = curveAndTangent(row, v);
    alongU[i] = p;
    alongUDv[i] = dp;
  }
  auto [p, du] = curveAndTangent(alongU, u);
  return {p, du, curveAndTangent(alongUDv, u).first};
}

// A patch edge's control points in a canonical order (lexicographically smaller end first), so
// that both patches sharing the edge evaluate its points with identical arithmetic.
Vec3 edgePoint(std::vector<Vec3> edge, int k, int n) {
  const Vec3 &a = edge.front(), &b = edge.back();
  const bool reversed = std::tie(b.x, b.y, b.z) < std::tie(a.x, a.y, a.z);
  if (reversed) {
    std::reverse(edge.begin(), edge.end());
    k = n - k;
  }
  return deCasteljau(edge, double(k) / n);
}

// The surface normal at (u, v); at a collapsed edge (a pole, where ∂S/∂u × ∂S/∂v vanishes) the
// limit from just inside the patch.
Vec3 bezierNormal(const BezierPatch& patch, double u, double v) {
  BezierPoint e = evaluate(patch, u, v);
  Vec3 n = cross(e.du, e.dv);
  for (double step = 1e-7; length(n) <= 1e-12 * (1 + dot(e.du, e.du) + dot(e.dv, e.dv)) && step < 0.1; step *= 10) {
    e = evaluate(patch, u + (u < 0.5 ? step : -step), v + (v < 0.5 ? step : -step));
    n = cross(e.du, e.dv);
  }
  return normalize(n);
}

double chordError(const BezierPatch& patch, int n) {
  double worst = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double u0 = double(i) / n, u1 = double(i + 1) / n, v0 = double(j) / n, v1 = double(j + 1) / n;
      const Vec3 corners = (evaluate(patch, u0, v0).position + evaluate(patch, u1, v0).position +
                            evaluate(patch, u1, v1).position + evaluate(patch, u0, v1).position) / 4;
      const Vec3 edges[4] = {(evaluate(patch, u0, v0).position + evaluate(patch, u1, v0).position) / 2,
                             (evaluate(patch, u1, v0).position + evaluate(patch, u1, v1).position) / 2,
                             (evaluate(patch, u1, v1).position + evaluate(patch, u0, v1).position) / 2,
                             (evaluate(patch, u0, v1).position + evaluate(patch, u0, v0).position) / 2};
      const Vec3 truth[4] = {evaluate(patch, (u0 + u1) / 2, v0).position, evaluate(patch, u1, (v0 + v1) / 2).position,
                             evaluate(patch, (u0 + u1) / 2, v1).position, evaluate(patch, u0, (v0 + v1) / 2).position};
      worst = std::max(worst, length(evaluate(patch, (u0 + u1) / 2, (v0 + v1) / 2).position - corners));
      for (int k = 0; k < 4; ++k) worst = std::max(worst, length(truth[k] - edges[k]));
    }
  return worst;
}

// One uniform rate for all patches of the surface, so shared edges get the same points.
// Measuring a rate costs about as much as the patches it makes, so each rate is checked against
// the budget before it is measured: a hostile .bpt cannot make the search itself run long.
int bezierRate(const std::vector<BezierPatch>& patches, const TessellateOptions& options, const std::string& file) {
  Bounds bounds;
  for (const BezierPatch& p : patches)
    for (const Vec3& c : p.control) bounds.add(c);
  const double chord = options.maxChord > 0 ? options.maxChord : 1e-3 * bounds.diagonal();
  constexpr int kMaxRate = kMaxCurvedRate;
  int rate = std::max(1, options.subdivide);
  auto raise = [&](int next) {
    checkPatchBudget(double(patches.size()) * next * next, options, file, "the Bezier surface");
    rate = next;
  };
  for (const BezierPatch& p : patches) {
    while (rate < kMaxRate && chordError(p, rate) > chord) raise(std::min(kMaxRate, rate * 2));
    if (options.maxChord > 0 && rate == kMaxRate)
      if (const double reached = chordError(p, rate); reached > chord)
        chordUnreachable(options, reached, "Bezier patch " + std::to_string(&p - patches.data()));
    if (options.maxEdgeLength > 0)
      while (rate < kMaxRate) {
        double longest = 0;
        for (int k = 0; k < rate; ++k)
          for (int l = 0; l <= rate; ++l) {
            longest = std::max(longest, length(evaluate(p, double(k + 1) / rate, double(l) / rate).position -
                                               evaluate(p, double(k) / rate, double(l) / rate).position));
            longest = std::max(longest, length(evaluate(p, double(l) / rate, double(k + 1) / rate).position -
                                               evaluate(p, double(l) / rate, double(k) / rate).position));
          }
        if (longest <= options.maxEdgeLength) break;
        raise(rate + 1);
      }
  }
  return rate;
}

void tessellateBezier(const Scene& scene, const TessellateOptions& options, Welder& welder, PatchMesh& mesh) {
  if (scene.bezierPatches.empty()) return;
  const int n = bezierRate(scene.bezierPatches, options, fileName(scene));
  checkPatchBudget(double(scene.bezierPatches.size()) * n * n + double(mesh.patches.size()), options, fileName(scene),
                   "the Bezier surface");
  mesh.curvedRate = n;
  GeneratedSurface surface;
  surface.material = scene.bezierPatches.front().material;
  std::unordered_map<uint32_t, uint32_t> outputOf;
  std::vector<uint32_t> grid((n + 1) * (n + 1));
  for (const BezierPatch& patch : scene.bezierPatches) {
    const int nu = patch.degreeU + 1, nv = patch.degreeV + 1;
    auto column = [&](int i) { return std::vector<Vec3>(patch.control.begin() + i * nv, patch.control.begin() + (i + 1) * nv); };
    auto row = [&](int j) {
      std::vector<Vec3> r(nu);
      for (int i = 0; i < nu; ++i) r[i] = patch.control[i * nv + j];
      return r;
    };
    const std::vector<Vec3> edgeU0 = column(0), edgeU1 = column(nu - 1), edgeV0 = row(0), edgeV1 = row(nv - 1);
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) {
        const double u = double(i) / n, v = double(j) / n;
        Vec3 p;
        if (i == 0) p = edgePoint(edgeU0, j, n);
        else if (i == n) p = edgePoint(edgeU1, j, n);
        else if (j == 0) p = edgePoint(edgeV0, i, n);
        else if (j == n) p = edgePoint(edgeV1, i, n);
        else p = evaluate(patch, u, v).position;
        grid[j * (n + 1) + i] = welder.vertex(p, bezierNormal(patch, u, v), patch.material, kSmoothSeamCos);
      }
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        std::array<uint32_t, 4> q{grid[j * (n + 1) + i], grid[j * (n + 1) + i + 1], grid[(j + 1) * (n + 1) + i + 1],
                                  grid[(j + 1) * (n + 1) + i]};
        // A collapsed edge (a pole) makes the quad a triangle: rotate so the repeat sits at v2 == v3.
        int distinct = 0;
        std::array<uint32_t, 4> unique{};
        for (int k = 0; k < 4; ++k)
          if (q[k] != q[(k + 3) % 4]) unique[distinct++] = q[k];
        if (distinct < 3) continue;  // a degenerate sliver at a pole
        if (distinct == 3) q = {unique[0], unique[1], unique[2], unique[2]};
        if (!addCurvedPatch(mesh, q, patch.material, -1)) continue;
        for (uint32_t v : q)
          if (outputOf.try_emplace(v, uint32_t(surface.patchVertex.size())).second) surface.patchVertex.push_back(v);
        surface.triangles.push_back({outputOf[q[0]], outputOf[q[1]], outputOf[q[2]]});
        if (q[3] != q[2]) surface.triangles.push_back({outputOf[q[0]], outputOf[q[2]], outputOf[q[3]]});
      }
  }
  mesh.generated.push_back(std::move(surface));
}

// ---- Adaptive refinement --------------------------------------------------------------------
//
// Cells of a flat face's n×n grid split in four, recursively (TessellateOptions::split). Every
// point is computed from its grid coordinates as the grid's own points are (an edge point from the
// edge's endpoints in position order), so a point shared by two cells, two faces or two primitives
// of the same rate has the same bits on both sides: conformity is checked by position.

using PositionSet = std::unordered_set<std::array<uint64_t, 3>, WordsHash<3>>;

// A primitive's faces, rate and leaf cells under the refinement.
struct RefinedPrimitive {
  bool refinable = false;
  int n = 1;
  std::vector<Face> faces;
  std::vector<Cell> leaves;
  bool cells = false;  // tessellated by its cells (some split, or a neighbour's point on an edge)
};

void collectLeaves(const std::set<Cell>& split, const Cell& c, std::vector<Cell>& out) {
  if (c.level < kMaxRefineLevel && split.count(c)) {
    for (int b = 0; b < 2; ++b)
      for (int a = 0; a < 2; ++a) collectLeaves(split, {c.primitive, c.face, c.level + 1, 2 * c.i + a, 2 * c.j + b}, out);
  } else {
    out.push_back(c);
  }
}

// Grid coordinates, `extra` levels below a cell's, of the point at fraction k/2^extra along its
// edge e (0 bottom, 1 right, 2 top, 3 left, counter-clockwise).
std::pair<long, long> alongEdge(const Cell& c, int e, int extra, long k) {
  const long m = 1L << extra, i = c.i * m, j = c.j * m;
  switch (e) {
    case 0: return {i + k, j};
    case 1: return {i + m, j + k};
    case 2: return {i + m - k, j + m};
    default: return {i, j + m - k};
  }
}

struct RefinementPlan {
  std::vector<RefinedPrimitive> primitives;
  PositionSet corners;  // of every leaf cell
};

// Whether edge e of a cell collapses to a point: the top edge of a triangle face's top row.
bool collapsedEdge(const RefinedPrimitive& rp, const Cell& c, int e) {
  const Face& f = rp.faces[c.face];
  return e == 2 && f.q[2] == f.q[3] && (c.j + 1) == (long(rp.n) << c.level);
}

Vec3 cellPoint(const Primitive& prim, const RefinedPrimitive& rp, const Cell& c, int extra, long I, long J) {
  return gridPoint(prim, rp.faces[c.face], uint32_t(c.face), rp.n, c.level + extra, I, J).position;
}

// The leaves under `split` (which grows): a leaf with a point of another cell at a quarter of one
// of its edges is split too, so that neighbours differ by at most one level and a cell's edge holds
// at most its midpoint (2:1 balance; the fans below then have at most 8 triangles).
RefinementPlan planRefinement(const Scene& scene, const TessellateOptions& options, std::set<Cell>& split) {
  RefinementPlan plan;
  plan.primitives.resize(scene.primitives.size());
  if (split.empty() || options.flatPatches) return plan;
  for (size_t p = 0; p < scene.primitives.size(); ++p) {
    const Primitive& prim = scene.primitives[p];
    if (schemeOf(prim, options) != SubdivisionScheme::kNone || prim.triangles.empty()) continue;
    RefinedPrimitive& rp = plan.primitives[p];
    rp.refinable = true;
    rp.n = subdivisionFor(prim, options);
    rp.faces = buildFaces(prim);
  }
  for (bool changed = true; changed;) {
    changed = false;
    plan.corners.clear();
    for (size_t p = 0; p < plan.primitives.size(); ++p) {
      RefinedPrimitive& rp = plan.primitives[p];
      if (!rp.refinable) continue;
      rp.leaves.clear();
      for (size_t f = 0; f < rp.faces.size(); ++f)
        for (int j = 0; j < rp.n; ++j)
          for (int i = 0; i < rp.n; ++i) collectLeaves(split, {int(p), int(f), 0, i, j}, rp.leaves);
      for (const Cell& c : rp.leaves)
        for (int e = 0; e < 4; ++e) {
          const auto [I, J] = alongEdge(c, e, 0, 0);
          plan.corners.insert(positionKey(cellPoint(scene.primitives[p], rp, c, 0, I, J)));
        }
    }
    for (size_t p = 0; p < plan.primitives.size(); ++p) {
      const RefinedPrimitive& rp = plan.primitives[p];
      if (!rp.refinable) continue;
      for (const Cell& c : rp.leaves) {
        if (c.level >= kMaxRefineLevel) continue;
        bool unbalanced = false;
        for (int e = 0; e < 4 && !unbalanced; ++e) {
          if (collapsedEdge(rp, c, e)) continue;
          for (long k : {1L, 3L}) {
            const auto [I, J] = alongEdge(c, e, 2, k);
            unbalanced |= plan.corners.count(positionKey(cellPoint(scene.primitives[p], rp, c, 2, I, J))) > 0;
          }
        }
        if (unbalanced) changed |= split.insert(c).second;
      }
    }
  }
  for (size_t p = 0; p < plan.primitives.size(); ++p) {
    RefinedPrimitive& rp = plan.primitives[p];
    for (const Cell& c : rp.leaves) {
      rp.cells |= c.level > 0;
      for (int e = 0; e < 4 && !rp.cells; ++e) {
        if (collapsedEdge(rp, c, e)) continue;
        const auto [I, J] = alongEdge(c, e, 1, 1);
        rp.cells |= plan.corners.count(positionKey(cellPoint(scene.primitives[p], rp, c, 1, I, J))) > 0;
      }
    }
  }
  return plan;
}

// A primitive by its leaf cells: each a patch, or where a neighbour's point sits at the midpoint of
// one of its edges, a fan of triangles through that point (no hanging vertex: the field stays
// continuous and the written mesh has no T-junction).
void tessellateCells(const Scene& scene, int primIndex, const RefinedPrimitive& rp, const PositionSet& corners, Welder& welder,
                     PatchMesh& mesh, std::vector<uint32_t>& firstTriangle) {
  const Primitive& prim = scene.primitives[primIndex];
  PrimitivePatches& out = mesh.primitives[primIndex];
  out.keepsSourceVertices = false;
  std::map<std::pair<PointId, uint32_t>, uint32_t> outputIndex;
  struct Made {
    uint32_t vertex, output;
    SurfacePoint source;
  };
  auto make = [&](const Cell& c, int extra, long I, long J) {
    const Face& f = rp.faces[c.face];
    const GridPoint g = gridPoint(prim, f, uint32_t(c.face), rp.n, c.level + extra, I, J);
    const uint32_t pv = welder.vertex(g.position, faceNormalAt(prim, f, g.w), prim.material);
    const SurfacePoint source = locate(prim, f, g.position);
    auto [it, inserted] = outputIndex.try_emplace({g.id, pv}, uint32_t(out.patchVertex.size()));
    if (inserted) {
      out.patchVertex.push_back(pv);
      out.source.push_back(source);
    }
    return Made{pv, it->second, source};
  };
  auto addPatch = [&](const Cell& c, const std::array<Made, 4>& m) {
    Patch patch = makePatch({m[0].vertex, m[1].vertex, m[2].vertex, m[3].vertex}, prim.material, primIndex,
                            rp.faces[c.face].normal, 0);
    patch.area = quadArea({mesh.positions[m[0].vertex], mesh.positions[m[1].vertex], mesh.positions[m[2].vertex],
                           mesh.positions[m[3].vertex]});
    patch.cell = c;
    shade(scene, prim, mesh, patch, [&](int k, int set) { return uvAt(prim, set, m[k].source); });
    mesh.patches.push_back(patch);
    firstTriangle.push_back(uint32_t(out.triangles.size()));
    out.triangles.push_back({m[0].output, m[1].output, m[2].output});
    if (m[3].vertex != m[2].vertex) out.triangles.push_back({m[0].output, m[2].output, m[3].output});
  };
  for (const Cell& c : rp.leaves) {
    std::array<Made, 4> corner;
    std::array<bool, 4> hanging{};
    for (int e = 0; e < 4; ++e) {
      const auto [I, J] = alongEdge(c, e, 0, 0);
      corner[e] = make(c, 0, I, J);
    }
    bool any = false;
    for (int e = 0; e < 4; ++e) {
      if (collapsedEdge(rp, c, e)) continue;
      const auto [I, J] = alongEdge(c, e, 1, 1);
      hanging[e] = corners.count(positionKey(cellPoint(prim, rp, c, 1, I, J))) > 0;
      any |= hanging[e];
    }
    if (!any) {
      addPatch(c, corner);
      continue;
    }
    // The fan: the boundary counter-clockwise from the first midpoint that hangs on it, with the
    // others, fanned from that midpoint (k − 2 triangles for k boundary points, no new vertex: a
    // fan round the cell's centre made two more triangles and one more unknown per cell). No
    // triangle is flat: the two segments through the apex are its first and last edges, and 2:1
    // balance leaves at most one midpoint on an edge.
    std::vector<Made> ring;
    int first = -1;
    for (int e = 0; e < 4; ++e) {
      if (ring.empty() || ring.back().vertex != corner[e].vertex) ring.push_back(corner[e]);
      if (hanging[e]) {
        const auto [I, J] = alongEdge(c, e, 1, 1);
        if (first < 0) first = int(ring.size());
        ring.push_back(make(c, 1, I, J));
      }
    }
    if (ring.size() > 1 && ring.back().vertex == ring.front().vertex) ring.pop_back();
    std::rotate(ring.begin(), ring.begin() + first, ring.end());
    for (size_t k = 1; k + 1 < ring.size(); ++k) addPatch(c, {ring[0], ring[k], ring[k + 1], ring[k + 1]});
  }
}

// A double-sided material lights both sides: every patch of such a primitive gets a mirrored twin
// on its own vertices (normals reversed, so they never weld with the front). Each side is a surface
// of its own: the solver keeps a side from seeing or shadowing its twin (Patch::twin). The
// exporter writes the front side.
void addBackSides(const Scene& scene, PatchMesh& mesh, Welder& welder) {
  const size_t end = mesh.patches.size();
  for (size_t i = 0; i < end; ++i) {
    if (mesh.patches[i].primitive < 0 || !scene.materials[mesh.patches[i].material].doubleSided) continue;
    Patch back = mesh.patches[i];
    std::array<uint32_t, 4> v;
    for (int k = 0; k < 4; ++k)
      v[k] = welder.vertex(mesh.positions[back.v[k]], -mesh.normals[back.v[k]], back.material);
    back.v = back.v[2] == back.v[3] ? std::array<uint32_t, 4>{v[0], v[2], v[1], v[1]} : std::array<uint32_t, 4>{v[0], v[3], v[2], v[1]};
    back.normal = -back.normal;
    back.backSide = true;
    back.twin = int(i);
    mesh.patches[i].twin = int(mesh.patches.size());
    mesh.patches.push_back(back);
  }
}

// The contact cut (contact.h) applied: each cut patch becomes its pieces (quad and triangle patches
// that keep its cell, material and shading), on new vertices where the cuts need them, and its output
// triangles are replaced by the pieces'. Patches with a cut-out mask are not cut (their mask's
// texture coordinates are their corners').
void cutAtContacts(const Scene& scene, const Contacts& contacts, Welder& welder, PatchMesh& mesh,
                   const std::vector<uint32_t>& firstTriangle) {
  std::vector<bool> cuttable(mesh.patches.size(), false);
  std::vector<std::vector<ContactSegment>> segments(mesh.patches.size());
  std::vector<std::vector<Face>> faces(scene.primitives.size());
  for (size_t p = 0; p < scene.primitives.size(); ++p)
    if (contacts.touched[p]) faces[p] = buildFaces(scene.primitives[p]);
  for (size_t k = 0; k < mesh.patches.size(); ++k) {
    const Patch& patch = mesh.patches[k];
    if (patch.primitive < 0 || !contacts.touched[patch.primitive] || patch.mask >= 0 || firstTriangle[k] == UINT32_MAX) continue;
    cuttable[k] = true;
    for (int t : faces[patch.primitive][patch.cell.face].triangles) {
      if (t < 0) continue;
      const auto it = contacts.segments[patch.primitive].find(uint32_t(t));
      if (it != contacts.segments[patch.primitive].end()) segments[k].insert(segments[k].end(), it->second.begin(), it->second.end());
    }
  }
  const std::vector<PatchPieces> cut = cutPatches(mesh, cuttable, segments, contacts.epsilon);
  if (cut.empty()) return;
  // Output vertices of the new points, one per patch vertex and output edge (or patch, inside).
  std::vector<std::map<std::tuple<uint32_t, uint32_t, uint32_t>, uint32_t>> outputOf(scene.primitives.size());
  std::map<uint32_t, std::vector<std::array<uint32_t, 3>>> piecesOf;  // cut patch → its output triangles
  for (const PatchPieces& pieces : cut) {
    const Patch parent = mesh.patches[pieces.patch];
    const int p = parent.primitive;
    const Primitive& prim = scene.primitives[p];
    PrimitivePatches& out = mesh.primitives[p];
    const Face& face = faces[p][parent.cell.face];
    const auto& t0 = out.triangles[firstTriangle[pieces.patch]];
    const bool quad = parent.v[3] != parent.v[2];
    const std::array<uint32_t, 4> cornerOut{t0[0], t0[1], t0[2], quad ? out.triangles[firstTriangle[pieces.patch] + 1][2] : t0[2]};
    std::vector<uint32_t> vertex(pieces.position.size()), output(pieces.position.size());
    for (size_t i = 0; i < pieces.position.size(); ++i) {
      const auto& w = pieces.weights[i];
      int nonzero = 0, only = 0;
      for (int c = 0; c < 4; ++c)
        if (w[c] != 0) ++nonzero, only = c;
      if (nonzero == 1 && w[only] == 1) {
        vertex[i] = parent.v[only];
        output[i] = cornerOut[only];
        continue;
      }
      Vec3 n{};
      for (int c = 0; c < 4; ++c) n += mesh.normals[parent.v[c]] * w[c];
      vertex[i] = welder.vertex(pieces.position[i], length(n) > 0 ? normalize(n) : parent.normal, parent.material);
      // On an edge (two adjacent corners weighted): shared with the patch across it.
      std::tuple<uint32_t, uint32_t, uint32_t> key{vertex[i], UINT32_MAX, pieces.patch};
      if (nonzero == 2)
        for (int c = 0; c < 4; ++c) {
          const int d = (c + 1) % (quad ? 4 : 3);
          if (w[c] != 0 && w[d] != 0) key = {vertex[i], std::min(cornerOut[c], cornerOut[d]), std::max(cornerOut[c], cornerOut[d])};
        }
      auto [it, inserted] = outputOf[p].try_emplace(key, uint32_t(out.patchVertex.size()));
      if (inserted) {
        out.patchVertex.push_back(vertex[i]);
        out.source.push_back(locate(prim, face, pieces.position[i]));
      }
      output[i] = it->second;
    }
    bool first = true;
    auto& triangles = piecesOf[pieces.patch];
    for (const auto& t : pieces.polygons) {
      Patch piece = parent;
      piece.v = {vertex[t[0]], vertex[t[1]], vertex[t[2]], vertex[t[3]]};
      piece.area = quadArea({mesh.positions[piece.v[0]], mesh.positions[piece.v[1]], mesh.positions[piece.v[2]], mesh.positions[piece.v[3]]});
      if (!(piece.area > 0)) continue;
      if (first) mesh.patches[pieces.patch] = piece;
      else mesh.patches.push_back(piece);
      first = false;
      triangles.push_back({output[t[0]], output[t[1]], output[t[2]]});
      if (t[3] != t[2]) triangles.push_back({output[t[0]], output[t[2]], output[t[3]]});
    }
  }
  // Each cut primitive's output triangles again, the pieces' in place of their patches'.
  std::vector<std::vector<std::array<uint32_t, 3>>> rebuilt(scene.primitives.size());
  std::vector<bool> changed(scene.primitives.size(), false);
  for (const auto& [k, t] : piecesOf) changed[mesh.patches[k].primitive] = true;
  for (size_t k = 0; k < firstTriangle.size(); ++k) {
    if (firstTriangle[k] == UINT32_MAX) continue;
    const int p = mesh.patches[k].primitive;
    if (!changed[p]) continue;
    const auto it = piecesOf.find(uint32_t(k));
    if (it != piecesOf.end()) {
      rebuilt[p].insert(rebuilt[p].end(), it->second.begin(), it->second.end());
      continue;
    }
    // A primitive's patches are consecutive (pieces beyond the first go after all of them), so a
    // patch's triangles run to the next patch's first, or to the end.
    const auto& tris = mesh.primitives[p].triangles;
    const bool last = k + 1 == firstTriangle.size() || mesh.patches[k + 1].primitive != p;
    const uint32_t to = last ? uint32_t(tris.size()) : firstTriangle[k + 1];
    rebuilt[p].insert(rebuilt[p].end(), tris.begin() + firstTriangle[k], tris.begin() + to);
  }
  for (size_t p = 0; p < scene.primitives.size(); ++p)
    if (changed[p]) mesh.primitives[p].triangles = std::move(rebuilt[p]);
}

}  // namespace

PatchMesh tessellate(const Scene& scene, const TessellateOptions& options, const PatchMesh* previous) {
  PatchMesh mesh;
  mesh.primitives.resize(scene.primitives.size());
  Welder welder{mesh, {}};
  // Where flat surfaces meet (contact.h): found on the source triangles, cut into the patches below.
  std::vector<bool> cuttable(scene.primitives.size(), false);
  for (size_t p = 0; p < scene.primitives.size(); ++p)
    cuttable[p] = options.cutContacts && !options.flatPatches && schemeOf(scene.primitives[p], options) == SubdivisionScheme::kNone;
  if (previous && previous->contacts && previous->contacts->cuttable == cuttable) mesh.contacts = previous->contacts;
  else mesh.contacts = std::make_shared<const Contacts>(findContacts(scene, cuttable));
  const Contacts& contacts = *mesh.contacts;
  mesh.contactSegments = contacts.count;
  mesh.split = options.split;
  const RefinementPlan plan = planRefinement(scene, options, mesh.split);
  std::vector<uint32_t> firstTriangle;  // per patch; UINT32_MAX where it has none of its own (kept vertices, curved)
  for (size_t p = 0; p < scene.primitives.size(); ++p) {
    const double rate = subdivisionFor(scene.primitives[p], options);
    checkPatchBudget(double(scene.primitives[p].triangles.size()) * rate * rate + double(mesh.patches.size()), options,
                     fileName(scene), "mesh " + std::to_string(scene.primitives[p].mesh));
    const SubdivisionScheme scheme = schemeOf(scene.primitives[p], options);
    if (scheme != SubdivisionScheme::kNone && !scene.primitives[p].triangles.empty())
      tessellateSubdivided(scene, int(p), scheme, options, welder, mesh);
    else if (plan.primitives[p].cells)
      tessellateCells(scene, int(p), plan.primitives[p], plan.corners, welder, mesh, firstTriangle);
    else
      tessellatePrimitive(scene, int(p), subdivisionFor(scene.primitives[p], options), options.flatPatches, !contacts.touched[p], welder,
                          mesh, firstTriangle);
    firstTriangle.resize(mesh.patches.size(), UINT32_MAX);
  }
  cutAtContacts(scene, contacts, welder, mesh, firstTriangle);
  addBackSides(scene, mesh, welder);
  tessellateBezier(scene, options, welder, mesh);
  finishShading(scene, mesh);
  return mesh;
}

std::array<double, 2> uvAt(const Primitive& prim, int set, const SurfacePoint& sp) {
  const auto& t = prim.triangles[sp.triangle];
  const auto& uv = prim.texcoords[set];
  const double w0 = 1 - sp.w1 - sp.w2;
  return {w0 * uv[t[0]][0] + sp.w1 * uv[t[1]][0] + sp.w2 * uv[t[2]][0], w0 * uv[t[0]][1] + sp.w1 * uv[t[1]][1] + sp.w2 * uv[t[2]][1]};
}

Vec3 positionAt(const Primitive& prim, const SurfacePoint& sp) {
  const auto& t = prim.triangles[sp.triangle];
  return prim.positions[t[0]] * (1 - sp.w1 - sp.w2) + prim.positions[t[1]] * sp.w1 + prim.positions[t[2]] * sp.w2;
}

bool hasTexcoords(const Primitive& prim, int set) {
  return set >= 0 && set < int(prim.texcoords.size()) && prim.texcoords[set].size() == prim.positions.size();
}

}  // namespace radbake

#include "radiosity/radiosity.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>
#include <memory>
#include <mutex>
#include <span>

#include "core/core.h"
#include "radiosity/form_factor.h"
#include "radiosity/visibility.h"

namespace radbake {
namespace {

// Where visibility is first probed on a patch, in (s, t): its centre and four inner points.
constexpr double kProbe[5][2] = {{0, 0}, {-0.5, -0.5}, {0.5, -0.5}, {0.5, 0.5}, {-0.5, 0.5}};

// The patches around each vertex (CSR), to keep them from occluding the vertex's own rays.
struct VertexPatches {
  std::vector<size_t> start;
  std::vector<uint32_t> patch;
  std::span<const uint32_t> of(size_t v) const { return {patch.data() + start[v], start[v + 1] - start[v]}; }
};

VertexPatches vertexPatches(const PatchMesh& mesh) {
  VertexPatches out;
  out.start.assign(mesh.positions.size() + 1, 0);
  for (const Patch& p : mesh.patches)
    for (int k = 0; k < 4; ++k)
      if (k < 3 || p.v[3] != p.v[2]) ++out.start[p.v[k] + 1];
  for (size_t v = 0; v < mesh.positions.size(); ++v) out.start[v + 1] += out.start[v];
  out.patch.resize(out.start.back());
  std::vector<size_t> fill(out.start.begin(), out.start.end() - 1);
  for (size_t i = 0; i < mesh.patches.size(); ++i)
    for (int k = 0; k < 4; ++k)
      if (k < 3 || mesh.patches[i].v[3] != mesh.patches[i].v[2]) out.patch[fill[mesh.patches[i].v[k]]++] = uint32_t(i);
  return out;
}

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
      progress_(from_ + (to_ - from_) * double(before + n) / double(total_));
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

constexpr size_t kBytesPerEntry = sizeof(uint32_t) + sizeof(double);

// Builds the rows in parallel and keeps them if their estimated size (from a sample of rows)
// fits the budget.
void storeIfItFits(Transport& t, const RadiosityOptions& options, size_t& entries) {
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
  Ticker ticker(options.progress, t.rows, 0.0, 0.8);
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

// For each vertex, the direction into its own surface from which a crease vertex takes its limit:
// the mean direction to the centroids of the patches around it (the corner bisector for a patch
// corner, the inward perpendicular on an edge).
std::vector<Vec3> approachDirections(const PatchMesh& mesh) {
  std::vector<Vec3> sum(mesh.positions.size());
  for (const Patch& patch : mesh.patches) {
    const auto q = corners(mesh, patch);
    const Vec3 centroid = pointOnPatch(q, 0, 0);
    for (int k = 0; k < 4; ++k) {
      if (k == 3 && patch.v[3] == patch.v[2]) continue;
      sum[patch.v[k]] += normalize(centroid - mesh.positions[patch.v[k]]);
    }
  }
  // Not projected onto the tangent plane: on a curved surface the facets around a vertex rise or
  // fall away from it, and the limit must be taken inside them (inside the closed faceted surface),
  // or the closure Σ_j K_ij = 1 loses the near field.
  for (Vec3& a : sum) a = normalize(a);
  return sum;
}

// Visibility between a receiver point and a source patch, as a factor per shape function.
// Five rays first (centre and four inner points); if they agree the pair is fully visible or
// fully hidden. Otherwise a 4×4 Gauss grid on the source, each ray weighted by the shape function
// and the unoccluded kernel there, gives the visible fraction of each K_j.
std::array<double, 4> visibleFraction(const Occlusion& occlusion, const Vec3& from, const Vec3& n,
                                      const std::array<Vec3, 4>& q, const Vec3& qNormal,
                                      std::span<const uint32_t> ignore) {
  const double lift = occlusion.epsilon() * 10;
  auto target = [&](double s, double t) { return pointOnPatch(q, s, t) + qNormal * lift; };
  int seen = 0;
  for (const auto& st : kProbe) seen += occlusion.visible(from, target(st[0], st[1]), ignore);
  if (seen == 5) return {1, 1, 1, 1};
  if (seen == 0) return {0, 0, 0, 0};
  constexpr double kNode[4] = {-0.8611363115940526, -0.3399810435848563, 0.3399810435848563, 0.8611363115940526};
  constexpr double kWeight[4] = {0.3478548451374538, 0.6521451548625461, 0.6521451548625461, 0.3478548451374538};
  std::array<double, 4> all{}, visible{};
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < 4; ++b) {
      const Vec3 x = pointOnPatch(q, kNode[a], kNode[b]);
      const Vec3 d = x - from;
      const double r2 = dot(d, d);
      const double kernel = std::max(0.0, dot(n, d)) * std::max(0.0, -dot(qNormal, d)) / (r2 * r2);
      const bool v = occlusion.visible(from, target(kNode[a], kNode[b]), ignore);
      const auto nj = shapeFunctions(kNode[a], kNode[b]);
      for (int j = 0; j < 4; ++j) {
        const double w = kWeight[a] * kWeight[b] * nj[j] * (kernel > 0 ? kernel : 1e-300);
        all[j] += w;
        if (v) visible[j] += w;
      }
    }
  std::array<double, 4> out{};
  for (int j = 0; j < 4; ++j) out[j] = all[j] > 0 ? visible[j] / all[j] : double(seen) / 5;
  return out;
}

// Bilinear method: row i holds K_ij for every vertex j, K_ij = Σ over patches of the kernel from
// vertex i to the patch's shape function at j, times visibility.
Transport bilinearTransport(const PatchMesh& mesh, const Occlusion& occlusion, const RadiosityOptions& options) {
  Transport t;
  t.rows = mesh.positions.size();
  auto approach = std::make_shared<std::vector<Vec3>>(approachDirections(mesh));
  auto around = std::make_shared<VertexPatches>(vertexPatches(mesh));
  KernelOptions kernelOptions;
  kernelOptions.relativeTolerance = options.kernelTolerance;
  t.build = [&mesh, &occlusion, approach, around, kernelOptions](size_t i, Row& row) {
    const Vec3 p = mesh.positions[i], nrm = mesh.normals[i], a = (*approach)[i];
    std::vector<uint32_t> ignore(around->of(i).begin(), around->of(i).end());
    ignore.push_back(0);  // the source patch, set below
    // Rays leave from just inside the vertex's own surface: off the crease, above the plane.
    const Vec3 origin = p + (nrm + a) * (occlusion.epsilon() * 10);
    for (size_t source = 0; source < mesh.patches.size(); ++source) {
      const Patch& patch = mesh.patches[source];
      const auto q = corners(mesh, patch);
      // Cheap rejections: source entirely below the receiver's horizon, or receiver behind it.
      bool above = false;
      for (const Vec3& c : q) above |= dot(nrm, c - p) > 0;
      if (!above || dot(patch.normal, p - q[0]) < -occlusion.epsilon()) continue;
      const auto k = vertexQuadKernel(p, nrm, a, q, kernelOptions);
      if (k[0] == 0 && k[1] == 0 && k[2] == 0 && k[3] == 0) continue;
      // A crease contribution sits at the receiver itself: nothing can come between.
      const bool touching = nearestQuadPoint(q, p).distance <= occlusion.epsilon();
      ignore.back() = uint32_t(source);
      const auto vis = touching ? std::array<double, 4>{1, 1, 1, 1} : visibleFraction(occlusion, origin, nrm, q, patch.normal, ignore);
      for (int j = 0; j < 4; ++j) {
        // A triangle's collapsed corner (v3 == v2) adds its shape function to v2.
        if (k[j] * vis[j] != 0) row.emplace_back(patch.v[j], k[j] * vis[j]);
      }
    }
    canonicalize(row);
  };
  return t;
}

// Constant method: row k holds the patch-to-patch factors F_kl (exact near, Gauss far: see
// constantPatchFactor), times a visible fraction from rays between the two patches.
Transport constantTransport(const PatchMesh& mesh, const Occlusion& occlusion, const RadiosityOptions& options) {
  Transport t;
  t.rows = mesh.patches.size();
  const double tolerance = 0.1 * options.kernelTolerance;
  t.build = [&mesh, &occlusion, tolerance](size_t k, Row& row) {
    const Patch& pk = mesh.patches[k];
    const auto qk = corners(mesh, pk);
    const Vec3 lift = pk.normal * (occlusion.epsilon() * 10);
    for (size_t l = 0; l < mesh.patches.size(); ++l) {
      if (l == k) continue;
      const Patch& pl = mesh.patches[l];
      const auto ql = corners(mesh, pl);
      bool facing = false, front = false;
      for (const Vec3& c : ql) facing |= dot(pk.normal, c - qk[0]) > occlusion.epsilon();
      for (const Vec3& c : qk) front |= dot(pl.normal, c - ql[0]) > occlusion.epsilon();
      if (!facing || !front) continue;
      const double f = constantPatchFactor(qk, ql, tolerance);
      if (!(f > 0)) continue;
      // Visible fraction: five rays from the receiver's centre first; if they disagree, 5×5
      // rays between inner points of both patches.
      const uint32_t pair[2] = {uint32_t(k), uint32_t(l)};
      auto ray = [&](int a, int b) {
        return occlusion.visible(pointOnPatch(qk, kProbe[a][0], kProbe[a][1]) + lift,
                                 pointOnPatch(ql, kProbe[b][0], kProbe[b][1]) + pl.normal * (occlusion.epsilon() * 10), pair);
      };
      int seen = 0;
      for (int b = 0; b < 5; ++b) seen += ray(0, b);
      double vis = seen == 5 ? 1.0 : 0.0;
      if (seen > 0 && seen < 5) {
        seen = 0;
        for (int a = 0; a < 5; ++a)
          for (int b = 0; b < 5; ++b) seen += ray(a, b);
        vis = seen / 25.0;
      }
      if (vis > 0) row.emplace_back(uint32_t(l), f * vis);
    }
  };
  return t;
}

// The part of each receiver's projected solid angle that no surface covers, front or back: what a
// uniform sky lights. Two-sided factors of every patch, times their visible fraction.
std::vector<double> bilinearSkyFractions(const PatchMesh& mesh, const Occlusion& occlusion) {
  const std::vector<Vec3> approach = approachDirections(mesh);
  const VertexPatches around = vertexPatches(mesh);
  std::vector<double> sky(mesh.positions.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, sky.size(), 16), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t i = range.begin(); i != range.end(); ++i) {
      const Vec3 p = mesh.positions[i], nrm = mesh.normals[i];
      const Vec3 origin = p + (nrm + approach[i]) * (occlusion.epsilon() * 10);
      double covered = 0;
      std::vector<uint32_t> ignore(around.of(i).begin(), around.of(i).end());
      ignore.push_back(0);
      const auto own = around.of(i);
      for (size_t source = 0; source < mesh.patches.size(); ++source) {
        const Patch& patch = mesh.patches[source];
        ignore.back() = uint32_t(source);
        auto q = corners(mesh, patch);
        Vec3 normal = patch.normal;
        // The vertex's own patches: on a concave surface they rise in front of it and cover what
        // their front-side limit says (as in K); on a convex one they fall away behind it and
        // cover nothing (their limit from behind is ill-conditioned, so it is not taken).
        const bool isOwn = std::find(own.begin(), own.end(), uint32_t(source)) != own.end();
        if (!isOwn && dot(normal, p - q[0]) < 0) {  // seen from behind: the same solid angle, reversed polygon
          // (a triangle's repeated vertex moves but stays consecutive, which the factor accepts)
          std::swap(q[1], q[3]);
          normal = -normal;
        }
        const double f = pointPolygonFactorLimit(p, nrm, approach[i], q.data(), 4);
        if (!(f > 0)) continue;
        const bool touching = nearestQuadPoint(q, p).distance <= occlusion.epsilon();
        const auto vis = touching ? std::array<double, 4>{1, 1, 1, 1} : visibleFraction(occlusion, origin, nrm, q, normal, ignore);
        covered += f * (vis[0] + vis[1] + vis[2] + vis[3]) / 4;
      }
      sky[i] = std::max(0.0, 1 - covered);
    }
  });
  return sky;
}

std::vector<double> constantSkyFractions(const PatchMesh& mesh, const Occlusion& occlusion) {
  std::vector<double> sky(mesh.patches.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, sky.size(), 8), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t k = range.begin(); k != range.end(); ++k) {
      const Patch& pk = mesh.patches[k];
      const auto qk = corners(mesh, pk);
      const Vec3 from = pointOnPatch(qk, 0, 0) + pk.normal * (occlusion.epsilon() * 10);
      double covered = 0;
      for (size_t l = 0; l < mesh.patches.size(); ++l) {
        if (l == k) continue;
        auto ql = corners(mesh, mesh.patches[l]);
        if (dot(mesh.patches[l].normal, pointOnPatch(qk, 0, 0) - ql[0]) < 0) {
          std::swap(ql[1], ql[3]);
        }
        const double f = constantPatchFactor(qk, ql);
        if (!(f > 0)) continue;
        int seen = 0;
          const uint32_t pair[2] = {uint32_t(k), uint32_t(l)};
        for (const auto& b : kProbe) seen += occlusion.visible(from, pointOnPatch(ql, b[0], b[1]), pair);
        covered += f * seen / 5.0;
      }
      sky[k] = std::max(0.0, 1 - covered);
    }
  });
  return sky;
}

// Jacobi iteration L ← L⁰ + ρ ⊙ (K L): every row independent, so parallel and bit-identical for
// any thread count. Converges for ρ < 1 (each row of K sums to at most 1).
void iterate(const Transport& K, const std::vector<Vec3>& emission, const std::vector<Vec3>& reflectance,
             const RadiosityOptions& options, std::vector<Vec3>& L, std::vector<Vec3>& gathered, Solution& solution) {
  const size_t n = emission.size();
  L = emission;
  gathered.assign(n, Vec3{});
  double scale = 0;
  for (const Vec3& e : emission) scale = std::max({scale, std::abs(e.x), std::abs(e.y), std::abs(e.z)});
  if (scale == 0) return;  // no emitter: black is the answer
  std::vector<Vec3> next(n);
  std::vector<double> rowChange(n);
  for (int it = 1; it <= options.maxIterations; ++it) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, K.stored() ? 256 : 8), [&](const tbb::blocked_range<size_t>& range) {
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
        next[i] = emission[i] + Vec3{reflectance[i].x * h.x, reflectance[i].y * h.y, reflectance[i].z * h.z};
        const Vec3 d = next[i] - L[i];
        rowChange[i] = std::max({std::abs(d.x), std::abs(d.y), std::abs(d.z)});
      }
    });
    const double residual = *std::max_element(rowChange.begin(), rowChange.end()) / scale;
    L.swap(next);
    solution.iterations = it;
    solution.residual = residual;
    if (options.progress) options.progress(0.8 + 0.2 * std::min(1.0, std::log(residual) / std::log(options.relativeResidual)));
    if (residual <= options.relativeResidual) break;
  }
}

// Irradiance at x (normal n) from the punctual lights, shadowed (KHR_lights_punctual: intensity
// in candela for point and spot lights, illuminance in lux for directional ones; the spec's spot
// cone and range falloff).
Vec3 directIrradiance(const std::vector<PunctualLight>& lights, const Occlusion& occlusion, const Vec3& origin,
                      const Vec3& x, const Vec3& n, std::span<const uint32_t> ignore) {
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
    const Vec3 target = light.type == PunctualLight::Type::kDirectional ? origin + toLight * (10 * occlusion.sceneSize()) : light.position;
    if (!occlusion.visible(origin, target, ignore)) continue;
    e += light.intensity * (cosine * falloff);
  }
  return e;
}

// Direct light from the punctual lights, as the radiance it adds: ρ E / π per unknown.
std::vector<Vec3> bilinearDirectLight(const Scene& scene, const PatchMesh& mesh, const Occlusion& occlusion) {
  std::vector<Vec3> e(mesh.positions.size());
  if (scene.lights.empty()) return e;
  const std::vector<Vec3> approach = approachDirections(mesh);
  const VertexPatches around = vertexPatches(mesh);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, e.size(), 64), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t i = range.begin(); i != range.end(); ++i) {
      const Vec3 origin = mesh.positions[i] + (mesh.normals[i] + approach[i]) * (occlusion.epsilon() * 10);
      e[i] = directIrradiance(scene.lights, occlusion, origin, mesh.positions[i], mesh.normals[i], around.of(i));
    }
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
          sum += directIrradiance(scene.lights, occlusion, x + patch.normal * (occlusion.epsilon() * 10), x,
                                  patch.normal, self) * w;
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

// The source term: emission plus, with a sky, the reflected sky light ρ · (uncovered fraction) · sky.
std::vector<Vec3> withSky(const std::vector<Vec3>& emission, const std::vector<Vec3>& reflectance,
                          const RadiosityOptions& options, const std::function<std::vector<double>()>& fractions) {
  if (!(options.sky.x > 0 || options.sky.y > 0 || options.sky.z > 0)) return emission;
  const std::vector<double> sky = fractions();
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

}  // namespace

Solution solveRadiosity(const Scene& scene, const PatchMesh& mesh, const RadiosityOptions& options) {
  Solution solution;
  solution.method = options.method;
  solution.interreflection = true;
  Occlusion occlusion(mesh);
  if (!mesh.masks.empty()) occlusion.setCutouts([&](uint32_t patch, double u, double v) { return passesCutout(scene, mesh, patch, u, v); });
  std::vector<Vec3> gathered;
  if (options.method == Method::kBilinear) {
    std::vector<Vec3> emission(mesh.positions.size()), reflectance(mesh.positions.size());
    for (size_t v = 0; v < mesh.positions.size(); ++v) {
      emission[v] = mesh.vertexEmission[v];
      reflectance[v] = mesh.vertexReflectance[v];
    }
    const std::vector<Vec3> source =
        withDirectLight(withSky(emission, reflectance, options, [&] { return bilinearSkyFractions(mesh, occlusion); }),
                        reflectance, bilinearDirectLight(scene, mesh, occlusion));
    Transport K;
    if (anyLight(source)) {  // no light at all: black is the exact answer, no transport needed
      K = bilinearTransport(mesh, occlusion, options);
      storeIfItFits(K, options, solution.matrixEntries);
      solution.matrixFree = !K.stored();
    }
    iterate(K, source, reflectance, options, solution.vertexRadiance, gathered, solution);
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
    std::vector<Vec3> emission(mesh.patches.size()), reflectance(mesh.patches.size());
    for (size_t p = 0; p < mesh.patches.size(); ++p) {
      emission[p] = mesh.patches[p].emission;
      reflectance[p] = mesh.patches[p].reflectance;
    }
    const std::vector<Vec3> source =
        withDirectLight(withSky(emission, reflectance, options, [&] { return constantSkyFractions(mesh, occlusion); }),
                        reflectance, constantDirectLight(scene, mesh, occlusion));
    Transport F;
    if (anyLight(source)) {
      F = constantTransport(mesh, occlusion, options);
      storeIfItFits(F, options, solution.matrixEntries);
      solution.matrixFree = !F.stored();
    }
    iterate(F, source, reflectance, options, solution.patchRadiance, gathered, solution);
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

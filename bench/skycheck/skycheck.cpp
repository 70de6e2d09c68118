// skycheck: each vertex's sky, as a transport solves it, against independent rays.
//
//   skycheck INPUT [--transport exact|hierarchical] [--rays N] [--top K] [--csv FILE]
//            [--max-rms R] [--max-off N]
//
// Bakes INPUT under a sky of 1 (`--refine off`, the CLI's other defaults) and reads the share of
// each vertex's hemisphere that no surface covers (Solution::skyFraction). Then, with nothing of
// radbake's visibility or kernel code, it traces N × N stratified cosine-distributed rays from each
// vertex (about its geometric normal, the mean of its own patches' planes, as the solve's) into
// Embree's own scene of the patches and counts those that meet nothing. The origin is
// the vertex lifted off its surface by a millionth of the scene and moved ten times that into its
// own patches (off the plane of a wall meeting it at a crease), and 8 more origins around it along
// its surface (N/2 rays per axis) give a range: a vertex can lie on another surface (a contact, one
// part running into another), where its sky differs on each side of that surface and the solve
// takes one side. Origins that meet a surface within 5 lifts are not counted; a vertex with none
// left is not judged. The solved sky must lie within the range, to the rays' spread.
//
// Prints how far the solved skies lie outside their ranges (RMS, mean, largest) and the K vertices
// furthest out, with the patches their rays met first; --csv writes every vertex (index, position,
// normal, solved, the range, judged). With --max-rms or --max-off it exits 1 when the RMS, or the
// count of vertices off by more than 0.05, is above the limit (ctest skycheck_engine_part). Threads:
// TBB's default (all cores). Used in docs/results.md, "Thirtieth session".
#include <embree3/rtcore.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <numeric>
#include <string>
#include <vector>

#include "importers/importers.h"
#include "radiosity/radiosity.h"
#include "tessellate/tessellate.h"

using namespace radbake;

namespace {

struct Args {
  std::string input, transport = "hierarchical", csv;
  int rays = 64;  // per axis of the stratified disk
  int top = 12;
  double maxRms = -1;  // --max-rms: fail above this RMS (negative: no limit)
  long maxOff = -1;    // --max-off: fail with more vertices than this off by more than 0.05
};

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    auto value = [&] {
      if (i + 1 >= argc) throw std::runtime_error("skycheck: " + k + " needs a value");
      return std::string(argv[++i]);
    };
    if (k == "--transport") a.transport = value();
    else if (k == "--rays") a.rays = std::stoi(value());
    else if (k == "--top") a.top = std::stoi(value());
    else if (k == "--csv") a.csv = value();
    else if (k == "--max-rms") a.maxRms = std::stod(value());
    else if (k == "--max-off") a.maxOff = std::stol(value());
    else if (a.input.empty() && k[0] != '-') a.input = k;
    else throw std::runtime_error("skycheck: unknown argument " + k);
  }
  if (a.input.empty() || (a.transport != "exact" && a.transport != "hierarchical") || a.rays < 1)
    throw std::runtime_error("usage: skycheck INPUT [--transport exact|hierarchical] [--rays N] [--top K] [--csv FILE] "
                             "[--max-rms R] [--max-off N]");
  return a;
}

// Two unit vectors completing n to an orthonormal frame (Duff et al. 2017).
void frame(const Vec3& n, Vec3& t, Vec3& b) {
  const double s = n.z >= 0 ? 1.0 : -1.0;
  const double a = -1.0 / (s + n.z), c = n.x * n.y * a;
  t = {1 + s * n.x * n.x * a, s * c, -s * n.x};
  b = {c, s + n.y * n.y * a, -n.y};
}

// What N × N stratified cosine-distributed rays from `origin` about `n` meet: the share that meets
// nothing, how many meet a surface closer than `near` (the origin is on or at another surface), and
// the three patches met first by most rays.
struct Census {
  double open = 0;
  size_t near = 0;
  std::vector<std::pair<size_t, uint32_t>> firstMet;  // (rays, patch), most first
};

Census census(RTCScene scene, const Vec3& origin, const Vec3& n, int N, double near) {
  Vec3 t, b;
  frame(n, t, b);
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  Census c;
  size_t open = 0;
  for (int i = 0; i < N; ++i)
    for (int j = 0; j < N; ++j) {
      // Malley: a point stratified over the unit disk, lifted onto the hemisphere.
      const double r = std::sqrt((i + 0.5) / N), phi = 2 * 3.14159265358979323846 * (j + 0.5) / N;
      const Vec3 d = t * (r * std::cos(phi)) + b * (r * std::sin(phi)) + n * std::sqrt(std::max(0.0, 1 - r * r));
      RTCRayHit rh{};
      rh.ray.org_x = float(origin.x); rh.ray.org_y = float(origin.y); rh.ray.org_z = float(origin.z);
      rh.ray.dir_x = float(d.x); rh.ray.dir_y = float(d.y); rh.ray.dir_z = float(d.z);
      rh.ray.tfar = std::numeric_limits<float>::infinity();
      rh.ray.mask = 0xFFFFFFFF;
      rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
      rtcIntersect1(scene, &context, &rh);
      if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) {
        ++open;
        continue;
      }
      if (rh.ray.tfar < near) ++c.near;
      auto it = std::find_if(c.firstMet.begin(), c.firstMet.end(), [&](const auto& m) { return m.second == rh.hit.primID; });
      if (it == c.firstMet.end()) c.firstMet.push_back({1, rh.hit.primID});
      else ++it->first;
    }
  std::sort(c.firstMet.begin(), c.firstMet.end(), std::greater<>());
  if (c.firstMet.size() > 3) c.firstMet.resize(3);
  c.open = double(open) / (double(N) * N);
  return c;
}

}  // namespace

int main(int argc, char** argv) try {
  const Args args = parse(argc, argv);
  const auto t0 = std::chrono::steady_clock::now();
  const Scene scene = importScene(args.input, {});
  const PatchMesh mesh = tessellate(scene, {});
  RadiosityOptions options;
  options.transport = args.transport == "exact" ? TransportMode::kExact : TransportMode::kHierarchical;
  options.sky = {1, 1, 1};
  const Solution solution = solveRadiosity(scene, mesh, options);
  const auto t1 = std::chrono::steady_clock::now();

  RTCDevice device = rtcNewDevice(nullptr);
  RTCScene rays = rtcNewScene(device);
  rtcSetSceneFlags(rays, RTC_SCENE_FLAG_ROBUST);
  RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_QUAD);
  auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                                        mesh.positions.size()));
  Bounds bounds;
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    v[3 * i] = float(mesh.positions[i].x), v[3 * i + 1] = float(mesh.positions[i].y), v[3 * i + 2] = float(mesh.positions[i].z);
    bounds.add(mesh.positions[i]);
  }
  auto* q = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT4, 4 * sizeof(unsigned),
                                                           mesh.patches.size()));
  for (size_t p = 0; p < mesh.patches.size(); ++p)
    for (int k = 0; k < 4; ++k) q[4 * p + k] = mesh.patches[p].v[k];
  rtcCommitGeometry(geom);
  rtcAttachGeometry(rays, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(rays);
  const double lift = 1e-6 * bounds.diagonal();

  // Each vertex's own patches, and the way into them along its surface: the sum of the unit
  // directions from it to their centres, in its tangent plane. The origin goes 10 lifts that way and
  // one lift along the normal: off the planes of the patches meeting it at a crease, which a ray
  // from the vertex itself would start in.
  const size_t n = mesh.positions.size();
  std::vector<std::vector<uint32_t>> own(n);
  std::vector<Vec3> inward(n);
  for (size_t p = 0; p < mesh.patches.size(); ++p) {
    const Patch& patch = mesh.patches[p];
    const int corners = patch.v[2] == patch.v[3] ? 3 : 4;
    Vec3 centre{};
    for (int k = 0; k < corners; ++k) centre += mesh.positions[patch.v[k]] / double(corners);
    for (int k = 0; k < corners; ++k) {
      own[patch.v[k]].push_back(uint32_t(p));
      const Vec3 d = centre - mesh.positions[patch.v[k]];
      if (length(d) > 0) inward[patch.v[k]] += d / length(d);
    }
  }
  // The receiving normal is the geometry's, as the solve's (docs/radiosity.md): the mean of the
  // distinct planes of the vertex's own patches (a file's shading normal can lie outside them).
  std::vector<Vec3> normal(n);
  for (size_t i = 0; i < n; ++i) {
    std::vector<Vec3> planes;
    for (const uint32_t p : own[i])
      if (std::none_of(planes.begin(), planes.end(), [&](const Vec3& m) { return dot(m, mesh.patches[p].normal) > 1 - 1e-9; }))
        planes.push_back(mesh.patches[p].normal);
    Vec3 sum{};
    for (const Vec3& m : planes) sum += m;
    normal[i] = length(sum) > 1e-9 ? sum / length(sum) : mesh.normals[i];
  }
  std::vector<Vec3> origin(n);
  for (size_t i = 0; i < n; ++i) {
    const Vec3& nv = normal[i];
    const Vec3 in = inward[i] - nv * dot(nv, inward[i]);
    origin[i] = mesh.positions[i] + nv * lift + (length(in) > 1e-9 ? in / length(in) * (10 * lift) : Vec3{});
  }
  // A vertex can lie on another surface (a contact, one part running into another, a cut along
  // where they meet). Its sky is then a limit, different on each side of that surface (the solve
  // takes the side in front of it, docs/radiosity.md). So every vertex is traced from 8 more origins
  // around it, 10 lifts away along its surface (with half the rays per axis), and judged against
  // the range of the origins that are clear (no ray meeting anything within 5 lifts): on an open
  // surface the range is the rays' spread, across a surface running through the vertex it spans
  // both sides, and the solved sky must lie within it. A vertex without a clear origin is not judged.
  struct Traced {
    double low = 0, high = 0;  // the sky's range over the clear origins
    bool judged = false;
    Census census;             // the clear origin seeing the most sky
  };
  std::vector<Traced> traced(n);
  tbb::parallel_for(size_t(0), n, [&](size_t i) {
    Traced& t = traced[i];
    const Vec3& nv = normal[i];
    auto take = [&](const Census& c) {
      if (c.near > 0) return;
      if (!t.judged || c.open < t.low) t.low = c.open;
      if (!t.judged || c.open > t.high) t.high = c.open, t.census = c;
      t.judged = true;
    };
    take(census(rays, origin[i], nv, args.rays, 5 * lift));
    Vec3 u, w;
    frame(nv, u, w);
    for (int k = 0; k < 8; ++k) {
      const double a = 2 * 3.14159265358979323846 * k / 8;
      take(census(rays, mesh.positions[i] + nv * lift + (u * std::cos(a) + w * std::sin(a)) * (10 * lift), nv, std::max(1, args.rays / 2),
                  5 * lift));
    }
  });
  const auto t2 = std::chrono::steady_clock::now();

  // How far the solved sky lies outside the rays' range.
  auto off = [&](size_t i) { return solution.skyFraction[i] - std::clamp(solution.skyFraction[i], traced[i].low, traced[i].high); };
  std::vector<size_t> order;
  size_t unjudged = 0;
  double sum2 = 0, net = 0, spread = 0;
  for (size_t i = 0; i < n; ++i) {
    if (!traced[i].judged) {
      ++unjudged;
      continue;
    }
    sum2 += off(i) * off(i);
    spread += traced[i].high - traced[i].low;
    net += off(i);
    order.push_back(i);
  }
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return std::abs(off(a)) > std::abs(off(b)); });
  auto seconds = [](auto a, auto b) { return std::chrono::duration<double>(b - a).count(); };
  std::printf("%s: %zu vertices, %zu patches, transport %s (%.1f s), %d x %d rays a vertex (%.1f s)\n", args.input.c_str(), n,
              mesh.patches.size(), args.transport.c_str(), seconds(t0, t1), args.rays, args.rays, seconds(t1, t2));
  const double counted = std::max<double>(1, double(order.size())), rms = std::sqrt(sum2 / counted);
  // A stratified estimate's spread is below the plain one's, sqrt(s (1 - s) / N²) <= 0.5 / N.
  std::printf("sky, solved outside the rays' range, over %zu vertices (%zu not judged): RMS %.5f, mean %+.5f, largest %.5f "
              "(the range's mean width %.5f; one origin's spread at most %.5f)\n",
              order.size(), unjudged, rms, net / counted, order.empty() ? 0.0 : std::abs(off(order[0])),
              spread / counted, 0.5 / args.rays);
  for (size_t k = 0; k < std::min<size_t>(args.top, order.size()); ++k) {
    const size_t i = order[k];
    std::printf("  vertex %zu at (%.6g, %.6g, %.6g) normal (%.3f, %.3f, %.3f): solved %.4f, rays %.4f", i, mesh.positions[i].x,
                mesh.positions[i].y, mesh.positions[i].z, normal[i].x, normal[i].y, normal[i].z,
                solution.skyFraction[i], traced[i].low);
    if (traced[i].high > traced[i].low) std::printf(" to %.4f", traced[i].high);
    std::printf("\n");
    for (const auto& [count, p] : traced[i].census.firstMet) {
      const Patch& patch = mesh.patches[p];
      const bool mine = std::find(own[i].begin(), own[i].end(), p) != own[i].end();
      std::printf("    met first by %zu rays: patch %u (primitive %d), normal (%.3f, %.3f, %.3f), the vertex %.3g in front of its plane%s\n",
                  count, p, patch.primitive, patch.normal.x, patch.normal.y, patch.normal.z,
                  dot(patch.normal, mesh.positions[i] - mesh.positions[patch.v[0]]), mine ? " (its own)" : "");
    }
  }
  rtcReleaseScene(rays);
  rtcReleaseDevice(device);
  const long offCount = std::count_if(order.begin(), order.end(), [&](size_t i) { return std::abs(off(i)) > 0.05; });
  std::printf("%ld vertices off by more than 0.05\n", offCount);
  if (!args.csv.empty()) {
    std::ofstream out(args.csv);
    out << "vertex,x,y,z,nx,ny,nz,solved,low,high,judged\n";
    for (size_t i = 0; i < n; ++i)
      out << i << ',' << mesh.positions[i].x << ',' << mesh.positions[i].y << ',' << mesh.positions[i].z << ',' << normal[i].x
          << ',' << normal[i].y << ',' << normal[i].z << ',' << solution.skyFraction[i] << ',' << traced[i].low << ','
          << traced[i].high << ',' << traced[i].judged << '\n';
  }
  if (args.maxRms >= 0 && rms > args.maxRms) {
    std::fprintf(stderr, "skycheck: %s: RMS %.5f above --max-rms %g\n", args.input.c_str(), rms, args.maxRms);
    return 1;
  }
  if (args.maxOff >= 0 && offCount > args.maxOff) {
    std::fprintf(stderr, "skycheck: %s: %ld vertices off by more than 0.05, above --max-off %ld\n", args.input.c_str(), offCount, args.maxOff);
    return 1;
  }
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "%s\n", e.what());
  return 1;
}

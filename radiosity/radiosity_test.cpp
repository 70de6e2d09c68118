// Radiosity solver tests against answers that do not come from the solver: the furnace identity
// L = L⁰/(1−ρ), the one-patch cube values and converged face averages of tests/data/reference, the
// exact two-plates field, power balance and the closed-scene mean-radiance invariant.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <tbb/global_control.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <set>
#include <string_view>
#include <tuple>

#include "radiosity/form_factor.h"
#include "radiosity/radiosity.h"
#include "radiosity/visibility.h"

namespace fs = std::filesystem;
using namespace radbake;
using nlohmann::json;

namespace {

const fs::path kScenes = fs::path(RADBAKE_TEST_DATA_DIR) / "scenes";
const fs::path kData = fs::path(RADBAKE_TEST_DATA_DIR) / "reference";

Material material(const char* name, double rho, double emission, bool doubleSided = false) {
  Material m;
  m.name = name;
  m.reflectance = {rho, rho, rho};
  m.emission = {emission, emission, emission};
  m.doubleSided = doubleSided;
  return m;
}

json loadJson(const fs::path& path) {
  std::ifstream in(path);
  return json::parse(in);
}

struct Baked {
  Scene scene;
  PatchMesh mesh;
  Solution solution;
};

Baked bake(const std::string& file, int n, Method method, double tolerance = 1e-6,
           TransportMode transport = TransportMode::kExact, const Vec3& sky = {}) {
  Baked b;
  b.scene = importScene((kScenes / file).string());
  TessellateOptions t;
  t.subdivide = n;
  b.mesh = tessellate(b.scene, t);
  RadiosityOptions o;
  o.method = method;
  o.relativeResidual = tolerance;
  o.transport = transport;
  o.sky = sky;
  b.solution = solveRadiosity(b.scene, b.mesh, o);
  return b;
}


// Area-weighted average of L over each cube face (faces are meshes named floor, ceiling, ...).
std::map<std::string, double> faceAverages(const Baked& b, const json& names) {
  std::map<int, std::pair<double, double>> byMesh;  // mesh → (∫L, area), channel 0
  for (size_t p = 0; p < b.mesh.patches.size(); ++p) {
    const Patch& patch = b.mesh.patches[p];
    std::array<Vec3, 4> q;
    for (int k = 0; k < 4; ++k) q[k] = b.mesh.positions[patch.v[k]];
    const auto a = shapeFunctionAreas(q);
    double integral = 0;
    if (b.solution.method == Method::kBilinear) {
      for (int j = 0; j < 4; ++j) integral += a[j] * b.solution.vertexRadiance[patch.v[j]].x;
    } else {
      integral = b.solution.patchRadiance[p].x * (a[0] + a[1] + a[2] + a[3]);
    }
    auto& acc = byMesh[b.scene.primitives[patch.primitive].mesh];
    acc.first += integral;
    acc.second += a[0] + a[1] + a[2] + a[3];
  }
  std::map<std::string, double> out;
  for (const auto& [mesh, acc] : byMesh) out[names[mesh].get<std::string>()] = acc.first / acc.second;
  return out;
}

json meshNames(const std::string& file) {
  const json doc = loadJson(kScenes / file);
  json names = json::array();
  for (const auto& m : doc["meshes"]) names.push_back(m["name"]);
  return names;
}

// (method, transport): both methods with both transports (the hierarchical one's far links begin
// at N = 3 here; Hierarchical.Furnace* goes further).
using Solver = std::pair<Method, TransportMode>;
class Furnace : public ::testing::TestWithParam<std::tuple<int, Solver>> {};

TEST_P(Furnace, RadianceIsTwoAtEveryVertexAndPatch) {
  const auto [n, solver] = GetParam();
  const auto [method, transport] = solver;
  const Baked b = bake("furnace_cube.gltf", n, method, 1e-6, transport);
  double worst = 0;
  if (method == Method::kBilinear) {
    ASSERT_EQ(b.solution.vertexRadiance.size(), size_t(6 * (n + 1) * (n + 1)));
    for (const Vec3& L : b.solution.vertexRadiance)
      worst = std::max({worst, std::abs(L.x - 2), std::abs(L.y - 2), std::abs(L.z - 2)});
  } else {
    for (const Vec3& L : b.solution.patchRadiance)
      worst = std::max({worst, std::abs(L.x - 2), std::abs(L.y - 2), std::abs(L.z - 2)});
  }
  EXPECT_LT(worst, 1e-6) << "N=" << n;
  // Closed scene: what is emitted is absorbed.
  EXPECT_NEAR(b.solution.absorbedPower / b.solution.emittedPower, 1.0, 1e-6);
}

INSTANTIATE_TEST_SUITE_P(
    BothMethods, Furnace,
    ::testing::Combine(::testing::Values(1, 2, 3, 4, 5, 6, 7, 8),
                       ::testing::Values(Solver{Method::kBilinear, TransportMode::kExact},
                                         Solver{Method::kBilinear, TransportMode::kHierarchical},
                                         Solver{Method::kConstant, TransportMode::kExact},
                                         Solver{Method::kConstant, TransportMode::kHierarchical})),
    [](const auto& info) {
      const Solver solver = std::get<1>(info.param);
      return std::string(solver.first == Method::kBilinear ? "bilinear" : "constant") +
             (solver.second == TransportMode::kHierarchical ? "_hierarchical" : "") + "_N" +
             std::to_string(std::get<0>(info.param));
    });

TEST(FloorEmitterCube, OnePatchBilinearMatchesTheReference) {
  const json ref = loadJson(kData / "cube_radiosity.json")["floor_emitter"]["bilinear_1patch"];
  const Baked b = bake("floor_emitter_cube.gltf", 1, Method::kBilinear, 1e-12);
  // Classify each vertex by its face and height.
  const json names = meshNames("floor_emitter_cube.gltf");
  int checked = 0;
  for (size_t p = 0; p < b.mesh.patches.size(); ++p) {
    const std::string face = names[b.scene.primitives[b.mesh.patches[p].primitive].mesh];
    for (uint32_t v : b.mesh.patches[p].v) {
      const double y = b.mesh.positions[v].y, L = b.solution.vertexRadiance[v].x;
      const char* key = face == "floor" ? "floor_corner" : face == "ceiling" ? "ceiling_corner"
                        : y < 0.5 ? "wall_bottom_corner" : "wall_top_corner";
      EXPECT_NEAR(L, ref[key].get<double>(), 1e-6) << face << " y=" << y;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 24);
}

TEST(FloorEmitterCube, OnePatchConstantMatchesTheReference) {
  const json ref = loadJson(kData / "cube_radiosity.json")["floor_emitter"]["constant_1patch"];
  const Baked b = bake("floor_emitter_cube.gltf", 1, Method::kConstant, 1e-12);
  const json names = meshNames("floor_emitter_cube.gltf");
  for (size_t p = 0; p < b.mesh.patches.size(); ++p) {
    const std::string face = names[b.scene.primitives[b.mesh.patches[p].primitive].mesh];
    const char* key = face == "floor" ? "floor" : face == "ceiling" ? "ceiling" : "walls";
    EXPECT_NEAR(b.solution.patchRadiance[p].x, ref[key].get<double>(), 1e-6) << face;
  }
}

// Face averages approach the converged continuous solution; the observed orders are printed (and
// recorded in docs/results.md). Face averages favour the constant method (a Galerkin method whose
// averages converge fast), so the test asserts convergence, not which method wins.
TEST(FloorEmitterCube, FaceAveragesConvergeToTheContinuousSolution) {
  const json ref = loadJson(kData / "cube_radiosity.json")["floor_emitter"]["continuous"]["face_average"];
  const json names = meshNames("floor_emitter_cube.gltf");
  std::map<Method, std::vector<double>> errors;
  const std::vector<int> levels{2, 4, 8};
  for (Method method : {Method::kBilinear, Method::kConstant})
    for (int n : levels) {
      const Baked b = bake("floor_emitter_cube.gltf", n, method, 1e-10);
      double worst = 0;
      for (const auto& [face, avg] : faceAverages(b, names))
        worst = std::max(worst, std::abs(avg - ref[face].get<double>()) / ref[face].get<double>());
      errors[method].push_back(worst);
      // Exact invariant of this scene: the area-weighted mean of L is (1/6)/(1−0.5) = 1/3.
      double mean = 0;
      for (const auto& [face, avg] : faceAverages(b, names)) mean += avg / 6;
      EXPECT_NEAR(mean, 1.0 / 3, method == Method::kConstant ? 1e-6 : 0.02) << "N=" << n;
    }
  for (Method method : {Method::kBilinear, Method::kConstant}) {
    const auto& e = errors[method];
    for (size_t i = 1; i < e.size(); ++i) EXPECT_LT(e[i], e[i - 1]);
    const double order = std::log(e.front() / e.back()) / std::log(double(levels.back()) / levels.front());
    EXPECT_GT(order, 1.5);
    std::printf("floor-emitter cube, %s: max relative face-average error N=2,4,8: %.3e %.3e %.3e, observed order %.2f\n",
                method == Method::kBilinear ? "bilinear" : "constant", e[0], e[1], e[2], order);
  }
}

TEST(TwoPlates, ReceiverVerticesMatchTheClosedForm) {
  const json ref = loadJson(kScenes / "two_plates_reference.json");
  const Baked b = bake("two_plates.gltf", 1, Method::kBilinear, 1e-12);
  const auto& vertices = ref["vertices"];
  int checked = 0;
  for (const auto& v : vertices) {
    const Vec3 pos{v["pos"][0], v["pos"][1], v["pos"][2]};
    const Vec3 nrm{v["nrm"][0], v["nrm"][1], v["nrm"][2]};
    const Vec3 L = evaluateRadiance(b.solution, b.mesh, pos, nrm);
    EXPECT_NEAR(L.x, v["L"][0].get<double>(), 1e-9 * std::max(1.0, v["L"][0].get<double>())) << pos.x << " " << pos.z;
    ++checked;
  }
  EXPECT_GE(checked, 25);
}

TEST(Probe, ReproducesVertexValuesExactly) {
  const Baked b = bake("floor_emitter_cube.gltf", 3, Method::kBilinear);
  for (size_t v = 0; v < b.mesh.positions.size(); ++v) {
    const Vec3 L = evaluateRadiance(b.solution, b.mesh, b.mesh.positions[v], b.mesh.normals[v]);
    EXPECT_NEAR(L.x, b.solution.vertexRadiance[v].x, 1e-14) << v;  // to rounding of the shape functions
  }
}

TEST(Solver, IdenticalForAnyThreadCount) {
  std::vector<Vec3> one, two;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    one = bake("cornell_box.gltf", 3, Method::kBilinear).solution.vertexRadiance;
  }
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    two = bake("cornell_box.gltf", 3, Method::kBilinear).solution.vertexRadiance;
  }
  ASSERT_EQ(one.size(), two.size());
  for (size_t i = 0; i < one.size(); ++i) EXPECT_TRUE(one[i] == two[i]) << i;
}

// Hierarchical transport: links to whole clusters keep every enclosed row's total exact (closure
// scales near entries and far links alike), so a subdivided furnace is still 2 everywhere; the
// clusters really are used (far links), and the same bits come out for any thread count.
TEST(Hierarchical, FurnaceIsTwoEverywhereWithFarLinks) {
  for (const Method method : {Method::kBilinear, Method::kConstant}) {
    const Baked b = bake("furnace_cube.gltf", 16, method, 1e-10, TransportMode::kHierarchical);
    EXPECT_GT(b.solution.farLinks, b.mesh.patches.size());
    double worst = 0;
    for (const Vec3& L : method == Method::kBilinear ? b.solution.vertexRadiance : b.solution.patchRadiance)
      worst = std::max({worst, std::abs(L.x - 2), std::abs(L.y - 2), std::abs(L.z - 2)});
    EXPECT_LT(worst, 1e-5) << (method == Method::kBilinear ? "bilinear" : "constant");
    EXPECT_NEAR(b.solution.absorbedPower / b.solution.emittedPower, 1.0, 1e-6);
  }
}

TEST(Hierarchical, IdenticalForAnyThreadCount) {
  // With a sky too: the bilinear method's sky is its rows' (a gather) less its backs' cover walk.
  for (const Vec3 sky : {Vec3{}, Vec3{2, 2, 2}})
    for (const Method method : {Method::kBilinear, Method::kConstant}) {
      auto run = [&](int threads) {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, threads);
        const Solution s =
            bake("cornell_box.gltf", method == Method::kBilinear ? 8 : 4, method, 1e-6, TransportMode::kHierarchical, sky).solution;
        return method == Method::kBilinear ? s.vertexRadiance : s.patchRadiance;
      };
      const std::vector<Vec3> one = run(1), two = run(2);
      ASSERT_EQ(one.size(), two.size());
      for (size_t i = 0; i < one.size(); ++i) EXPECT_TRUE(one[i] == two[i]) << i;
    }
}

// Issue 16's accuracy bounds for a hierarchical bake against the exact one, unknown by unknown: RMS
// difference ≤ 0.5% and largest ≤ 3% of the mean radiance (the channels averaged).
void expectWithinIssueBounds(const std::vector<Vec3>& exactL, const std::vector<Vec3>& hierL) {
  ASSERT_EQ(exactL.size(), hierL.size());
  double mean = 0, sumSquares = 0, largest = 0;
  const size_t n = exactL.size();
  for (size_t v = 0; v < n; ++v) {
    const Vec3 &a = exactL[v], &b = hierL[v];
    mean += (a.x + a.y + a.z) / 3 / n;
    const double d = std::abs((a.x + a.y + a.z) - (b.x + b.y + b.z)) / 3;
    sumSquares += d * d / n;
    largest = std::max(largest, d);
  }
  EXPECT_LT(std::sqrt(sumSquares) / mean, 0.005);
  EXPECT_LT(largest / mean, 0.03);
}

// And no net loss or gain in any channel on the lit surfaces: the mean of (hierarchical − exact) /
// brightness over the lit vertices of non-emitting patches, per channel, within 0.6% (the bounds above
// take the emitters' radiance into their mean, which hides a bias of the reflected light). Hidden
// verdicts from a ray or two per receiver made the Cornell box's walls 1.2% too dark in red, 0.6%
// in green at N = 8 (the light's penumbrae: 8.7% RMS on the floor with the direct light alone);
// now 0.36% and 0.22%.
void expectNoNetBias(const PatchMesh& mesh, const std::vector<Vec3>& exactL, const std::vector<Vec3>& hierL) {
  std::vector<bool> emits(exactL.size(), false);
  for (const Patch& p : mesh.patches)
    if (p.emission.x > 0 || p.emission.y > 0 || p.emission.z > 0)
      for (uint32_t v : p.v) emits[v] = true;
  auto brightnessOf = [&](size_t v) { return (exactL[v].x + exactL[v].y + exactL[v].z) / 3; };
  double mean = 0;
  size_t lit = 0;
  for (size_t v = 0; v < exactL.size(); ++v)
    if (!emits[v]) mean += brightnessOf(v), ++lit;
  mean /= std::max<size_t>(lit, 1);
  double sum[3] = {0, 0, 0};
  size_t count = 0;
  for (size_t v = 0; v < exactL.size(); ++v) {
    const double brightness = brightnessOf(v);
    if (emits[v] || !(brightness > 0.01 * mean)) continue;  // not the unlit backs of the walls
    for (int c = 0; c < 3; ++c) sum[c] += (hierL[v][c] - exactL[v][c]) / brightness;
    ++count;
  }
  ASSERT_GT(count, 0u);
  for (int c = 0; c < 3; ++c) {
    EXPECT_LT(std::abs(sum[c] / count), 0.006) << "channel " << c << ": " << sum[c] / count;
  }
}

// Against the exact transport (the second method) on the Cornell box at N = 8, with and without a
// sky through its open front (the sky pass walks the clusters too): the issue's accuracy bounds,
// RMS ≤ 0.5% and largest ≤ 3% of the mean radiance.
// The constant method likewise, patch by patch (at N = 4: its exact transport is the slow one).
class HierarchicalCornell : public ::testing::TestWithParam<std::tuple<Method, bool>> {};

TEST_P(HierarchicalCornell, AgreesWithExactTransport) {
  const auto [method, sky] = GetParam();
  auto run = [&](TransportMode transport) {
    Baked b;
    b.scene = importScene((kScenes / "cornell_box.gltf").string());
    TessellateOptions t;
    t.subdivide = method == Method::kBilinear ? 8 : 4;
    t.flatPatches = method == Method::kConstant;
    b.mesh = tessellate(b.scene, t);
    RadiosityOptions o;
    o.method = method;
    o.transport = transport;
    if (sky) o.sky = {4, 4, 4};
    b.solution = solveRadiosity(b.scene, b.mesh, o);
    return b;
  };
  const Baked exact = run(TransportMode::kExact);
  const Baked hier = run(TransportMode::kHierarchical);
  const auto& exactL = method == Method::kBilinear ? exact.solution.vertexRadiance : exact.solution.patchRadiance;
  const auto& hierL = method == Method::kBilinear ? hier.solution.vertexRadiance : hier.solution.patchRadiance;
  EXPECT_GT(hier.solution.farLinks, 0u);
  expectWithinIssueBounds(exactL, hierL);
  if (method == Method::kBilinear) expectNoNetBias(hier.mesh, exactL, hierL);
}

INSTANTIATE_TEST_SUITE_P(Sky, HierarchicalCornell, ::testing::Combine(::testing::Values(Method::kBilinear, Method::kConstant), ::testing::Bool()),
                         [](const auto& info) {
                           return std::string(std::get<0>(info.param) == Method::kBilinear ? "bilinear" : "constant") +
                                  (std::get<1>(info.param) ? "_with_sky" : "_without_sky");
                         });

TEST(Solver, CornellBoxStaysBoundedAndNoLightLeaksUnderBlocks) {
  const Baked b = bake("cornell_box.gltf", 4, Method::kBilinear);
  for (size_t v = 0; v < b.mesh.positions.size(); ++v) {
    const Vec3& L = b.solution.vertexRadiance[v];
    const Material& m = b.scene.materials[b.mesh.vertexMaterial[v]];
    EXPECT_GE(L.x, m.emission.x);
    if (m.emission.x == 0) {
      EXPECT_LT(L.x, 17);  // no reflector outshines the light
    }
  }
  // The Cornell box is closed except for its open front: some light escapes, none is created.
  EXPECT_LT(b.solution.absorbedPower, b.solution.emittedPower);
  EXPECT_GT(b.solution.absorbedPower, 0.5 * b.solution.emittedPower);
}

}  // namespace

namespace {

// An axis-aligned box as one primitive: 6 faces of 2 triangles, facing in or out, own vertices
// per face (creases are not welded).
Primitive boxPrimitive(const Vec3& lo, const Vec3& hi, bool inward, int material) {
  Primitive p;
  p.material = material;
  p.hasNormals = true;
  const Vec3 c[8] = {{lo.x, lo.y, lo.z}, {hi.x, lo.y, lo.z}, {hi.x, hi.y, lo.z}, {lo.x, hi.y, lo.z},
                     {lo.x, lo.y, hi.z}, {hi.x, lo.y, hi.z}, {hi.x, hi.y, hi.z}, {lo.x, hi.y, hi.z}};
  // Faces counter-clockwise seen from outside.
  const int faces[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {3, 7, 6, 2}, {0, 4, 7, 3}, {1, 2, 6, 5}};
  for (const auto& f : faces) {
    int q[4] = {f[0], f[1], f[2], f[3]};
    if (inward) std::swap(q[1], q[3]);
    const Vec3 n = normalize(cross(c[q[1]] - c[q[0]], c[q[2]] - c[q[0]]));
    const uint32_t base = uint32_t(p.positions.size());
    for (int k : q) {
      p.positions.push_back(c[k]);
      p.normals.push_back(n);
    }
    p.triangles.push_back({base, base + 1, base + 2});
    p.triangles.push_back({base, base + 2, base + 3});
  }
  return p;
}

// A furnace made the way Blender exports a cube: one primitive whose faces each have their own four
// vertices (24 in all), subdivided at a rate that is not a power of two. The points along an edge
// two faces share must come out with the same bits from both faces, or the box is not found closed
// (its edges do not match) and closure is lost: the rows of its unknowns are not held to 1, and a
// closed double-sided object's inside is not known to be dark. Until 2026-12-03 each face
// interpolated an edge from its own lower vertex index: all 96 unknowns lost their closure at N = 3.
TEST(Closure, AnUnweldedBoxIsClosedAtAnyRate) {
  Scene scene;
  scene.materials = {material("furnace", 0.5, 1)};
  scene.primitives.push_back(boxPrimitive({0.1, 0.2, 0.3}, {1.3, 1.1, 1.7}, true, 0));
  for (int n : {3, 5}) {
    TessellateOptions t;
    t.subdivide = n;
    const PatchMesh mesh = tessellate(scene, t);
    for (TransportMode transport : {TransportMode::kExact, TransportMode::kHierarchical}) {
      RadiosityOptions o;
      o.transport = transport;
      o.relativeResidual = 1e-10;
      const Solution s = solveRadiosity(scene, mesh, o);
      EXPECT_EQ(s.enclosedUnknowns, mesh.positions.size()) << "N = " << n;
      double worst = 0;
      for (const Vec3& L : s.vertexRadiance) worst = std::max(worst, std::abs(L.x - 2));
      EXPECT_LT(worst, 1e-5) << "N = " << n << (transport == TransportMode::kExact ? ", exact" : ", hierarchical");
    }
  }
}

TEST(Visibility, RaysFromOnePointMeetWhatEachRayAloneMeets) {
  // Occlusion::firstHits traces rays from one point in packets; each must meet what firstHit meets
  // alone: inside a closed room with a box standing in it every ray meets something, and a patch
  // in the ignore list is stepped over (the ray meets what lies behind it).
  Scene scene;
  scene.materials = {material("room", 0.5, 0)};
  scene.primitives.push_back(boxPrimitive({0, 0, 0}, {2, 2, 2}, true, 0));
  scene.primitives.push_back(boxPrimitive({1.2, 1.2, 0}, {1.6, 1.6, 0.4}, false, 0));
  for (int p = 0; p < 2; ++p) scene.primitives[p].primitive = p;
  TessellateOptions t;
  t.subdivide = 4;
  const PatchMesh mesh = tessellate(scene, t);
  const Occlusion occlusion(mesh);
  const Vec3 from{0.5, 0.5, 0.3};
  std::vector<Vec3> to;  // 21 directions (not a multiple of 8), far past the walls
  for (int k = 0; k < 21; ++k) {
    const double a = 0.3 * k, z = -0.9 + 0.09 * k;
    to.push_back(from + Vec3{std::cos(a), std::sin(a), z} * 10.0);
  }
  to.push_back(from + Vec3{1, 1, -0.25} * 10.0);  // at the box standing on the floor
  std::vector<int64_t> hits(to.size(), -7);
  occlusion.firstHits(from, to, {}, hits.data());
  std::set<int64_t> met;
  for (size_t k = 0; k < to.size(); ++k) {
    EXPECT_EQ(hits[k], occlusion.firstHit(from, to[k])) << "ray " << k;
    EXPECT_GE(hits[k], 0) << "ray " << k << " left a closed room";
    met.insert(hits[k]);
  }
  EXPECT_GT(met.size(), 10u);
  // The box's patch in the way of the last ray, ignored: that ray now meets the room behind it.
  const uint32_t box = uint32_t(hits.back());
  EXPECT_EQ(mesh.patches[box].primitive, 1);
  const std::vector<uint32_t> ignore{box};
  std::vector<int64_t> past(to.size(), -7);
  occlusion.firstHits(from, to, ignore, past.data());
  for (size_t k = 0; k < to.size(); ++k) EXPECT_EQ(past[k], occlusion.firstHit(from, to[k], ignore)) << "ray " << k;
  EXPECT_NE(past.back(), hits.back());
  EXPECT_GE(past.back(), 0);
}

TEST(Visibility, NoLightLeaksOutOfAClosedBox) {
  // A lamp box (glowing inside, closed, its outside a zero-thickness shell on the same corners)
  // floats in a room. Its outside and the room must stay exactly black at every vertex, including
  // the shell's vertices on the lamp's edges and corners, which coincide with lit vertices.
  Scene scene;
  scene.materials = {material("room", 0.5, 0), material("glow", 0.5, 1)};
  scene.primitives.push_back(boxPrimitive({0, 0, 0}, {2, 2, 2}, true, 0));         // the room
  scene.primitives.push_back(boxPrimitive({0.5, 0.25, 0.5}, {1, 1, 1}, true, 1));   // lamp, inside
  scene.primitives.push_back(boxPrimitive({0.5, 0.25, 0.5}, {1, 1, 1}, false, 0));  // lamp, outside
  for (int p = 0; p < 3; ++p) scene.primitives[p].primitive = p;
  TessellateOptions t;
  t.subdivide = 3;
  const PatchMesh mesh = tessellate(scene, t);
  const Solution solution = solveRadiosity(scene, mesh);
  int dark = 0, lit = 0;
  for (size_t v = 0; v < mesh.positions.size(); ++v) {
    if (mesh.vertexMaterial[v] == 1) {
      EXPECT_NEAR(solution.vertexRadiance[v].x, 2.0, 1e-6);  // a closed furnace inside the lamp
      ++lit;
    } else {
      EXPECT_EQ(solution.vertexRadiance[v].x, 0.0) << "leak at " << mesh.positions[v].x << " "
                                                   << mesh.positions[v].y << " " << mesh.positions[v].z;
      ++dark;
    }
  }
  EXPECT_GT(dark, 0);
  EXPECT_GT(lit, 0);
}

}  // namespace

namespace {

TEST(Solver, MatrixFreeGivesTheSameBitsAsStoredRows) {
  for (Method method : {Method::kBilinear, Method::kConstant}) {
    const Scene scene = importScene((kScenes / "cornell_box.gltf").string());
    TessellateOptions t;
    t.subdivide = 2;
    const PatchMesh mesh = tessellate(scene, t);
    RadiosityOptions stored, free;
    stored.method = free.method = method;
    free.matrixMemoryBytes = 0;
    const Solution a = solveRadiosity(scene, mesh, stored);
    const Solution b = solveRadiosity(scene, mesh, free);
    EXPECT_FALSE(a.matrixFree);
    EXPECT_TRUE(b.matrixFree);
    EXPECT_EQ(a.iterations, b.iterations);
    ASSERT_EQ(a.vertexRadiance.size(), b.vertexRadiance.size());
    for (size_t i = 0; i < a.vertexRadiance.size(); ++i) EXPECT_TRUE(a.vertexRadiance[i] == b.vertexRadiance[i]) << i;
  }
}

}  // namespace

namespace {

// Under a uniform sky of radiance 1, a receiver whose hemisphere holds only a unit emitter (also
// of radiance 1) and sky sees radiance 1 everywhere: L = ρ · 1 = 0.5 exactly at every vertex.
TEST(Sky, TwoPlatesUnderAUniformSkyGiveRhoTimesSky) {
  for (Method method : {Method::kBilinear, Method::kConstant}) {
    const Scene scene = importScene((kScenes / "two_plates.gltf").string());
    const PatchMesh mesh = tessellate(scene);
    RadiosityOptions o;
    o.method = method;
    o.sky = {1, 1, 1};
    const Solution s = solveRadiosity(scene, mesh, o);
    int checked = 0;
    for (size_t v = 0; v < mesh.positions.size(); ++v) {
      if (scene.materials[mesh.vertexMaterial[v]].emission.x > 0 || method != Method::kBilinear) continue;
      EXPECT_NEAR(s.vertexRadiance[v].x, 0.5, 1e-9) << v;
      ++checked;
    }
    for (size_t p = 0; p < mesh.patches.size(); ++p) {
      if (scene.materials[mesh.patches[p].material].emission.x > 0 || method != Method::kConstant) continue;
      EXPECT_NEAR(s.patchRadiance[p].x, 0.5, 1e-6) << p;
      ++checked;
    }
    EXPECT_EQ(checked, method == Method::kBilinear ? 25 : 16);  // the 4×4 receiver grid
  }
}

TEST(Sky, AClosedBoxSeesNoSky) {
  const Scene scene = importScene((kScenes / "furnace_cube.gltf").string());
  TessellateOptions t;
  t.subdivide = 2;
  const PatchMesh mesh = tessellate(scene, t);
  RadiosityOptions o;
  o.sky = {5, 5, 5};
  const Solution s = solveRadiosity(scene, mesh, o);
  for (const Vec3& L : s.vertexRadiance) EXPECT_NEAR(L.x, 2.0, 1e-6);
}

// A white (ρ = 1) open box under a uniform sky of radiance 1: every ray from any point ends at the
// sky or at a surface of radiance 1, so L = 1 everywhere. That holds only where the sky fraction
// and the transport agree on what covers each point, the other wall at a crease included. The box
// is turned off the axes, so that a crease vertex lies in the other wall's plane only to rounding,
// as in any exported file (unturned, the test passed with the bilinear sky pass still wrong: up to
// 3.46). Double-sided, the constant method's sky probes once ended on the far wall's twin and were
// blocked by rounding (1.9% too bright).
TEST(Sky, AWhiteOpenBoxIsUniformUnderASky) {
  struct Case {
    Method method;
    TransportMode transport;
    bool doubleSided;
  };
  for (const Case& c : {Case{Method::kBilinear, TransportMode::kExact, false}, Case{Method::kBilinear, TransportMode::kHierarchical, false},
                        Case{Method::kBilinear, TransportMode::kHierarchical, true}, Case{Method::kConstant, TransportMode::kExact, true},
                        Case{Method::kConstant, TransportMode::kHierarchical, false}, Case{Method::kConstant, TransportMode::kHierarchical, true}}) {
    Scene scene;
    scene.materials = {material("white", 1.0, 0, c.doubleSided)};
    Primitive box = boxPrimitive({0, 0, 0}, {1, 1, 1}, true, 0);
    box.triangles.erase(box.triangles.begin() + 2, box.triangles.begin() + 4);  // no top
    const Vec3 axis = normalize(Vec3{1, 2, 3});
    const double cosine = std::cos(0.3), sine = std::sin(0.3);
    auto turn = [&](const Vec3& x) { return x * cosine + cross(axis, x) * sine + axis * (dot(axis, x) * (1 - cosine)); };
    for (Vec3& x : box.positions) x = turn(x) + Vec3{0.1, 0.2, 0.3};
    for (Vec3& n : box.normals) n = turn(n);
    scene.primitives.push_back(box);
    TessellateOptions t;
    t.subdivide = c.method == Method::kConstant ? 2 : 4;
    const PatchMesh mesh = tessellate(scene, t);
    RadiosityOptions o;
    o.method = c.method;
    o.transport = c.transport;
    o.sky = {1, 1, 1};
    const Solution solution = solveRadiosity(scene, mesh, o);
    double worst = 0;
    for (const Vec3& L : c.method == Method::kBilinear ? solution.vertexRadiance : solution.patchRadiance) worst = std::max(worst, std::abs(L.x - 1));
    EXPECT_LT(worst, 1e-5) << (c.method == Method::kConstant ? "constant, " : "bilinear, ")
                           << (c.transport == TransportMode::kExact ? "exact" : "hierarchical")
                           << (c.doubleSided ? ", double-sided" : "");
  }
}

}  // namespace

namespace {

// A white block standing on a white floor under a uniform sky of radiance 1, one-sided: every ray
// from a point that sees anything ends at the sky or at a surface of radiance 1, so L = 1. That
// holds only where the sky fraction and the transport's rows agree on what covers each receiver,
// partly hidden patches and the floor patch under the block's foot included: for the exact
// transport to rounding (3e-7: its sky pass takes what K's entries sum to), and for the
// hierarchical one (2.4e-7: its sky is what its rows leave open; 3.8e-5 while it was a walk of its
// own, to its own accuracy). The
// sky once took its cover from each polygon's own limit and a plain mean of the corners'
// visibility, and the block's sides along the floor gathered about 1.5 (the lower half of their
// hemisphere was sky and floor at once). The block stands inside one floor patch, so no floor
// vertex is under it (such a vertex is black, and the floor's bilinear field around it too).
TEST(Sky, AWhiteBlockOnAWhiteFloorIsUniformUnderASky) {
  Scene scene;
  scene.materials = {material("white", 1.0, 0)};
  Primitive floor;
  floor.material = 0;
  floor.hasNormals = true;
  floor.positions = {{-0.5, 0, -0.5}, {-0.5, 0, 1.5}, {1.5, 0, 1.5}, {1.5, 0, -0.5}};
  floor.normals.assign(4, Vec3{0, 1, 0});
  floor.triangles = {{0, 1, 2}, {0, 2, 3}};
  scene.primitives.push_back(floor);
  scene.primitives.push_back(boxPrimitive({0.6, 0, 0.6}, {0.9, 0.3, 0.9}, false, 0));
  TessellateOptions t;
  t.subdivide = 2;  // floor patches of 1 × 1: the block's foot lies inside one
  const PatchMesh mesh = tessellate(scene, t);
  for (TransportMode transport : {TransportMode::kExact, TransportMode::kHierarchical}) {
    RadiosityOptions o;
    o.transport = transport;
    o.sky = {1, 1, 1};
    const Solution s = solveRadiosity(scene, mesh, o);
    double worst = 0;
    int checked = 0;
    for (size_t v = 0; v < mesh.positions.size(); ++v) {
      if (mesh.normals[v].y < -0.5) continue;  // the block's bottom, pressed on the floor (a contact)
      worst = std::max(worst, std::abs(s.vertexRadiance[v].x - 1));
      ++checked;
    }
    EXPECT_LT(worst, 1e-5) << (transport == TransportMode::kExact ? "exact" : "hierarchical") << ": " << worst;
    // The floor's 3 × 3 vertices and those of its cut along the block's foot, the block's other five faces.
    EXPECT_GE(checked, 9 + 5 * 9);
  }
}

TEST(DoubleSided, AnOutwardFacingBoxIsAFurnaceInside) {
  // A closed box whose faces point outward, with a double-sided emitting material (ρ 0.5, L⁰ 1):
  // inside, the back sides form a furnace (L = 2 everywhere); outside, the fronts see nothing
  // (L = L⁰ = 1). Without doubleSided the inside would not be lit at all.
  Scene scene;
  scene.materials = {material("glow", 0.5, 1, true)};
  scene.primitives.push_back(boxPrimitive({0, 0, 0}, {1, 1, 1}, false, 0));
  TessellateOptions t;
  t.subdivide = 2;
  const PatchMesh mesh = tessellate(scene, t);
  for (TransportMode transport : {TransportMode::kExact, TransportMode::kHierarchical}) {
    RadiosityOptions o;
    o.transport = transport;
    const Solution s = solveRadiosity(scene, mesh, o);
    int inside = 0, outside = 0;
    for (size_t v = 0; v < mesh.positions.size(); ++v) {
      const Vec3 centre{0.5, 0.5, 0.5};
      const bool facesIn = dot(mesh.normals[v], centre - mesh.positions[v]) > 0;
      EXPECT_NEAR(s.vertexRadiance[v].x, facesIn ? 2.0 : 1.0, 1e-6);
      (facesIn ? inside : outside)++;
    }
    EXPECT_EQ(inside, 6 * 9);
    EXPECT_EQ(outside, 6 * 9);
  }
}

}  // namespace

namespace {

// A closed Catmull-Clark cage (a cube seen from inside → a near-sphere) with ρ 0.5 and L⁰ 1:
// the furnace identity L = 2 must hold at every vertex of the tessellated limit surface.
TEST(SubdivisionSurface, CatmullClarkFurnaceIsTwoEverywhere) {
  for (SubdivisionScheme scheme : {SubdivisionScheme::kCatmullClark, SubdivisionScheme::kLoop}) {
    Scene scene;
    scene.materials = {material("furnace", 0.5, 1)};
    scene.primitives.push_back(boxPrimitive({0, 0, 0}, {1, 1, 1}, true, 0));
    scene.primitives[0].subdivision = scheme;
    TessellateOptions t;
    t.subdivide = 16;  // the discretization error falls as h²: 3.5e-4 at rate 4, 5e-5 at 16
    const PatchMesh mesh = tessellate(scene, t);
    EXPECT_EQ(mesh.curvedRate, 16);
    for (TransportMode transport : {TransportMode::kExact, TransportMode::kHierarchical}) {
      RadiosityOptions o;
      o.transport = transport;
      const Solution s = solveRadiosity(scene, mesh, o);
      double worst = 0;
      for (const Vec3& L : s.vertexRadiance) worst = std::max(worst, std::abs(L.x - 2));
      EXPECT_LT(worst, 1e-4) << (scheme == SubdivisionScheme::kLoop ? "loop" : "catmull-clark")
                             << (transport == TransportMode::kHierarchical ? " hierarchical" : " exact");
    }
    // The limit surface is closed: each vertex appears once (no crack along cage edges).
    std::set<std::tuple<double, double, double>> seen;
    for (const Vec3& p : mesh.positions) EXPECT_TRUE(seen.insert({p.x, p.y, p.z}).second);
  }
}

}  // namespace

namespace {

TEST(Cutout, TexturedAlphaMaskLetsLightThroughItsClearHalf) {
  // A card at y = 1 whose texture is opaque on its left half (u < ½) and clear on its right, under
  // a 10 cd point light at (0, 2, 0), over a small plate (ρ 0.5) at y = 0. The plate's left
  // corners look at the light through the opaque half (dark), its right corners through the clear
  // half: ρ I cosθ / (π r²).
  Scene scene;
  scene.materials = {material("plate", 0.5, 0), material("card", 0, 0)};
  scene.materials[1].alphaMask = true;
  scene.materials[1].baseColorTexture.texture = 0;
  Texture t;
  t.width = 2;
  t.height = 1;
  t.rgb = {1, 1, 1, 1, 1, 1};
  t.alpha = {1, 0};
  scene.textures.push_back(t);
  Primitive plate;
  plate.material = 0;
  plate.positions = {{-0.1, 0, 0.05}, {0.1, 0, 0.05}, {0.1, 0, -0.05}, {-0.1, 0, -0.05}};
  plate.normals.assign(4, Vec3{0, 1, 0});
  plate.hasNormals = true;
  plate.triangles = {{0, 1, 2}, {0, 2, 3}};
  Primitive card;
  card.material = 1;
  card.primitive = 1;
  card.positions = {{-0.1, 1, -0.1}, {0.1, 1, -0.1}, {0.1, 1, 0.1}, {-0.1, 1, 0.1}};
  card.normals.assign(4, Vec3{0, -1, 0});
  card.hasNormals = true;
  card.triangles = {{0, 1, 2}, {0, 2, 3}};
  card.texcoords = {{{0, 0}, {1, 0}, {1, 1}, {0, 1}}};
  scene.primitives = {plate, card};
  PunctualLight light;
  light.position = {0, 2, 0};
  light.intensity = {10, 10, 10};
  scene.lights.push_back(light);
  const PatchMesh mesh = tessellate(scene);
  ASSERT_EQ(mesh.masks.size(), 1u);
  const Solution s = solveRadiosity(scene, mesh);
  int dark = 0, lit = 0;
  for (size_t v = 0; v < mesh.positions.size(); ++v) {
    const Vec3& p = mesh.positions[v];
    if (p.y != 0) continue;
    const double r2 = dot(p - light.position, p - light.position);
    const double expected = p.x < 0 ? 0.0 : 0.5 * 10 * (2 / std::sqrt(r2)) / (3.14159265358979323846 * r2);
    EXPECT_NEAR(s.vertexRadiance[v].x, expected, 1e-12) << p.x << " " << p.z;
    (p.x < 0 ? dark : lit)++;
  }
  EXPECT_EQ(dark, 2);
  EXPECT_EQ(lit, 2);
}

}  // namespace

namespace {

// One planar quad, corners counter-clockwise seen from its front.
Primitive quadPrimitive(const std::array<Vec3, 4>& c, int material) {
  Primitive p;
  p.material = material;
  p.hasNormals = true;
  const Vec3 n = normalize(cross(c[1] - c[0], c[2] - c[0]));
  for (const Vec3& x : c) {
    p.positions.push_back(x);
    p.normals.push_back(n);
  }
  p.triangles = {{0, 1, 2}, {0, 2, 3}};
  return p;
}

// Point-to-parallel-rectangle factor for a receiver facing the rectangle at distance h, whose foot
// point has the rectangle's corner at signed offsets (a, b): the classic corner formula, odd in a
// and in b, so any foot point follows by inclusion–exclusion.
double cornerFactor(double a, double b, double h) {
  const double ra = std::sqrt(a * a + h * h), rb = std::sqrt(b * b + h * h);
  return (a / ra * std::atan(b / ra) + b / rb * std::atan(a / rb)) / (2 * kPi);
}

// A 4 × 4 floor at y = 0 (material 0, facing +y) of n × n quads, each two triangles.
Primitive floorGrid(int n) {
  Primitive floor;
  floor.material = 0;
  floor.hasNormals = true;
  for (int i = 0; i <= n; ++i)
    for (int k = 0; k <= n; ++k) {
      floor.positions.push_back({-2 + 4.0 * i / n, 0, -2 + 4.0 * k / n});
      floor.normals.push_back({0, 1, 0});
    }
  for (uint32_t i = 0; i < uint32_t(n); ++i)
    for (uint32_t k = 0; k < uint32_t(n); ++k) {
      const uint32_t a = i * (n + 1) + k, b = a + n + 1;  // a → b along x, a → a + 1 along z
      floor.triangles.push_back({a, a + 1, b + 1});
      floor.triangles.push_back({a, b + 1, b});
    }
  return floor;
}

double parallelRectangleFactor(double x, double z, double x0, double x1, double z0, double z1, double h) {
  return cornerFactor(x1 - x, z1 - z, h) - cornerFactor(x0 - x, z1 - z, h) - cornerFactor(x1 - x, z0 - z, h) +
         cornerFactor(x0 - x, z0 - z, h);
}

// Every floor vertex's (material 0) relative error against ρ L⁰ F = 0.5 F, F = factor(its
// position): the largest, the RMS, and how many vertices.
struct FloorError {
  double worst = 0, rms = 0;
  int count = 0;
};
FloorError floorError(const PatchMesh& mesh, const Solution& s, const std::function<double(const Vec3&)>& factor) {
  FloorError e;
  double squares = 0;
  for (size_t v = 0; v < mesh.positions.size(); ++v) {
    if (mesh.vertexMaterial[v] != 0) continue;
    const double f = factor(mesh.positions[v]);
    const double error = std::abs(s.vertexRadiance[v].x - 0.5 * f) / (0.5 * f);
    e.worst = std::max(e.worst, error);
    squares += error * error;
    ++e.count;
  }
  e.rms = e.count > 0 ? std::sqrt(squares / e.count) : 0;
  return e;
}

TEST(DoubleSided, AnOpenPlateBetweenTwoEmittersIsExactOnBothSides) {
  // A double-sided plate (ρ 0.5) between two black emitters of the same size, L⁰ 1 above and 3
  // below, one unit away. Each side sees only its own emitter and nothing reflects back, so
  // L = ρ L⁰ F(vertex → emitter), F the closed-form point-to-rectangle factor: the same F on both
  // sides, three times the light below. A side that saw or shadowed its twin, or gathered the
  // other side's light, would break it.
  Scene scene;
  scene.materials = {material("plate", 0.5, 0, true), material("above", 0, 1), material("below", 0, 3)};
  scene.primitives.push_back(quadPrimitive({Vec3{-1, 0, -1}, {-1, 0, 1}, {1, 0, 1}, {1, 0, -1}}, 0));   // faces +y
  scene.primitives.push_back(quadPrimitive({Vec3{-1, 1, -1}, {1, 1, -1}, {1, 1, 1}, {-1, 1, 1}}, 1));   // faces −y
  scene.primitives.push_back(quadPrimitive({Vec3{-1, -1, -1}, {-1, -1, 1}, {1, -1, 1}, {1, -1, -1}}, 2));  // faces +y
  // Turned to an arbitrary orientation and rounded to float, as a glTF file holds it: the plate's
  // two sides are then coplanar only to rounding, not to the bit.
  const Vec3 ax = normalize(Vec3{0.3, 0.8, -0.5});
  const double angle = 0.7;
  auto rotate = [&](const Vec3& v) {  // Rodrigues
    return v * std::cos(angle) + cross(ax, v) * std::sin(angle) + ax * (dot(ax, v) * (1 - std::cos(angle)));
  };
  auto unrotate = [&](const Vec3& v) {
    return v * std::cos(angle) - cross(ax, v) * std::sin(angle) + ax * (dot(ax, v) * (1 - std::cos(angle)));
  };
  for (int p = 0; p < 3; ++p) {
    scene.primitives[p].primitive = p;
    for (Vec3& x : scene.primitives[p].positions) {
      x = rotate(x);
      x = {float(x.x), float(x.y), float(x.z)};
    }
    for (Vec3& m : scene.primitives[p].normals) m = rotate(m);
  }
  for (int n : {1, 3}) {
    TessellateOptions t;
    t.subdivide = n;
    const PatchMesh mesh = tessellate(scene, t);
    RadiosityOptions o;
    o.relativeResidual = 1e-12;
    const Solution s = solveRadiosity(scene, mesh, o);
    int top = 0, bottom = 0;
    for (size_t v = 0; v < mesh.positions.size(); ++v) {
      const Vec3 x = unrotate(mesh.positions[v]);
      if (mesh.vertexMaterial[v] != 0) continue;
      const double f = parallelRectangleFactor(x.x, x.z, -1, 1, -1, 1, 1);
      const bool up = unrotate(mesh.normals[v]).y > 0;
      EXPECT_NEAR(s.vertexRadiance[v].x, 0.5 * (up ? 1 : 3) * f, 1e-6) << "N " << n << (up ? " top " : " bottom ") << x.x << " " << x.z;
      (up ? top : bottom)++;
    }
    EXPECT_EQ(top, (n + 1) * (n + 1));
    EXPECT_EQ(bottom, (n + 1) * (n + 1));
  }
}

// A floor of n × n quads (ρ 0.5) under a ceiling that is one emitting patch (4 × 4, L⁰ 1, ρ 0,
// 2 above), with a black plate (1 × 1) halfway between them. Nothing reflects back to the floor, so
// a floor vertex's radiance is ρ L⁰ F, F the closed-form factor of the ceiling minus the plate's
// shadow on it (the plate seen from the vertex, projected to the ceiling: twice its size).
// Visibility is estimated per source patch, and five probe rays and a 4×4 grid on the whole
// ceiling put floor vertices up to 8.8% of their value off (RMS 1.9%); split into pieces by their
// factor (visibleFraction), 1.1% and 0.4% (the bound is 2% and 0.75%).
TEST(Visibility, ALargeEmitterIsSeenAroundAPlateBelowIt) {
  Scene scene;
  scene.materials = {material("floor", 0.5, 0), material("ceiling", 0, 1), material("plate", 0, 0)};
  const int n = 16;
  scene.primitives.push_back(floorGrid(n));
  scene.primitives.push_back(quadPrimitive({Vec3{-2, 2, -2}, {2, 2, -2}, {2, 2, 2}, {-2, 2, 2}}, 1));              // faces −y
  // The plate at sizes that are not round: shadow edges that fall on the pieces' dyadic points
  // (the pieces' probes once sat there) would make any estimate exact or wrong by luck.
  const double px0 = -0.43, px1 = 0.61, pz0 = -0.29, pz1 = 0.67, py = 0.9;
  scene.primitives.push_back(quadPrimitive({Vec3{px0, py, pz0}, {px0, py, pz1}, {px1, py, pz1}, {px1, py, pz0}}, 2));  // faces +y
  for (int p = 0; p < 3; ++p) scene.primitives[p].primitive = p;
  const PatchMesh mesh = tessellate(scene, TessellateOptions{});
  for (TransportMode transport : {TransportMode::kExact, TransportMode::kHierarchical}) {
    RadiosityOptions o;
    o.transport = transport;
    const Solution s = solveRadiosity(scene, mesh, o);
    const FloorError e = floorError(mesh, s, [&](const Vec3& x) {
      // The plate's shadow on the ceiling, seen from x, clipped to the ceiling.
      const double scale = 2 / py;  // from the plate to the ceiling, seen from x
      const double x0 = std::max(-2.0, x.x + scale * (px0 - x.x)), x1 = std::min(2.0, x.x + scale * (px1 - x.x));
      const double z0 = std::max(-2.0, x.z + scale * (pz0 - x.z)), z1 = std::min(2.0, x.z + scale * (pz1 - x.z));
      double f = parallelRectangleFactor(x.x, x.z, -2, 2, -2, 2, 2);
      if (x0 < x1 && z0 < z1) f -= parallelRectangleFactor(x.x, x.z, x0, x1, z0, z1, 2);
      return f;
    });
    ASSERT_EQ(e.count, (n + 1) * (n + 1));
    const bool hierarchical = transport == TransportMode::kHierarchical;
    EXPECT_LT(e.worst, 0.04) << (hierarchical ? "hierarchical" : "exact");
    EXPECT_LT(e.rms, 0.006) << (hierarchical ? "hierarchical" : "exact");
  }
}

// Solves the scene with each transport, the exact one (the tests' reference) and the hierarchical
// one, and hands each solution to check with the transport's name.
template <typename Check>
void withEachTransport(const Scene& scene, const PatchMesh& mesh, Check check) {
  for (TransportMode transport : {TransportMode::kExact, TransportMode::kHierarchical}) {
    RadiosityOptions o;
    o.transport = transport;
    check(solveRadiosity(scene, mesh, o), transport == TransportMode::kHierarchical ? "hierarchical" : "exact");
  }
}

// An emitting panel (4 × 4, one patch) 2 cm above a floor of 16 × 16 quads, facing it, nothing
// between (a ceiling over a lamp hung just below it, upside down). A floor vertex's radiance is
// ρ L⁰ F, F the closed-form factor of the panel. The panel fills nearly the whole hemisphere, so
// its visibility would be judged in hundreds of pieces per vertex: since nothing can stand between
// the two (shaftClear), it is seen whole without a ray. The plate test above holds the other case,
// a blocker inside the hull; with shaftClear always saying clear it fails.
TEST(Visibility, AnEmitterJustAboveAFloorIsSeenWholeWithoutRays) {
  Scene scene;
  scene.materials = {material("floor", 0.5, 0), material("panel", 0, 1)};
  const int n = 16;
  scene.primitives.push_back(floorGrid(n));
  const double h = 0.02;
  scene.primitives.push_back(quadPrimitive({Vec3{-2, h, -2}, {2, h, -2}, {2, h, 2}, {-2, h, 2}}, 1));  // faces −y
  for (int p = 0; p < 2; ++p) scene.primitives[p].primitive = p;
  const PatchMesh mesh = tessellate(scene, TessellateOptions{});
  withEachTransport(scene, mesh, [&](const Solution& s, std::string_view name) {
    const FloorError e = floorError(mesh, s, [&](const Vec3& x) { return parallelRectangleFactor(x.x, x.z, -2, 2, -2, 2, h); });
    ASSERT_EQ(e.count, (n + 1) * (n + 1));
    EXPECT_LT(e.worst, 1e-3) << name;
    // The hierarchical transport counts its pair rays: 118,760 with the pieces traced, 1,320 (the
    // panel's corners gathering from the floor's patches) without.
    if (name == "hierarchical") {
      EXPECT_LT(s.nearRays, size_t(5 * e.count));
    }
  });
}

// A source straddling a receiver's horizon sends only what lies above it, and that part's
// visibility decides: here an emitting wall 1 away stands from 0.9 below the floor's plane to 0.1
// above it, and a black strip halfway hides the sliver above from the small floor. Every probe of
// the wall (its centre and four inner points) lies below the horizon and sees through, so judged by
// them the sliver was seen whole, about 1e-3 of radiance on the floor; the truth is 0. (On a
// 2CylinderEngine part, vertices' sky against 262k independent rays: off by up to 0.105 that way,
// now within 0.005.) Without the strip the sliver's light arrives.
TEST(Visibility, ASourceStraddlingTheHorizonIsJudgedByItsPartAboveIt) {
  for (const bool strip : {true, false}) {
    Scene scene;
    scene.materials = {material("floor", 0.5, 0), material("wall", 0, 1), material("strip", 0, 0)};
    const double a = 0.05;
    scene.primitives.push_back(quadPrimitive({Vec3{-a, 0, -a}, {-a, 0, a}, {a, 0, a}, {a, 0, -a}}, 0));  // faces +y
    scene.primitives.push_back(quadPrimitive({Vec3{1, -0.9, -1}, {1, -0.9, 1}, {1, 0.1, 1}, {1, 0.1, -1}}, 1));  // faces −x
    if (strip) scene.primitives.push_back(quadPrimitive({Vec3{0.5, -0.01, -2}, {0.5, -0.01, 2}, {0.5, 0.08, 2}, {0.5, 0.08, -2}}, 2));
    for (size_t p = 0; p < scene.primitives.size(); ++p) scene.primitives[p].primitive = int(p);
    const PatchMesh mesh = tessellate(scene, TessellateOptions{});
    withEachTransport(scene, mesh, [&](const Solution& s, std::string_view name) {
      for (size_t v = 0; v < mesh.positions.size(); ++v) {
        if (mesh.positions[v].y != 0) continue;  // the floor's
        if (strip) EXPECT_LT(s.vertexRadiance[v].x, 1e-6) << name << " vertex " << v;
        else EXPECT_GT(s.vertexRadiance[v].x, 2e-4) << name << " vertex " << v;
      }
    });
  }
}

// A closed emitting box of reflectance ρ has L = L⁰ / (1 − ρ) everywhere. Plain Jacobi needed about
// 2,800 iterations at ρ = 0.995; the mixed iteration (Anderson's) takes the uniform mode out at
// once (3 iterations). At ρ = 1 there is no steady state, and the solve stops once its residual's
// fall could not reach the goal within maxIterations (it ran all 10,000 before: minutes at the 20k
// patches a default bake refines to). A slow solve is not cut: a closed tube 16 long of ρ = 0.999,
// lit by a small glowing box near one end, has many slow modes (light diffusing along the tube)
// that the mixing's short history cannot take out at once: it needs some 600 iterations, more than
// the early stop's window, and converges.
TEST(Solver, ASolveWithoutSteadyStateStopsEarlyAndASlowOneIsNotCut) {
  TessellateOptions twoByTwo;
  twoByTwo.subdivide = 2;
  RadiosityOptions exact;
  exact.transport = TransportMode::kExact;
  for (const double rho : {0.995, 1.0}) {
    Scene scene;
    scene.materials = {material("furnace", rho, 1)};
    scene.primitives.push_back(boxPrimitive({0, 0, 0}, {1, 1, 1}, true, 0));
    const Solution s = solveRadiosity(scene, tessellate(scene, twoByTwo), exact);
    if (rho < 1) {
      EXPECT_TRUE(s.converged) << s.iterations << " iterations, residual " << s.residual;
      for (const Vec3& L : s.vertexRadiance) EXPECT_NEAR(L.x, 200, 200 * 1e-3);
    } else {
      EXPECT_FALSE(s.converged);
      EXPECT_LT(s.iterations, 500);
    }
  }
  Scene tube;
  tube.materials = {material("tube", 0.999, 0), material("glow", 0.999, 1)};
  for (int k = 0; k < 16; ++k) {  // unit boxes in a row, their faces between them left out
    Primitive box = boxPrimitive({0, 0, double(k)}, {1, 1, double(k + 1)}, true, 0);
    if (k > 0) box.triangles.erase(box.triangles.begin(), box.triangles.begin() + 2);    // lo.z face
    if (k < 15) box.triangles.erase(box.triangles.begin() + (k > 0 ? 0 : 2), box.triangles.begin() + (k > 0 ? 2 : 4));  // hi.z
    tube.primitives.push_back(box);
  }
  tube.primitives.push_back(boxPrimitive({0.4, 0.4, 0.4}, {0.6, 0.6, 0.6}, false, 1));
  const Solution s = solveRadiosity(tube, tessellate(tube, twoByTwo), exact);
  EXPECT_TRUE(s.converged) << s.iterations << " iterations, residual " << s.residual;
  EXPECT_GT(s.iterations, 100) << "the early stop's window (kRateWindow) is not exercised";
}

// Adaptive refinement keeps a furnace exact: cells split to different depths on a box made the way
// Blender exports a cube (own vertices per face, N = 3), with 2:1 balance across its edges and fans
// of triangles beside finer cells, is still closed (every unknown enclosed) and L = 2 everywhere.
TEST(Refinement, AFurnaceStaysExactWithRefinedCellsAndFans) {
  Scene scene;
  scene.materials = {material("furnace", 0.5, 1)};
  scene.primitives.push_back(boxPrimitive({0.1, 0.2, 0.3}, {1.3, 1.1, 1.7}, true, 0));
  TessellateOptions t;
  t.subdivide = 3;
  t.split = {{0, 0, 0, 0, 0}, {0, 0, 1, 1, 1}, {0, 0, 2, 3, 3}, {0, 3, 0, 1, 1}, {0, 5, 0, 2, 0}, {0, 5, 1, 5, 1}};
  const PatchMesh mesh = tessellate(scene, t);
  size_t triangles = 0;
  for (const Patch& p : mesh.patches) triangles += p.v[2] == p.v[3];
  EXPECT_GT(triangles, 20u);  // fans were made
  EXPECT_GT(mesh.split.size(), t.split.size());  // and balance split more
  for (TransportMode transport : {TransportMode::kExact, TransportMode::kHierarchical}) {
    RadiosityOptions o;
    o.transport = transport;
    o.relativeResidual = 1e-10;
    const Solution s = solveRadiosity(scene, mesh, o);
    EXPECT_EQ(s.enclosedUnknowns, mesh.positions.size());
    double worst = 0;
    for (const Vec3& L : s.vertexRadiance) worst = std::max(worst, std::abs(L.x - 2));
    EXPECT_LT(worst, 1e-5) << (transport == TransportMode::kExact ? "exact" : "hierarchical");
  }
}

// Refinement by the direct light against a closed form: a 4 × 4 floor (one quad, ρ 0.5) lit by a
// point light 2 above it, with a black plate between casting a sharp shadow; the floor sees nothing
// but the black plate, so its radiance is exactly ρ I cosθ / (π r²) where the light is in view and
// 0 in the shadow. The bilinear field, sampled on a 101 × 101 grid that is nobody's vertices, is
// compared with it: refined from 2 × 2, it is several times closer to the answer than a uniform
// split with more patches, which smears the shadow's edge over a patch.
TEST(Refinement, APointLightsShadowIsResolvedWithFewerPatchesThanAUniformSplit) {
  Scene scene;
  scene.materials = {material("floor", 0.5, 0), material("plate", 0, 0)};
  scene.primitives.push_back(quadPrimitive({Vec3{-2, 0, -2}, {-2, 0, 2}, {2, 0, 2}, {2, 0, -2}}, 0));  // faces +y
  const double px0 = -0.43, px1 = 0.61, pz0 = -0.29, pz1 = 0.67, py = 0.9;
  scene.primitives.push_back(quadPrimitive({Vec3{px0, py, pz0}, {px0, py, pz1}, {px1, py, pz1}, {px1, py, pz0}}, 1));
  for (int p = 0; p < 2; ++p) scene.primitives[p].primitive = p;
  PunctualLight light;
  light.position = {0.13, 2, 0.07};
  light.intensity = {4, 4, 4};
  scene.lights.push_back(light);
  auto fieldError = [&](const PatchMesh& mesh, size_t& floorPatches) {
    const Solution s = solveRadiosity(scene, mesh, RadiosityOptions{});
    floorPatches = 0;
    for (const Patch& p : mesh.patches) floorPatches += p.material == 0;
    double squares = 0, sum = 0;
    int count = 0;
    for (int i = 0; i < 101; ++i)
      for (int k = 0; k < 101; ++k) {
        const Vec3 x{-2 + 4 * (i + 0.5) / 101, 0, -2 + 4 * (k + 0.5) / 101};
        const Vec3 d = light.position - x;
        // Where the segment to the light crosses the plate's height.
        const double t = py / d.y, cx = x.x + t * d.x, cz = x.z + t * d.z;
        const bool shadowed = cx > px0 && cx < px1 && cz > pz0 && cz < pz1;
        const double r2 = dot(d, d), truth = shadowed ? 0 : 0.5 * 4 * (d.y / std::sqrt(r2)) / (kPi * r2);
        const double e = evaluateRadiance(s, mesh, x, {0, 1, 0}).x - truth;
        squares += e * e;
        sum += truth;
        ++count;
      }
    return std::sqrt(squares / count) / (sum / count);
  };
  TessellateOptions uniform;
  uniform.subdivide = 64;
  size_t uniformPatches = 0;
  const double uniformError = fieldError(tessellate(scene, uniform), uniformPatches);
  TessellateOptions t;
  t.subdivide = 2;
  PatchMesh mesh = tessellate(scene, t);
  const Refinement r = refineMesh(scene, t, mesh, 0.01, 2000);
  size_t refinedPatches = 0;
  const double refinedError = fieldError(mesh, refinedPatches);
  std::printf("uniform 64x64: %zu floor patches, RMS %.4f; refined: %zu floor patches, RMS %.4f, %d rounds\n", uniformPatches,
              uniformError, refinedPatches, refinedError, r.rounds);
  EXPECT_GT(r.rounds, 3);
  EXPECT_LT(refinedPatches, uniformPatches);
  EXPECT_LT(refinedError, uniformError / 4);
}

// A box standing on a floor, the floor along one side of its footprint in the box's own shadow:
// no direct light on either side of that edge (under the box, in its shadow), so only the near
// hemisphere's share (the indirect light's proxy) can ask for patches there. The floor is cut along
// the footprint; every floor patch beside that edge (a corner on it, outside the box) is refined
// across it, where the light changes, to 1/8 of a start cell (0.125 of a 4 × 4 floor at
// --subdivide 4) or finer (along the edge the light does not change, and a cut cell's strip beside
// it is one quad). The box is 2 × 3, so its lit foot and its shadow's side lines, whose cells
// refine for the direct light, are far from that edge: with a 1 × 1 box their 2:1 balance split
// the cells beside it too, and the test passed without the near hemisphere's term.
// Without it (measured): 0.57 across.
TEST(Refinement, AContactInShadowIsRefinedByTheNearHemisphere) {
  Scene scene;
  scene.materials = {material("floor", 0.5, 0), material("box", 0.5, 0)};
  scene.primitives.push_back(quadPrimitive({Vec3{-2, 0, -2}, {-2, 0, 2}, {2, 0, 2}, {2, 0, -2}}, 0));  // faces +y
  // Its shadowed side at x = −0.43: not on any cell's edge at any level.
  scene.primitives.push_back(boxPrimitive({-0.43, 0, -1.5}, {1.57, 1, 1.5}, false, 1));
  for (int p = 0; p < 2; ++p) scene.primitives[p].primitive = p;
  PunctualLight light;
  light.position = {3, 3, 0};
  light.intensity = {10, 10, 10};
  scene.lights.push_back(light);
  TessellateOptions t;
  t.subdivide = 4;
  PatchMesh mesh = tessellate(scene, t);
  const Refinement r = refineMesh(scene, t, mesh, 0.02, 3000);
  EXPECT_GT(r.rounds, 2);
  int beside = 0;
  for (const Patch& p : mesh.patches) {
    if (p.material != 0) continue;
    bool onEdge = false;
    double lo = 1e9, hi = -1e9;
    for (uint32_t v : p.v) {
      const Vec3& x = mesh.positions[v];
      onEdge |= std::abs(x.x + 0.43) < 1e-9 && std::abs(x.z) < 0.3;
      lo = std::min(lo, x.x);
      hi = std::max(hi, x.x);
    }
    if (!onEdge || hi > -0.43 + 1e-9) continue;
    ++beside;
    EXPECT_LE(hi - lo, 0.125 + 1e-9) << "a floor patch beside the footprint's shadowed edge, " << hi - lo << " across it";
  }
  EXPECT_GT(beside, 0);
}

// A 1 × 1 × 1 box standing on a 4 × 4 floor of reflectance rho (the floor one quad, or nine quads
// split along the box's footprint), the footprint on no edge of the floor's dyadic cells.
constexpr double kBoxX0 = -0.43, kBoxX1 = 0.57, kBoxZ0 = -0.47, kBoxZ1 = 0.53;
Scene boxOnFloor(double rho, bool split, bool doubleSided) {
  Scene scene;
  scene.materials = {material("floor", rho, 0), material("box", rho, 0, doubleSided)};
  const double xs[4] = {-2, kBoxX0, kBoxX1, 2}, zs[4] = {-2, kBoxZ0, kBoxZ1, 2};
  if (split) {
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        scene.primitives.push_back(quadPrimitive({Vec3{xs[i], 0, zs[j]}, {xs[i], 0, zs[j + 1]}, {xs[i + 1], 0, zs[j + 1]}, {xs[i + 1], 0, zs[j]}}, 0));
  } else {
    scene.primitives.push_back(quadPrimitive({Vec3{-2, 0, -2}, {-2, 0, 2}, {2, 0, 2}, {2, 0, -2}}, 0));
  }
  scene.primitives.push_back(boxPrimitive({kBoxX0, 0, kBoxZ0}, {kBoxX1, 1, kBoxZ1}, false, 1));
  for (size_t p = 0; p < scene.primitives.size(); ++p) scene.primitives[p].primitive = int(p);
  return scene;
}

// The exact transport's bake of `scene` under a uniform sky of 1.
Baked exactUnderSky(const Scene& scene, const TessellateOptions& t) {
  Baked b;
  b.mesh = tessellate(scene, t);
  RadiosityOptions o;
  o.transport = TransportMode::kExact;
  o.sky = {1, 1, 1};
  b.solution = solveRadiosity(scene, b.mesh, o);
  return b;
}

// Under a sky alone (no emitter, no lamp: an ambient-occlusion bake) refinement measures the sky's
// light: a box (one- and double-sided) on a one-quad floor. The floor 2, 5 and 10 cm beside the box against the same floor
// split along the footprint at cells of 0.125 (exact transport). Measured: within 1.1%; before,
// refinement saw no light, made no round and left the floor one quad (0.80 everywhere, 17% off).
TEST(Refinement, SkyLightIsMeasuredToo) {
  double oneSidedWorst = 0;
  for (const bool doubleSided : {false, true}) {
    const double x0 = kBoxX0, x1 = kBoxX1, z0 = kBoxZ0;
    auto scene = [&](bool split) { return boxOnFloor(0.8, split, doubleSided); };
    RadiosityOptions o;
    o.sky = {1, 1, 1};
    const Scene coarse = scene(false), fine = scene(true);
    TessellateOptions t;
    PatchMesh mesh = tessellate(coarse, t);
    const Refinement r = refineMesh(coarse, t, mesh, 0.02, 3000, o.sky);
    EXPECT_GT(r.rounds, 2);
    // The inside of the double-sided box is a dark room, black in the solve: not measured (its
    // walls' rays near the seam with the floor saw light, and the worst error left was 0.61, not 0.30).
    if (doubleSided) {
      EXPECT_LT(r.worst, oneSidedWorst + 0.05);
    }
    oneSidedWorst = r.worst;
    const Solution refined = solveRadiosity(coarse, mesh, o);
    TessellateOptions u;
    u.maxEdgeLength = 0.125;
    const PatchMesh reference = tessellate(fine, u);
    o.transport = TransportMode::kExact;
    const Solution exact = solveRadiosity(fine, reference, o);
    for (const double gap : {0.02, 0.05, 0.1})
      for (const Vec3& x : {Vec3{x0 - gap, 0, 0.1}, Vec3{x1 + gap, 0, 0.1}, Vec3{0.1, 0, z0 - gap}}) {
        const Vec3 a = evaluateRadiance(refined, mesh, x, {0, 1, 0});
        const Vec3 b = evaluateRadiance(exact, reference, x, {0, 1, 0});
        EXPECT_NEAR(a.x / b.x, 1, 0.03) << "floor at (" << x.x << ", " << x.z << "): " << a.x << " against " << b.x;
      }
  }
}

// A unit room (ρ 0.5, its faces with their own vertices as Blender exports a cube) lit by a
// double-sided lamp (0.2 × 0.2, L⁰ 1) 2 cm under its ceiling.
Scene lampRoom() {
  Scene scene;
  scene.materials = {material("wall", 0.5, 0), material("lamp", 0.5, 1, true)};
  scene.primitives.push_back(boxPrimitive({0, 0, 0}, {1, 1, 1}, true, 0));
  scene.primitives.push_back(quadPrimitive({Vec3{0.4, 0.98, 0.4}, {0.4, 0.98, 0.6}, {0.6, 0.98, 0.6}, {0.6, 0.98, 0.4}}, 1));
  scene.primitives[0].primitive = 0;
  scene.primitives[1].primitive = 1;
  return scene;
}

// `scene` from one patch a face refined to 0.02 within `budget` patches (into `mesh`), solved with
// the hierarchical transport: what a default bake does.
Solution refinedBake(const Scene& scene, size_t budget, PatchMesh& mesh) {
  TessellateOptions t;
  mesh = tessellate(scene, t);
  refineMesh(scene, t, mesh, 0.02, budget);
  RadiosityOptions o;
  o.transport = TransportMode::kHierarchical;
  return solveRadiosity(scene, mesh, o);
}

// The lamp room at one patch a face: the lamp's back sees only the ceiling 2 cm above it,
// and the light goes back and forth between them. Between two parallel plates of ρ 0.5 with
// nothing lost at the rim, the back (emitting 1) would be 1 / (1 − ρ²) = 4/3 and the ceiling
// 2/3 (upper bounds, but for the walls' faint light). At the centre of a 0.2-m lamp 2 cm under the
// ceiling each sees the other with a view factor of about 0.96 (a disc of radius 0.1 at 0.02:
// 1/(1 + 0.04)); iterating L_c = 0.5 · 0.96 · L_b, L_b = 1 + 0.5 · 0.96 · L_c from L_b = 1 gives
// 1.30 and 0.62 there (an estimate: points nearer the rim see less). Refining by the direct light alone
// never splits the back (it has no direct light), and left it 1.07 and the ceiling 0.52; the
// second phase gathers the first bounce there. Measured: 1.295 and 0.620 (a uniform 2-cm bake:
// 1.297 and 0.624).
TEST(Refinement, TheFirstBounceRefinesALampsBackUnderTheCeiling) {
  const Scene scene = lampRoom();
  PatchMesh mesh;
  const Solution s = refinedBake(scene, 2000, mesh);
  const double back = evaluateRadiance(s, mesh, {0.5, 0.98, 0.5}, {0, 1, 0}).x;
  const double ceiling = evaluateRadiance(s, mesh, {0.5, 1, 0.5}, {0, -1, 0}).x;
  EXPECT_GT(back, 1.28);
  EXPECT_LT(back, 4.0 / 3);
  EXPECT_GT(ceiling, 0.6);
  EXPECT_LT(ceiling, 2.0 / 3 + 0.01);  // (the walls add about 1%)
}

// Radiance is never negative. The far links' fields are first-order expansions; at floor vertices
// deep under the Cornell box's blocks, which refinement gives patches of their own, they summed to
// -3e-5 (at 3,000 patches; -5e-4, 0.8% of the mean, at 20k) where the exact rows give 0.
TEST(Hierarchical, ARefinedCornellBoxHasNoNegativeRadiance) {
  PatchMesh mesh;
  const Solution s = refinedBake(importScene((kScenes / "cornell_box.gltf").string()), 3000, mesh);
  int negative = 0;
  for (const Vec3& L : s.vertexRadiance) negative += L.x < 0 || L.y < 0 || L.z < 0;
  EXPECT_EQ(negative, 0) << "of " << s.vertexRadiance.size() << " vertices";
}

// The lamp room, hierarchical against exact at 12×12 patches a face: the issue's bounds, RMS ≤ 0.5%
// and largest ≤ 3% of the mean radiance. The ceiling above the lamp is 3.4 times the mean and sees the walls only through the slit between them.
// Links judged by their factor alone, a faint link made on probes from elsewhere in its group, and
// closure over the whole row each put it off (0.83% RMS and 4.4% largest until the third session
// of 2026-12-03; docs/radiosity.md, "Refinement by light").
// `scene` split n × n a face, and a solve of it with `transport` (default options otherwise).
PatchMesh uniformMesh(const Scene& scene, int n) {
  TessellateOptions t;
  t.subdivide = n;
  return tessellate(scene, t);
}
Solution solveWith(const Scene& scene, const PatchMesh& mesh, TransportMode transport) {
  RadiosityOptions o;
  o.transport = transport;
  return solveRadiosity(scene, mesh, o);
}

TEST(Hierarchical, ALampUnderTheCeilingAgreesWithExactTransport) {
  const Scene scene = lampRoom();
  const PatchMesh mesh = uniformMesh(scene, 12);
  const Solution exact = solveWith(scene, mesh, TransportMode::kExact);
  const Solution hier = solveWith(scene, mesh, TransportMode::kHierarchical);
  EXPECT_GT(hier.refinedLinks, 0u);
  expectWithinIssueBounds(exact.vertexRadiance, hier.vertexRadiance);
}

// The lamp room at 16×16 a face: the floor's mean radiance within 0.6% of the exact transport's.
// Every vertex can be within the issue's bounds while a visibility shortcut biases a whole surface
// the same way: links to partly hidden clusters around the lamp (its small refined patches and the
// ceiling's hot spot behind it) taken whole on 4 rays, or with a share of rays to patches picked by
// index, put the floor 1.3% too bright here (3.6% at 20×20) in the twenty-second session; 0.33% too
// dark since (docs/radiosity.md, "A faint, partly hidden cluster").
TEST(Hierarchical, ALampsFloorKeepsItsMeanLight) {
  const Scene scene = lampRoom();
  const PatchMesh mesh = uniformMesh(scene, 16);
  const Solution exact = solveWith(scene, mesh, TransportMode::kExact);
  const Solution hier = solveWith(scene, mesh, TransportMode::kHierarchical);
  double exactSum = 0, hierSum = 0;
  size_t floor = 0;
  for (size_t v = 0; v < mesh.positions.size(); ++v) {
    if (std::abs(mesh.positions[v].y) > 1e-9 || mesh.normals[v].y < 0.5) continue;
    exactSum += exact.vertexRadiance[v].x + exact.vertexRadiance[v].y + exact.vertexRadiance[v].z;
    hierSum += hier.vertexRadiance[v].x + hier.vertexRadiance[v].y + hier.vertexRadiance[v].z;
    ++floor;
  }
  ASSERT_EQ(floor, 17u * 17u);
  EXPECT_NEAR(hierSum / exactSum, 1, 0.006);
}

// A tube (0.2 × 0.2 × 0.6, closed at one end, double-sided as Blender exports it) lying on the
// floor of `scene`, its open end toward +z. Its inside is the back side: written nowhere, and
// deep in the tube it sees the room only through the open end.
Primitive openTube(int material) {
  Primitive tube = boxPrimitive({0.3, 0.001, 0.15}, {0.5, 0.201, 0.75}, false, material);
  tube.triangles.erase(tube.triangles.begin() + 2, tube.triangles.begin() + 4);  // no +z end
  return tube;
}

// Back sides seen little (docs/radiosity.md) gather by rays: the tube's inside in a unit room lit by
// a panel (0.2 × 0.2, 20 cm under the ceiling), hierarchical against exact: every vertex within the
// issue's bounds, and the inside against its own mean within 5% RMS and 25% at worst (measured
// 2.4% and 11%, the walk 0.45% and 2.2%; with the traced rows left empty 31% and 87%). The same
// bits for one thread and two. (With the lamp 2 cm under the ceiling the walk itself is 7% of the
// mean off exact here, traced or not: the tube's top and the floor beside it, +33%; not yet
// understood, docs/results.md.)
TEST(Hierarchical, AnOpenTubesInsideGathersByRaysAndAgreesWithExactTransport) {
  Scene scene;
  scene.materials = {material("wall", 0.5, 0), material("lamp", 0.5, 1), material("tube", 0.5, 0, true)};
  scene.primitives.push_back(boxPrimitive({0, 0, 0}, {1, 1, 1}, true, 0));
  scene.primitives.push_back(quadPrimitive({Vec3{0.4, 0.8, 0.4}, {0.6, 0.8, 0.4}, {0.6, 0.8, 0.6}, {0.4, 0.8, 0.6}}, 1));  // facing down
  scene.primitives.push_back(openTube(2));
  for (int k = 0; k < 3; ++k) scene.primitives[k].primitive = k;
  const PatchMesh mesh = uniformMesh(scene, 8);
  const Solution exact = solveWith(scene, mesh, TransportMode::kExact);
  EXPECT_EQ(exact.tracedUnknowns, 0u);
  auto run = [&](int threads) {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, threads);
    return solveWith(scene, mesh, TransportMode::kHierarchical);
  };
  const Solution hier = run(2);
  EXPECT_GT(hier.tracedUnknowns, 20u);
  expectWithinIssueBounds(exact.vertexRadiance, hier.vertexRadiance);
  // The inside itself (what the walls see through the open end), against its own mean: the
  // bound above is relative to the whole scene's, lamp included, which the dark inside hardly moves.
  std::set<uint32_t> inside;
  for (const Patch& p : mesh.patches)
    if (p.backSide && scene.primitives[p.primitive].material == 2) inside.insert(p.v.begin(), p.v.end());
  double mean = 0, squares = 0, largest = 0;
  for (uint32_t v : inside) {
    const double d = hier.vertexRadiance[v].x - exact.vertexRadiance[v].x;
    mean += exact.vertexRadiance[v].x / inside.size();
    squares += d * d / inside.size();
    largest = std::max(largest, std::abs(d));
  }
  EXPECT_LT(std::sqrt(squares) / mean, 0.05);
  EXPECT_LT(largest / mean, 0.25);
  const Solution one = run(1);
  for (size_t v = 0; v < one.vertexRadiance.size(); ++v) EXPECT_TRUE(one.vertexRadiance[v] == hier.vertexRadiance[v]) << v;
}

// The white tube alone under a uniform sky of 1: every ray from its inside ends at the sky or at a
// surface of radiance 1, so L = 1 there too. That holds only if a traced row's near kernels, its
// rays' share of the rest and its sky add up to the whole hemisphere (their rays alone, without
// that share: 18% off). Within 1e-4, as for the block on a floor (the outside is walked; measured
// 2e-5). The exact transport's own rows are 5 to 8 there: an open white cavity magnifies any
// excess of a row over its hemisphere, and the exact rows of its inside have some.
TEST(Sky, AnOpenTubesTracedInsideIsUniformUnderASky) {
  Scene scene;
  scene.materials = {material("white", 1.0, 0, true)};
  scene.primitives.push_back(openTube(0));
  TessellateOptions t;
  t.subdivide = 6;
  const PatchMesh mesh = tessellate(scene, t);
  RadiosityOptions o;
  o.transport = TransportMode::kHierarchical;
  o.sky = {1, 1, 1};
  const Solution s = solveRadiosity(scene, mesh, o);
  EXPECT_GT(s.tracedUnknowns, 20u);
  double worst = 0;
  for (const Vec3& L : s.vertexRadiance) worst = std::max(worst, std::abs(L.x - 1));
  EXPECT_LT(worst, 1e-4);
}

}  // namespace

namespace {

// Contact (docs/radiosity.md): a box standing on a floor under a uniform sky, one-sided as in the
// Cornell box and double-sided as Blender exports a cube. With cells of 0.125 the footprint's edges
// cross floor cells, and the floor vertices under the box gather nothing; the floor just outside
// must still take the light of the same floor split along the footprint (nine quads meeting at its
// edges, the same cell size), at points 2 and 5 cm from it on three sides. Measured: within 4.0%
// either way (Σ of the channels); with the vertices under the box left at zero, up to 35% too dark.
class Contact : public ::testing::TestWithParam<bool> {};
INSTANTIATE_TEST_SUITE_P(Sides, Contact, ::testing::Bool(),
                         [](const auto& info) { return info.param ? "double_sided" : "one_sided"; });

TEST_P(Contact, TheFloorBesideABoxTakesTheLightOfAFloorSplitAlongItsFootprint) {
  const double x0 = kBoxX0, x1 = kBoxX1, z0 = kBoxZ0;  // on no edge of the 0.125 cells
  auto solve = [&](bool split, double maxEdge, bool doubleSided) {
    const Scene scene = boxOnFloor(0.5, split, doubleSided);
    TessellateOptions t;
    t.subdivide = 1;
    t.maxEdgeLength = maxEdge;
    return exactUnderSky(scene, t);
  };
  const Baked coarse = solve(false, 0.125, GetParam()), reference = solve(true, 0.125, GetParam());
  EXPECT_GT(coarse.solution.contactUnknowns, 0u);
  // On the split floor the box's sides do not matter outside it: a double-sided box's outside and
  // the floor under it share edges there, and were taken for the inside of its closed back (the
  // floor beside it was 58% dark, 9% still 0.5 m away).
  if (GetParam()) {
    const Baked oneSided = solve(true, 0.125, false);
    for (const double gap : {0.02, 0.2, 0.5})
      for (const Vec3& x : {Vec3{x0 - gap, 0, 0.1}, Vec3{x1 + gap, 0, 0.1}, Vec3{0.1, 0, z0 - gap}}) {
        const Vec3 a = evaluateRadiance(reference.solution, reference.mesh, x, {0, 1, 0});
        const Vec3 r = evaluateRadiance(oneSided.solution, oneSided.mesh, x, {0, 1, 0});
        EXPECT_NEAR(a.x / r.x, 1, 1e-3) << "split floor at (" << x.x << ", " << x.z << "): " << a.x << " against " << r.x;
      }
  }
  for (const double gap : {0.02, 0.05})
    for (const double along : {-0.3, 0.0, 0.3})
      for (const Vec3& x : {Vec3{x0 - gap, 0, along}, Vec3{x1 + gap, 0, along}, Vec3{along, 0, z0 - gap}}) {
        const Vec3 a = evaluateRadiance(coarse.solution, coarse.mesh, x, {0, 1, 0});
        const Vec3 r = evaluateRadiance(reference.solution, reference.mesh, x, {0, 1, 0});
        const double off = std::abs((a.x + a.y + a.z) / (r.x + r.y + r.z) - 1);
        EXPECT_LT(off, 0.06) << "floor at (" << x.x << ", " << x.z << "): " << a.x << " against " << r.x;
      }
}

// A scene's mesh with patches no longer than `edge` (its primitives numbered in order first), and
// its bakes under a uniform sky of 1 by the exact and the hierarchical transports; the mean of a
// bake's red channel over its vertices.
PatchMesh meshWithEdges(Scene& scene, double edge) {
  for (size_t p = 0; p < scene.primitives.size(); ++p) scene.primitives[p].primitive = int(p);
  TessellateOptions t;
  t.maxEdgeLength = edge;
  return tessellate(scene, t);
}
std::pair<Solution, Solution> bothUnderSky(const Scene& scene, const PatchMesh& mesh) {
  RadiosityOptions o;
  o.sky = {1, 1, 1};
  o.transport = TransportMode::kExact;
  Solution exact = solveRadiosity(scene, mesh, o);
  o.transport = TransportMode::kHierarchical;
  return {std::move(exact), solveRadiosity(scene, mesh, o)};
}
double meanRed(const Solution& s) {
  double mean = 0;
  for (const Vec3& L : s.vertexRadiance) mean += L.x / double(s.vertexRadiance.size());
  return mean;
}

// A face pressed on another part's (parts of an assembly in contact): a block's bottom on a floor,
// turned off the axes as an assembly's parts are by their nodes, under a sky. Each bottom vertex
// lies inside a floor patch facing it in its plane; where rounding lifts that patch over the
// vertex's horizon, the kernel gives it the patch's in-plane limit, its whole hemisphere, and the
// exact transport takes it. The hierarchical transport culled the floor's clusters as lying on
// the bottom's horizon (its rays, from inside the floor, cannot see a limit): on a part of the
// 2CylinderEngine such vertices came out 110% of the mean off exact. Both transports now take the
// same pressed patches (pressedPatches).
TEST(Contact, AFacePressedOnAnotherGathersAsInTheExactTransport) {
  Scene scene;
  scene.materials = {material("floor", 0.5, 0), material("block", 0.5, 0)};
  scene.primitives.push_back(quadPrimitive({Vec3{-2, 0, -2}, {-2, 0, 2}, {2, 0, 2}, {2, 0, -2}}, 0));
  scene.primitives.push_back(boxPrimitive({-0.43, 0, -0.47}, {0.57, 1, 0.53}, false, 1));
  // Turned about (1, 2, 3) by 0.7 rad and moved off the origin, as a node's transform does.
  const Vec3 axis = normalize(Vec3{1, 2, 3}), shift{300, -40, 70};
  auto turn = [&](const Vec3& x) {
    const double c = std::cos(0.7), s = std::sin(0.7);
    return x * c + cross(axis, x) * s + axis * (dot(axis, x) * (1 - c));
  };
  for (Primitive& p : scene.primitives) {
    for (Vec3& x : p.positions) x = turn(x) + shift;
    for (Vec3& n : p.normals) n = turn(n);
  }
  const PatchMesh mesh = meshWithEdges(scene, 0.3);
  const auto [exact, hier] = bothUnderSky(scene, mesh);
  int bottom = 0, pressed = 0;
  double worst = 0;
  const double mean = meanRed(exact);
  const Vec3 down = turn({0, -1, 0});
  for (size_t v = 0; v < mesh.positions.size(); ++v) {
    if (!(dot(mesh.normals[v], down) > 0.5)) continue;  // the block's bottom
    ++bottom;
    pressed += exact.vertexRadiance[v].x < 0.45;  // took the floor's limit, not ρ × the sky below
    worst = std::max(worst, std::abs(hier.vertexRadiance[v].x - exact.vertexRadiance[v].x) / mean);
  }
  EXPECT_GE(bottom, 9);
  EXPECT_GE(pressed, 1) << "no bottom vertex takes a pressed patch in exact: the scene no longer tests it";
  EXPECT_LT(worst, 0.03) << "a pressed vertex off exact by " << worst << " of the mean";
}

// A floor under a one-sided canopy that faces the sky (the floor sees its back, which covers its
// sky and sends nothing), a double-sided plate between them casting a shadow on it: the canopy's
// clusters at the plate's silhouette are faint and partly hidden, and each floor vertex takes them
// with the share its rays see. Hierarchical against exact under a sky of 1: the floor beneath the
// canopy within the issue's bounds. Until the twenty-seventh session the share of a cluster seen
// from behind was 0 (its cosines were taken on its front) and the cluster was dropped, so the floor
// saw sky through it: 1.1% RMS and 2.8% at worst of the mean, too bright (now 0.17% and 0.57%).
TEST(Sky, AFloorSeesTheBackOfACanopyBehindAPlateAsInTheExactTransport) {
  Scene scene;
  scene.materials = {material("floor", 0.5, 0), material("canopy", 0.5, 0), material("plate", 0.5, 0, true)};
  scene.primitives.push_back(quadPrimitive({Vec3{-2, 0, -2}, {-2, 0, 2}, {2, 0, 2}, {2, 0, -2}}, 0));
  scene.primitives.push_back(quadPrimitive({Vec3{-1, 1, -1}, {-1, 1, 1}, {1, 1, 1}, {1, 1, -1}}, 1));
  scene.primitives.push_back(quadPrimitive({Vec3{-0.25, 0.5, -0.6}, {-0.25, 0.5, 0.6}, {0.25, 0.5, 0.6}, {0.25, 0.5, -0.6}}, 2));
  const PatchMesh mesh = meshWithEdges(scene, 0.1);
  const auto [exact, hier] = bothUnderSky(scene, mesh);
  double worst = 0, squares = 0;
  int under = 0;
  const double mean = meanRed(exact);
  for (size_t v = 0; v < mesh.positions.size(); ++v) {
    const Vec3& x = mesh.positions[v];
    if (!(x.y < 0.25 && std::abs(x.x) < 1 && std::abs(x.z) < 1)) continue;  // the floor under the canopy
    ++under;
    const double d = (hier.vertexRadiance[v].x - exact.vertexRadiance[v].x) / mean;
    squares += d * d;
    worst = std::max(worst, std::abs(d));
  }
  ASSERT_GT(under, 100);
  EXPECT_LT(std::sqrt(squares / under), 0.005);
  EXPECT_LT(worst, 0.03);
}

// A face hanging below a floor from a line of its vertices (the side of a part whose top is level
// with another's face, as a CAD assembly's are), its top edge lifted above the floor by less than
// rounding: nothing stands above the floor, so under a sky of 1 every floor vertex is ρ × 1, in
// both transports. The kernel takes what lies within epsilon of a vertex as touching it, and gave
// the hanging face's wedge its crease limit: the floor along the line was 0.25 (0.375 at its ends)
// instead of 0.5 (a 2CylinderEngine vertex took 0.80 of its hemisphere from piston faces hanging
// below it).
TEST(Contact, AFaceHangingBelowAFloorCoversNothingOfIt) {
  Scene scene;
  scene.materials = {material("floor", 0.5, 0), material("side", 0.5, 0)};
  scene.primitives.push_back(quadPrimitive({Vec3{-2, 0, -2}, {-2, 0, 2}, {2, 0, 2}, {2, 0, -2}}, 0));
  const double lift = 1e-9;  // below the occlusion epsilon of a 4 m scene
  scene.primitives.push_back(quadPrimitive({Vec3{0, lift, -1}, {0, -1, -1}, {0, -1, 1}, {0, lift, 1}}, 1));
  const PatchMesh mesh = meshWithEdges(scene, 0.5);
  const auto [exact, hier] = bothUnderSky(scene, mesh);
  for (const auto& [s, transport] : {std::pair{&exact, "exact"}, std::pair{&hier, "hierarchical"}}) {
    int online = 0;
    for (size_t v = 0; v < mesh.positions.size(); ++v) {
      const Vec3& x = mesh.positions[v];
      if (!(mesh.normals[v].y > 0.5)) continue;  // the floor
      online += std::abs(x.x) < 1e-6 && std::abs(x.z) <= 1;
      EXPECT_NEAR(s->vertexRadiance[v].x, 0.5, 1e-6) << "floor vertex at " << x.x << " " << x.z << ", transport " << transport;
    }
    EXPECT_GE(online, 5) << "no floor vertex on the hanging face's line: the scene no longer tests it";
  }
}

// The vertices of a primitive's patches.
std::set<uint32_t> verticesOf(const PatchMesh& mesh, int primitive) {
  std::set<uint32_t> out;
  for (const Patch& patch : mesh.patches)
    if (patch.primitive == primitive) out.insert(patch.v.begin(), patch.v.end());
  return out;
}

// A floor (primitive 0, 2 x 2 about the origin) with a plate standing through it along x = 0
// (facing -x) in two halves, as a contact cut leaves it, the lower half's top at `lowerTop`, and
// `extra` primitives (floor material); tessellated at 0.5 without cutting the contacts again.
PatchMesh plateThroughAFloor(Scene& scene, double lowerTop, const std::vector<std::array<Vec3, 4>>& extra = {}) {
  scene.materials = {material("floor", 0.5, 0), material("plate", 0.5, 0)};
  scene.primitives.push_back(quadPrimitive({Vec3{-1, 0, -1}, {-1, 0, 1}, {1, 0, 1}, {1, 0, -1}}, 0));
  for (const auto& q : extra) scene.primitives.push_back(quadPrimitive(q, 0));
  scene.primitives.push_back(quadPrimitive({Vec3{0, -1, -2}, {0, -1, 3}, {0, lowerTop, 3}, {0, lowerTop, -2}}, 1));
  scene.primitives.push_back(quadPrimitive({Vec3{0, 0, -2}, {0, 0, 3}, {0, 1, 3}, {0, 1, -2}}, 1));
  for (size_t p = 0; p < scene.primitives.size(); ++p) scene.primitives[p].primitive = int(p);
  TessellateOptions t;
  t.maxEdgeLength = 0.5;
  t.cutContacts = false;
  return tessellate(scene, t);
}

// A floor with a column of vertices on the foot of a plate standing through it (facing -x), and
// beside the floor, 3e-7 away, a coplanar piece of floor that starts 3e-8 behind the plate (a crack,
// as contact cuts and CAD parts leave them). The floor's vertices on the foot see the plate cover
// the half of their hemisphere behind it: a sky of 1/2. The corner vertex (0, 0, 1) was moved onto
// the nearest point of the other piece, 3e-8 behind the plate, and took none of it: a sky of 1.
TEST(Contact, AVertexOnAPlatesFootStaysOnItBesideACrackInItsFloor) {
  Scene scene;
  const PatchMesh mesh = plateThroughAFloor(scene, 0, {{Vec3{3e-8, 0, 1 + 3e-7}, {3e-8, 0, 2}, {1, 0, 2}, {1, 0, 1 + 3e-7}}});
  const auto [exact, hier] = bothUnderSky(scene, mesh);
  for (const auto& [s, transport] : {std::pair{&exact, "exact"}, std::pair{&hier, "hierarchical"}}) {
    bool corner = false;
    for (const uint32_t v : verticesOf(mesh, 0)) {
      const Vec3& x = mesh.positions[v];
      if (x.x != 0) continue;
      corner |= x.z == 1;
      EXPECT_NEAR(s->skyFraction[v], 0.5, 0.01) << "floor vertex at z " << x.z << ", transport " << transport;
    }
    EXPECT_TRUE(corner) << "no floor vertex at the crack: the scene no longer tests it";
  }
}

// The same foot, the plate's lower half 3e-7 below the floor (a crack in the plate, as contact cuts
// leave one between the pieces of a face a bore runs through). The floor's vertices on the foot lie
// on the upper half's edge; each was moved onto the nearest point of the lower half, 3e-7 off that
// edge, where the upper half is seen edge-on: a sky of 1 where it is 1/2 (on a 2CylinderEngine part
// a shaft's vertex where it enters a plate: 0.99 where independent rays see at most 0.48).
TEST(Contact, AVertexOnAPlatesFootStaysOnItAboveACrackInThePlate) {
  Scene scene;
  const PatchMesh mesh = plateThroughAFloor(scene, -3e-7);
  const auto [exact, hier] = bothUnderSky(scene, mesh);
  for (const auto& [s, transport] : {std::pair{&exact, "exact"}, std::pair{&hier, "hierarchical"}}) {
    size_t onFoot = 0;
    for (const uint32_t v : verticesOf(mesh, 0)) {
      const Vec3& x = mesh.positions[v];
      if (x.x != 0 || std::abs(x.z) == 1) continue;  // (the floor's corners on the foot see its end)
      ++onFoot;
      EXPECT_NEAR(s->skyFraction[v], 0.5, 0.01) << "floor vertex at z " << x.z << ", transport " << transport;
    }
    EXPECT_GT(onFoot, 0u) << "no floor vertex on the foot: the scene no longer tests it";
  }
}

// A face below a floor whose plane passes through a floor vertex, the vertex inside it by a few
// millionths, so that only a sliver of it (its corner, 3e-6 away, 2.9e-6 up) rises above the floor,
// within the lift its rays start from (10 epsilon, 5.7e-6 here): as CAD parts meet with a corner a
// few float steps off. Nothing stands above the floor, so its sky is 1. The kernel gave the face its
// in-plane limit at the vertex, 0.5 (1 - n.m) = 0.36 of its hemisphere, in both transports (on the
// 2CylinderEngine 0.52-0.63 where independent rays see a sky of 1: bench/skycheck).
TEST(Contact, AFaceRisingAboveAFloorOnlyWithinTheRaysLiftCoversNothingOfIt) {
  Scene scene;
  scene.materials = {material("floor", 0.5, 0), material("face", 0.5, 0)};
  scene.primitives.push_back(quadPrimitive({Vec3{-2, 0, -2}, {-2, 0, 2}, {2, 0, 2}, {2, 0, -2}}, 0));
  // The face's plane holds the floor vertex at the origin; e1 along it, e2 down its slope.
  const Vec3 e1{1, 0, 0}, e2 = normalize(Vec3{0, -1, 0.3});
  const Vec3 a = e2 * -3e-6, b = e1 * -1 + e2, c = e1 + e2;
  Primitive face = quadPrimitive({a, b, c, c}, 1);
  face.triangles = {{0, 1, 2}};
  scene.primitives.push_back(face);
  const PatchMesh mesh = meshWithEdges(scene, 0.5);
  const auto [exact, hier] = bothUnderSky(scene, mesh);
  for (const auto& [s, transport] : {std::pair{&exact, "exact"}, std::pair{&hier, "hierarchical"}}) {
    bool atOrigin = false;
    for (const uint32_t v : verticesOf(mesh, 0)) {
      atOrigin |= length(mesh.positions[v]) == 0;
      EXPECT_NEAR(s->skyFraction[v], 1, 1e-6) << "floor vertex at " << mesh.positions[v].x << " " << mesh.positions[v].z << ", transport " << transport;
    }
    EXPECT_TRUE(atOrigin) << "no floor vertex in the face's plane: the scene no longer tests it";
  }
}

// A smooth-shaded surface running through a plate (a bore through a wall in a CAD assembly): its
// vertices along the plate's plane are in the plate, which covers the half of their hemisphere
// beyond it, seen from the side in front of it: a sky of exactly 1/2 (the crease limit of a plane
// through the point at right angles to its own). The vertex's own patches lie on both sides of the
// plate and in two planes (a ridge); it took its approach from their centres, along the plate,
// and saw it edge-on: a sky of 1, in both transports (on a 2CylinderEngine part 0.92 where the side
// in front sees about 0.42: bench/skycheck).
TEST(Contact, ASmoothSurfaceRunningThroughAPlateSeesTheSkyInFrontOfIt) {
  Scene scene;
  scene.materials = {material("plate", 0.5, 0), material("ridge", 0.5, 0)};
  scene.primitives.push_back(quadPrimitive({Vec3{0, -0.5, -1}, {0, -0.5, 1}, {0, 1.5, 1}, {0, 1.5, -1}}, 0));  // facing -x
  Primitive ridge;
  ridge.material = 1;
  ridge.hasNormals = true;
  ridge.positions = {{-1, 0, -0.5}, {1, 0, -0.5}, {1, 0.1, 0}, {-1, 0.1, 0}, {-1, 0, 0.5}, {1, 0, 0.5}};
  const Vec3 south = normalize(Vec3{0, 1, -0.2}), north = normalize(Vec3{0, 1, 0.2});
  ridge.normals = {south, south, {0, 1, 0}, {0, 1, 0}, north, north};
  ridge.triangles = {{0, 3, 2}, {0, 2, 1}, {3, 4, 5}, {3, 5, 2}};
  scene.primitives.push_back(ridge);
  const PatchMesh mesh = meshWithEdges(scene, 0.25);
  const auto [exact, hier] = bothUnderSky(scene, mesh);
  for (const auto& [s, transport] : {std::pair{&exact, "exact"}, std::pair{&hier, "hierarchical"}}) {
    ASSERT_EQ(s->skyFraction.size(), mesh.positions.size());
    std::set<uint32_t> inPlate, onRidge;
    for (const uint32_t v : verticesOf(mesh, 1))
      if (std::abs(mesh.positions[v].x) < 1e-9) {
        inPlate.insert(v);
        if (mesh.positions[v].y > 0.1 - 1e-9) onRidge.insert(v);
      }
    EXPECT_GE(inPlate.size(), 5u) << "no vertex of the ridge in the plate's plane: the scene no longer tests it";
    EXPECT_EQ(onRidge.size(), 1u);
    for (const uint32_t v : inPlate)
      EXPECT_NEAR(s->skyFraction[v], 0.5, 0.01) << "vertex at y " << mesh.positions[v].y << ", z " << mesh.positions[v].z << ", transport " << transport;
  }
}

// A floor vertex within rounding of the foot of a box's wall (Blender writes single precision: a
// cube on a grid meets it 1.2e-7 apart) takes the light of one exactly at it, from the side in
// front of the wall. The floor is either split along the foot (two quads, x = 1 + off) or one quad
// whose cells straddle it (shifted by off, so a row of its vertices lies there); the reference is
// the split floor's outer vertices with off = 0, compared in the mean along the foot. Before: split, 10% too dark at 1.2e-7 outside and the whole sky (20%
// too bright) 1e-6 inside; straddling, 40% too dark (the wall's light lost).
TEST(Contact, AVertexWithinRoundingOfAWallFootGathersAsOneOnIt) {
  // The mean radiance of the floor's upward vertices within 1e-9 of x = 1 + off, |z| <= 0.6, of
  // the outer (or only) floor quad.
  auto solve = [](double off, bool split, bool doubleSided) {
    Scene scene;
    scene.materials = {material("floor", 0.8, 0, true), material("box", 0.8, 0, doubleSided)};
    // One quad 4 × 3 has a rate of 20 (its diagonal): a row of its vertices at its middle.
    const std::vector<double> xs = split ? std::vector<double>{-1, 1 + off, 3} : std::vector<double>{-1 + off, 3 + off};
    for (size_t i = 0; i + 1 < xs.size(); ++i)
      scene.primitives.push_back(quadPrimitive({Vec3{xs[i], 0, -1.5}, {xs[i], 0, 1.5}, {xs[i + 1], 0, 1.5}, {xs[i + 1], 0, -1.5}}, 0));
    scene.primitives.push_back(boxPrimitive({-1, 0, -0.93}, {1, 2, 1.07}, false, 1));  // no vertex shared with the floor
    for (size_t p = 0; p < scene.primitives.size(); ++p) scene.primitives[p].primitive = int(p);
    TessellateOptions t;
    t.maxEdgeLength = 0.25;
    const Baked b = exactUnderSky(scene, t);
    std::map<uint32_t, double> line;
    for (const Patch& patch : b.mesh.patches)
      for (const uint32_t v : patch.v) {
        const Vec3& p = b.mesh.positions[v];
        if (patch.primitive == int(xs.size()) - 2 && !patch.backSide && std::abs(p.x - 1 - off) <= std::abs(off) + 1e-9 &&
            std::abs(p.z) <= 0.6)
          line[v] = b.solution.vertexRadiance[v].x;
      }
    double sum = 0;
    for (const auto& [v, value] : line) sum += value;
    EXPECT_GE(line.size(), 3u) << (split ? "split" : "straddling") << " floor, " << off;
    return sum / double(std::max<size_t>(1, line.size()));
  };
  for (const bool doubleSided : {false, true}) {
    const double exact = solve(0, true, doubleSided);
    for (const bool split : {true, false})
      for (const double off : {-1e-6, -1.2e-7, 1.2e-7, 1e-6}) {
        const double near = solve(off, split, doubleSided);
        EXPECT_NEAR(near / exact, 1, 0.02) << (split ? "split" : "straddling") << " floor, vertices " << off
                                           << " beside the wall: " << near << " against " << exact;
      }
  }
}

}  // namespace

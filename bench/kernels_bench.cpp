// Throughput of the radiosity kernels: point-polygon factors, bilinear kernels K_ij (far, near an
// edge, crease limits), patch-patch factors and shadow rays. Run: build/bench/kernels_bench
#include <benchmark/benchmark.h>

#include <random>

#include "radiosity/form_factor.h"
#include "radiosity/visibility.h"

using namespace radbake;

namespace {

const std::array<Vec3, 4> kSource{{{0, 1, 0}, {1, 1, 0}, {1, 1, 1}, {0, 1, 1}}};  // facing down at y = 1

void PointPolygonFactor(benchmark::State& state) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Vec3> points(1024);
  for (Vec3& p : points) p = {u(rng) * 2 - 0.5, u(rng) * 0.5, u(rng) * 2 - 0.5};
  size_t i = 0;
  double sum = 0;
  for (auto _ : state) sum += pointPolygonFactor(points[i++ & 1023], {0, 1, 0}, kSource.data(), 4);
  if (!(sum > 0)) state.SkipWithError("the receivers see nothing: the benchmark measures the wrong case");
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(PointPolygonFactor);

// Receiver at distance `state.range(0)`/100 below the source's plane, near its centre.
void BilinearKernel(benchmark::State& state) {
  const double d = state.range(0) / 100.0;
  const Vec3 p{0.3, 1 - d, 0.6};
  if (!(vertexQuadKernel(p, {0, 1, 0}, {1, 0, 0}, kSource)[0] > 0)) state.SkipWithError("receiver sees nothing");
  for (auto _ : state) benchmark::DoNotOptimize(vertexQuadKernel(p, {0, 1, 0}, {1, 0, 0}, kSource));
  state.SetItemsProcessed(state.iterations());
  state.SetLabel("distance " + std::to_string(d));
}
BENCHMARK(BilinearKernel)->Arg(100)->Arg(10)->Arg(1);

void BilinearKernelNearEdge(benchmark::State& state) {
  // A floor vertex 1e-3 from a perpendicular wall: a neighbouring patch across a box edge.
  const std::array<Vec3, 4> wall{{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}};
  for (auto _ : state) benchmark::DoNotOptimize(vertexQuadKernel({0.4, 0, 1e-3}, {0, 1, 0}, {0, 0, 1}, wall));
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BilinearKernelNearEdge);

void BilinearKernelSliver(benchmark::State& state) {
  // A 50:1 sliver (a cylinder's side in a CAD tessellation), the receiver 0.01 in front of its middle.
  const std::array<Vec3, 4> sliver{{{0, 0, 0}, {1, 0, 0}, {1, 0.02, 0}, {0, 0.02, 0}}};
  for (auto _ : state) benchmark::DoNotOptimize(vertexQuadKernel({0.5, 0.01, 0.01}, {0, 0, -1}, {1, 0, 0}, sliver));
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BilinearKernelSliver);

void BilinearKernelCreaseLimit(benchmark::State& state) {
  const std::array<Vec3, 4> wall{{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}};
  const Vec3 bisector = normalize(Vec3{1, 0, 1});
  for (auto _ : state) benchmark::DoNotOptimize(vertexQuadKernel({0, 0, 0}, {0, 1, 0}, bisector, wall));
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BilinearKernelCreaseLimit);

void ConstantPatchFactor(benchmark::State& state) {
  const std::array<Vec3, 4> floor{{{0, 0, 0}, {0, 0, 1}, {1, 0, 1}, {1, 0, 0}}};
  const std::array<Vec3, 4> wall{{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}};
  const bool near = state.range(0) == 1;
  for (auto _ : state) benchmark::DoNotOptimize(constantPatchFactor(near ? wall : floor, near ? floor : kSource));
  state.SetItemsProcessed(state.iterations());
  state.SetLabel(near ? "sharing an edge" : "opposed at distance 1");
}
BENCHMARK(ConstantPatchFactor)->Arg(0)->Arg(1);

void ShadowRays(benchmark::State& state) {
  // A 64×64 grid of patches in the unit square and random rays across it.
  PatchMesh mesh;
  const int n = 64;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      mesh.positions.push_back({double(i) / n, 0.5, double(j) / n});
      mesh.normals.push_back({0, 1, 0});
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const uint32_t c = j * (n + 1) + i;
      mesh.patches.push_back(makePatch({c, c + n + 1, c + n + 2, c + 1}, 0, 0, {0, 1, 0}, 1.0 / (n * n)));
    }
  const Occlusion occlusion(mesh);
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<std::pair<Vec3, Vec3>> rays(4096);
  for (auto& r : rays) r = {{u(rng), 0, u(rng)}, {u(rng), 1, u(rng)}};
  size_t i = 0;
  for (auto _ : state) {
    const auto& r = rays[i++ & 4095];
    benchmark::DoNotOptimize(occlusion.visible(r.first, r.second));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(ShadowRays);

}  // namespace

BENCHMARK_MAIN();

#include "tessellate/subdivision.h"

#include <opensubdiv/bfr/refinerSurfaceFactory.h>
#include <opensubdiv/bfr/surface.h>
#include <opensubdiv/bfr/tessellation.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefinerFactory.h>

#include <map>
#include <memory>

namespace radbake {

using namespace OpenSubdiv;

LimitTessellation tessellateLimitSurface(const std::vector<Vec3>& cagePoints,
                                         const std::vector<std::vector<uint32_t>>& faces,
                                         SubdivisionScheme scheme, int rate) {
  LimitTessellation out;
  std::vector<int> vertsPerFace;
  std::vector<int> indices;
  for (const auto& f : faces) {
    vertsPerFace.push_back(int(f.size()));
    indices.insert(indices.end(), f.begin(), f.end());
  }
  Far::TopologyDescriptor desc;
  desc.numVertices = int(cagePoints.size());
  desc.numFaces = int(faces.size());
  desc.numVertsPerFace = vertsPerFace.data();
  desc.vertIndicesPerFace = indices.data();
  Sdc::Options sdcOptions;
  sdcOptions.SetVtxBoundaryInterpolation(Sdc::Options::VTX_BOUNDARY_EDGE_AND_CORNER);
  using Factory = Far::TopologyRefinerFactory<Far::TopologyDescriptor>;
  std::unique_ptr<Far::TopologyRefiner> refiner(Factory::Create(
      desc, Factory::Options(scheme == SubdivisionScheme::kLoop ? Sdc::SCHEME_LOOP : Sdc::SCHEME_CATMARK, sdcOptions)));
  if (!refiner) return out;

  std::vector<double> meshPoints(cagePoints.size() * 3);
  for (size_t i = 0; i < cagePoints.size(); ++i) {
    meshPoints[3 * i] = cagePoints[i].x;
    meshPoints[3 * i + 1] = cagePoints[i].y;
    meshPoints[3 * i + 2] = cagePoints[i].z;
  }
  Bfr::RefinerSurfaceFactory<> factory(*refiner);
  Bfr::Surface<double> surface;
  std::vector<double> patchPoints;
  std::map<uint32_t, uint32_t> cornerSample;                        // cage vertex → sample
  std::map<std::pair<uint32_t, uint32_t>, std::vector<uint32_t>> edgeSamples;  // (lo, hi) → samples lo→hi
  Bfr::Tessellation::Options tessOptions;
  tessOptions.PreserveQuads(true).SetFacetSize(4);

  for (size_t fi = 0; fi < faces.size(); ++fi) {
    if (!factory.InitVertexSurface(int(fi), &surface) || !surface.IsValid()) continue;
    patchPoints.resize(size_t(surface.GetNumPatchPoints()) * 3);
    surface.PreparePatchPoints(meshPoints.data(), 3, patchPoints.data(), 3);
    Bfr::Tessellation tess(surface.GetParameterization(), rate, tessOptions);
    const int n = tess.GetNumCoords();
    std::vector<double> uv(size_t(n) * 2);
    tess.GetCoords(uv.data());
    auto evaluate = [&](int c) {
      double p[3], du[3], dv[3];
      surface.Evaluate(&uv[2 * c], patchPoints.data(), 3, p, du, dv);
      const Vec3 normal = normalize(cross(Vec3{du[0], du[1], du[2]}, Vec3{dv[0], dv[1], dv[2]}));
      out.positions.push_back({p[0], p[1], p[2]});
      out.normals.push_back(normal);
      out.face.push_back(int(fi));
      return uint32_t(out.positions.size() - 1);
    };
    // Boundary coords come first: vertex 0, the points of edge 0, vertex 1, ... (rate − 1 per
    // edge at a uniform rate). Shared ones are looked up, the rest evaluated.
    const auto& f = faces[fi];
    const int size = int(f.size());
    std::vector<uint32_t> sample(n);
    int c = 0;
    for (int e = 0; e < size; ++e) {
      auto [corner, isNew] = cornerSample.try_emplace(f[e], 0);
      if (isNew) corner->second = evaluate(c);
      sample[c++] = corner->second;
      const uint32_t a = f[e], b = f[(e + 1) % size];
      const auto key = std::minmax(a, b);
      auto [edge, edgeIsNew] = edgeSamples.try_emplace({key.first, key.second});
      const int inner = tess.GetNumEdgeCoords(e);
      if (edgeIsNew) {
        std::vector<uint32_t> along(inner);
        for (int k = 0; k < inner; ++k) along[k] = evaluate(c + k);
        if (a > b) std::reverse(along.begin(), along.end());
        edge->second = along;
      }
      for (int k = 0; k < inner; ++k) sample[c + k] = a < b ? edge->second[k] : edge->second[inner - 1 - k];
      c += inner;
    }
    for (; c < n; ++c) sample[c] = evaluate(c);

    std::vector<int> facets(size_t(tess.GetNumFacets()) * 4);
    tess.GetFacets(facets.data());
    for (size_t k = 0; k < facets.size(); k += 4) {
      std::array<uint32_t, 4> q{sample[facets[k]], sample[facets[k + 1]], sample[facets[k + 2]],
                                facets[k + 3] < 0 ? sample[facets[k + 2]] : sample[facets[k + 3]]};
      out.quads.push_back(q);
      out.quadFace.push_back(int(fi));
    }
  }
  return out;
}

}  // namespace radbake

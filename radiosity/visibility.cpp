#include "radiosity/visibility.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace radbake {

struct Occlusion::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }
};

Occlusion::Occlusion(const PatchMesh& mesh) : impl_(std::make_unique<Impl>()) {
  // No "threads=N" config: Embree on TBB would install a process-wide tbb::global_control with it
  // and serialize the whole solver.
  impl_->device = rtcNewDevice(nullptr);
  if (!impl_->device) throw std::runtime_error("Embree device could not be created");
  impl_->scene = rtcNewScene(impl_->device);
  rtcSetSceneFlags(impl_->scene, RTC_SCENE_FLAG_ROBUST);  // watertight-ish: no rays slipping through shared edges
  rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_HIGH);

  Bounds bounds;
  for (const Vec3& p : mesh.positions) bounds.add(p);
  sceneSize_ = mesh.positions.empty() ? 1 : bounds.diagonal();
  epsilon_ = mesh.positions.empty() ? 1e-9 : std::max(1e-12, 1e-7 * sceneSize_);

  if (!mesh.patches.empty()) {
    RTCGeometry geom = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_QUAD);
    auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                                 3 * sizeof(float), mesh.positions.size()));
    for (size_t i = 0; i < mesh.positions.size(); ++i) {
      vertices[3 * i] = float(mesh.positions[i].x);
      vertices[3 * i + 1] = float(mesh.positions[i].y);
      vertices[3 * i + 2] = float(mesh.positions[i].z);
    }
    // A triangle patch (v2 == v3) is a valid Embree quad: Embree treats it as one triangle.
    auto* quads = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT4,
                                                                 4 * sizeof(unsigned), mesh.patches.size()));
    for (size_t i = 0; i < mesh.patches.size(); ++i)
      for (int k = 0; k < 4; ++k) quads[4 * i + k] = mesh.patches[i].v[k];
    rtcCommitGeometry(geom);
    rtcAttachGeometry(impl_->scene, geom);
    rtcReleaseGeometry(geom);
  }
  rtcCommitScene(impl_->scene);
}

Occlusion::~Occlusion() = default;

bool Occlusion::visible(const Vec3& from, const Vec3& to, std::span<const uint32_t> ignore) const {
  const Vec3 d = to - from;
  const double dist = length(d);
  if (dist <= 2 * epsilon_) return true;
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  float tnear = float(epsilon_);
  const float tfar = float(dist - epsilon_);
  if (ignore.empty() && !passes_) {
    RTCRay ray{};
    ray.org_x = float(from.x); ray.org_y = float(from.y); ray.org_z = float(from.z);
    ray.dir_x = float(d.x / dist); ray.dir_y = float(d.y / dist); ray.dir_z = float(d.z / dist);
    ray.tnear = tnear;
    ray.tfar = tfar;
    ray.mask = 0xFFFFFFFF;
    rtcOccluded1(impl_->scene, &context, &ray);
    return ray.tfar >= 0;  // Embree sets tfar to -inf on a hit
  }
  // With patches to ignore: walk the hits front to back, stepping over ignored ones.
  for (int step = 0; step < 64 && tnear < tfar; ++step) {
    RTCRayHit rh{};
    rh.ray.org_x = float(from.x); rh.ray.org_y = float(from.y); rh.ray.org_z = float(from.z);
    rh.ray.dir_x = float(d.x / dist); rh.ray.dir_y = float(d.y / dist); rh.ray.dir_z = float(d.z / dist);
    rh.ray.tnear = tnear;
    rh.ray.tfar = tfar;
    rh.ray.mask = 0xFFFFFFFF;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(impl_->scene, &context, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return true;
    const bool ignored = std::find(ignore.begin(), ignore.end(), rh.hit.primID) != ignore.end();
    if (!ignored && !(passes_ && passes_(rh.hit.primID, rh.hit.u, rh.hit.v))) return false;
    tnear = rh.ray.tfar + float(epsilon_);
  }
  return true;
}

}  // namespace radbake

#include "radiosity/cluster_tree.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace radbake {

int normalBin(const Vec3& m) {
  const int axis = std::abs(m.x) >= std::abs(m.y) && std::abs(m.x) >= std::abs(m.z) ? 0 : (std::abs(m.y) >= std::abs(m.z) ? 1 : 2);
  return 2 * axis + (m[axis] < 0);
}

ClusterTree buildClusterTree(const std::vector<TreeItem>& items) {
  ClusterTree tree;
  const size_t n = items.size();
  if (n == 0) return tree;
  std::vector<Vec3> centre(n);
  for (size_t p = 0; p < n; ++p) {
    Vec3 c{};
    for (int k = 0; k < items[p].pointCount; ++k) c += items[p].points[k];
    centre[p] = items[p].centre ? *items[p].centre : c / items[p].pointCount;
  }
  std::vector<uint8_t> bin(n);
  for (size_t p = 0; p < n; ++p) bin[p] = uint8_t(normalBin(items[p].normal));
  tree.order.resize(n);
  for (size_t p = 0; p < n; ++p) tree.order[p] = uint32_t(p);
  tree.nodes.reserve(2 * n);
  tree.nodes.push_back({});
  tree.nodes[0].count = uint32_t(n);
  // Top-down: each node splits its range at the median along the longest axis of its centres.
  std::vector<uint32_t> stack{0};
  while (!stack.empty()) {
    const uint32_t index = stack.back();
    stack.pop_back();
    TreeNode node = tree.nodes[index];
    const auto begin = tree.order.begin() + node.first, end = begin + node.count;
    double area = 0;
    Vec3 weighted{}, areaNormal{};
    Bounds box;
    for (auto it = begin; it != end; ++it) {
      const TreeItem& item = items[*it];
      area += item.area;
      weighted += centre[*it] * item.area;
      areaNormal += item.normal * item.area;
      box.add(centre[*it]);
      node.enclosed += item.enclosed;
    }
    node.centroid = area > 0 ? weighted / area : (box.lo + box.hi) / 2;
    node.areaNormal = areaNormal;
    node.area = area;
    node.axis = length(areaNormal) > 0 ? normalize(areaNormal) : Vec3{0, 0, 1};
    double radius = 0, coneSin = 0;
    Bounds corners;
    for (auto it = begin; it != end; ++it) {
      const TreeItem& item = items[*it];
      for (int k = 0; k < item.pointCount; ++k) {
        radius = std::max(radius, length(item.points[k] - node.centroid));
        corners.add(item.points[k]);
      }
      const double c = dot(item.normal, node.axis);
      coneSin = std::max(coneSin, c >= 0 ? std::sqrt(std::max(0.0, 1 - c * c)) : 2.0);
    }
    double thickness = 0;
    for (auto it = begin; it != end; ++it)
      for (int k = 0; k < items[*it].pointCount; ++k)
        thickness = std::max(thickness, std::abs(dot(node.axis, items[*it].points[k] - node.centroid)));
    node.radius = radius;
    node.thickness = thickness;
    node.lo = corners.lo;
    node.hi = corners.hi;
    node.coneSin = coneSin;
    if (node.count > 1) {
      // Orientation first: patches facing different ways (by the dominant axis of their normal,
      // six bins) are split apart before any spatial split, so that clusters have narrow normal
      // cones and can be linked whole (a spatial cluster across a room's corner never can).
      std::array<uint32_t, 6> inBin{};
      for (auto it = begin; it != end; ++it) ++inBin[bin[*it]];
      uint32_t leftCount = 0;
      if (std::any_of(begin, end, [&](uint32_t p) { return items[p].part != items[*begin].part; })) {
        const uint8_t first = items[*std::min_element(begin, end, [&](uint32_t a, uint32_t b) { return items[a].part < items[b].part; })].part;
        leftCount = uint32_t(std::stable_partition(begin, end, [&](uint32_t p) { return items[p].part == first; }) - begin);
      } else if (std::count_if(inBin.begin(), inBin.end(), [](uint32_t c) { return c > 0; }) > 1) {
        int pivot = 1;  // bins below go left: the boundary that splits the count most evenly
        uint32_t below = 0, best = UINT32_MAX;
        for (int b = 1; b < 6; ++b) {
          below += inBin[b - 1];
          const uint32_t imbalance = below > node.count - below ? 2 * below - node.count : node.count - 2 * below;
          if (below > 0 && below < node.count && imbalance < best) {
            best = imbalance;
            pivot = b;
            leftCount = below;
          }
        }
        std::stable_partition(begin, end, [&](uint32_t p) { return bin[p] < pivot; });
      } else {
        const Vec3 extent = box.hi - box.lo;
        const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
        leftCount = node.count / 2;
        std::nth_element(begin, begin + leftCount, end, [&](uint32_t a, uint32_t b) {
          const double ca = centre[a][axis], cb = centre[b][axis];
          return ca < cb || (ca == cb && a < b);
        });
        // Items at one point stay on one side (the receivers of a flat-shaded crease, one per face,
        // share their visibility rays where a group holds them all): those beside the median go
        // right, or, where the whole left part is at that point, the right part's join them.
        const Vec3 at = centre[*(begin + leftCount)];
        auto elsewhere = [&](uint32_t p) { return !(centre[p] == at); };
        uint32_t left = uint32_t(std::partition(begin, begin + leftCount, elsewhere) - begin);
        if (left == 0) left = uint32_t(std::partition(begin + leftCount, end, [&](uint32_t p) { return !elsewhere(p); }) - begin);
        if (left > 0 && left < node.count) leftCount = left;
      }
      for (int k = 0; k < 2; ++k) {
        TreeNode child;
        child.first = k == 0 ? node.first : node.first + leftCount;
        child.count = k == 0 ? leftCount : node.count - leftCount;
        node.child[k] = int32_t(tree.nodes.size());
        tree.nodes.push_back(child);
        stack.push_back(uint32_t(node.child[k]));
      }
    }
    tree.nodes[index] = node;
  }
  return tree;
}

Heights heightsOver(const TreeNode& node, const TreeNode& other) {
  const Vec3 &lo = other.lo, &hi = other.hi;
  double low = 0, high = 0, reach = 0;
  for (int k = 0; k < 3; ++k) {
    const double a = node.axis[k] * (lo[k] - node.centroid[k]), b = node.axis[k] * (hi[k] - node.centroid[k]);
    low += std::min(a, b);
    high += std::max(a, b);
    const double far = std::max(std::abs(lo[k] - node.centroid[k]), std::abs(hi[k] - node.centroid[k]));
    reach += far * far;
  }
  // The other node's slab (its thickness along its own axis, its radius across) bounds it more
  // tightly when the two are nearly parallel: a box around a tilted face is not flat, the face is.
  const double cosine = dot(node.axis, other.axis), sine = std::sqrt(std::max(0.0, 1 - cosine * cosine));
  const double centre = dot(node.axis, other.centroid - node.centroid);
  const double half = other.thickness * std::abs(cosine) + other.radius * sine;
  low = std::max(low, centre - half);
  high = std::min(high, centre + half);
  const double span = std::sqrt(reach) + node.radius;  // bounds |y − x|
  const double tan = node.coneSin < 1 ? node.coneSin / std::sqrt(1 - node.coneSin * node.coneSin)
                                      : std::numeric_limits<double>::infinity();
  const double slack = node.thickness + (tan > 0 ? tan * span : 0);
  return {low - slack, high + slack, 1e-9 * span};
}

}  // namespace radbake

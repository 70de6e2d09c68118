// Internal to radiosity/: bounding-volume hierarchies for hierarchical (panel-clustered) transport
// (docs/radiosity.md "Hierarchical transport"): one over the source patches, one over the
// receiving vertices.
//
// A group of receivers far from a cluster of patches, relative to both sizes, gathers from the
// whole cluster at once through its vector moment Σ_patches n_p ∫ L N_j dA (face-cluster radiosity's
// vector irradiance; the panel clustering of collocation methods): one link instead of a kernel
// per vertex and patch.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "core/core.h"

namespace radbake {

// What a tree is built over: a patch (its corners, normal, area) or a receiving vertex (one point,
// its receiving normal, weight 1).
struct TreeItem {
  std::array<Vec3, 4> points;
  int pointCount = 4;
  Vec3 normal;
  double area = 1;
  bool enclosed = false;  // inside a closed room (Closure)
  // Where the item sits, if not the mean of its points: a receiving patch's area centroid (the
  // constant method), where a linear field takes its mean over the patch.
  std::optional<Vec3> centre;
  // Items of different parts are split apart before anything else (the receivers that gather by
  // rays, tracedBackSides, get subtrees of their own).
  uint8_t part = 0;
};

struct TreeNode {
  Vec3 centroid;          // area-weighted centre of the items
  double radius = 0;      // bounding sphere about the centroid (every point inside)
  double thickness = 0;   // largest |axis · (point − centroid)|: 0 for a flat group
  Vec3 lo, hi;            // bounding box of the points
  Vec3 axis;              // normal cone: mean normal (unit) ...
  double coneSin = 0;     // ... and the sine of its half-angle (> 1: wider than a hemisphere)
  Vec3 areaNormal;        // Σ area · normal: a source cluster's moment of L ≡ 1 (closure sums)
  double area = 0;
  uint32_t first = 0, count = 0;  // items order[first, first + count)
  int32_t child[2] = {-1, -1};    // -1: a leaf (one item)
  uint32_t enclosed = 0;          // how many of its items are enclosed
};

struct ClusterTree {
  std::vector<TreeNode> nodes;  // nodes[0] is the root; children after their parent
  std::vector<uint32_t> order;  // item indices, each node's range contiguous
  bool empty() const { return nodes.empty(); }
};

// The dominant axis and sign of a normal, 0..5: the tree's first split separates these bins.
int normalBin(const Vec3& normal);

// Built in a fixed order (items first separated by part, then by the dominant axis of their
// normal, then median splits on the longest axis, ties by index, items at one point kept on one
// side): the same tree, and the same bits downstream, for any thread count.
ClusterTree buildClusterTree(const std::vector<TreeItem>& items);

// A value per node from the leaves up: `leaf(k)` at leaf node k (its one item is
// tree.order[nodes[k].first]), `combine(a, b)` of its children's values at an inner node. One
// backward pass: children come after their parent.
template <typename T, typename Leaf, typename Combine>
std::vector<T> bottomUp(const ClusterTree& tree, Leaf leaf, Combine combine) {
  std::vector<T> value(tree.nodes.size());
  for (size_t k = tree.nodes.size(); k-- > 0;) {
    const TreeNode& node = tree.nodes[k];
    value[k] = node.count == 1 ? T(leaf(k)) : T(combine(value[node.child[0]], value[node.child[1]]));
  }
  return value;
}

// Where another node lies relative to the tangent planes of a node's items: every item's plane (a
// patch's, or a receiver's horizon) has the other's points at heights within [low, high], up to
// `rounding`. A flat node has thickness 0 and a cone of 0: the nodes in its own plane are at height 0
// (the floor's patches lie on a floor group's horizon and are culled whole, not opened to leaves).
struct Heights {
  double low, high, rounding;
};
Heights heightsOver(const TreeNode& node, const TreeNode& other);

}  // namespace radbake

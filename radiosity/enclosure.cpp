#include "radiosity/enclosure.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <tuple>

#include "core/core.h"

namespace radbake {
namespace {

struct PointKey {
  double x, y, z;
  bool operator<(const PointKey& o) const { return std::tie(x, y, z) < std::tie(o.x, o.y, o.z); }
};

struct EdgeKey {
  PointKey a, b;  // a < b
  bool back;
  bool operator<(const EdgeKey& o) const { return std::tie(a, b, back) < std::tie(o.a, o.b, o.back); }
};

struct EdgeUse {
  uint32_t patch;
  bool forward;  // runs from a to b
};

size_t find(std::vector<size_t>& parent, size_t i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

// The corners a patch actually has (a triangle's repeated corner dropped).
int cornerCount(const Patch& p) { return p.v[3] == p.v[2] ? 3 : 4; }

// Generalized winding number of the closed surface `patches` at x (Van Oosterom & Strackee's
// solid angle per triangle): ±1 inside, 0 outside, ±½ on it; the sign follows the orientation.
double windingNumber(const PatchMesh& mesh, const std::vector<uint32_t>& patches, const Vec3& x) {
  double sum = 0;
  for (uint32_t k : patches) {
    const Patch& p = mesh.patches[k];
    const int n = cornerCount(p);
    for (int t = 1; t + 1 < n; ++t) {
      const Vec3 a = mesh.positions[p.v[0]] - x, b = mesh.positions[p.v[t]] - x, c = mesh.positions[p.v[t + 1]] - x;
      const double la = length(a), lb = length(b), lc = length(c);
      const double num = dot(a, cross(b, c));
      if (num == 0) continue;  // x in the triangle's plane: on it (ambiguous, ±2π) or seeing it edge-on (0)
      const double den = la * lb * lc + dot(a, b) * lc + dot(a, c) * lb + dot(b, c) * la;
      sum += 2 * std::atan2(num, den);
    }
  }
  return sum / (4 * kPi);
}

}  // namespace

bool Enclosures::contains(const PatchMesh& mesh, int room, const Vec3& point) const {
  return std::abs(windingNumber(mesh, walls[room], point)) > 0.5;
}

Enclosures findEnclosures(const PatchMesh& mesh) {
  const size_t n = mesh.patches.size();
  Enclosures out;
  out.of.assign(n, -1);
  if (n == 0) return out;
  auto key = [&](uint32_t v) {
    const Vec3& p = mesh.positions[v];
    return PointKey{p.x, p.y, p.z};
  };
  // Every edge use, sorted by edge (stably: an edge's uses in patch order), so that each edge's
  // uses lie together: the order a map from edge to uses gave, which took 31 ms where this takes
  // 17 (issue 16's room, each of refinement's 31 rounds finds the enclosures of its mesh).
  std::vector<std::pair<EdgeKey, EdgeUse>> uses;
  uses.reserve(4 * n);
  for (size_t i = 0; i < n; ++i) {
    const Patch& p = mesh.patches[i];
    const int c = cornerCount(p);
    for (int k = 0; k < c; ++k) {
      const PointKey a = key(p.v[k]), b = key(p.v[(k + 1) % c]);
      if (!(a < b) && !(b < a)) continue;
      const bool forward = a < b;
      uses.push_back({{forward ? a : b, forward ? b : a, p.backSide}, {uint32_t(i), forward}});
    }
  }
  std::stable_sort(uses.begin(), uses.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
  // Components over shared edges; a component is closed when each of its edges has exactly two
  // uses running in opposite directions.
  std::vector<size_t> parent(n);
  std::iota(parent.begin(), parent.end(), size_t(0));
  std::vector<bool> open(n, false);
  for (size_t first = 0, last = 0; first < uses.size(); first = last) {
    for (last = first + 1; last < uses.size() && !(uses[first].first < uses[last].first); ++last) {
    }
    const EdgeUse& one = uses[first].second;
    for (size_t u = first + 1; u < last; ++u) parent[find(parent, uses[u].second.patch)] = find(parent, one.patch);
    if (last - first != 2 || one.forward == uses[first + 1].second.forward)
      for (size_t u = first; u < last; ++u) open[uses[u].second.patch] = true;
  }
  std::map<size_t, std::vector<uint32_t>> components;
  for (size_t i = 0; i < n; ++i) components[find(parent, i)].push_back(uint32_t(i));
  std::vector<std::pair<double, const std::vector<uint32_t>*>> rooms;  // (enclosed volume, walls)
  std::vector<const std::vector<uint32_t>*> others;
  for (const auto& [root, patches] : components) {
    const bool closed = std::none_of(patches.begin(), patches.end(), [&](uint32_t k) { return open[k]; });
    double volume = 0;  // six times the signed volume: positive when the fronts face outward
    if (closed)
      for (uint32_t k : patches) {
        const Patch& p = mesh.patches[k];
        for (int t = 1; t + 1 < cornerCount(p); ++t)
          volume += dot(mesh.positions[p.v[0]], cross(mesh.positions[p.v[t]], mesh.positions[p.v[t + 1]]));
      }
    if (closed && volume < 0) rooms.push_back({-volume, &patches});
    else others.push_back(&patches);
  }
  // Smallest first, so the first room found around something is the innermost.
  std::sort(rooms.begin(), rooms.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (size_t r = 0; r < rooms.size(); ++r) {
    out.walls.push_back(*rooms[r].second);
    for (uint32_t k : *rooms[r].second) out.of[k] = int(r);
  }
  const std::vector<int> wallOf = out.of;  // per patch: the room whose walls it is, or −1
  // Anything else inside a room (objects in a closed room). A component is tested at the centres
  // of its patches until one is clearly inside or outside: a block standing on the floor has a
  // face lying on it, where the winding number is ½.
  for (const auto* component : others) {
    // The rooms this component is the other side of: a double-sided surface's two sides coincide,
    // so neither is inside the other. Any patch of the component counts, not only its first: a
    // double-sided box standing on a floor split along its footprint shares its bottom edges with
    // the floor under it, so its outside and that floor are one (open) component, and the floor's
    // patch came first (the box's outside and the floor around it went dark: 25-58% beside it).
    std::vector<bool> outsideOf(out.walls.size(), false);
    for (uint32_t k : *component) {
      const int twin = mesh.patches[k].twin;
      if (twin >= 0 && wallOf[size_t(twin)] >= 0) outsideOf[size_t(wallOf[size_t(twin)])] = true;
    }
    const size_t samples = std::min<size_t>(component->size(), 16);
    for (size_t r = 0; r < out.walls.size(); ++r) {
      const auto& walls = out.walls[r];
      if (outsideOf[r]) continue;
      bool inside = false, decided = false;
      for (size_t t = 0; t < samples && !decided; ++t) {
        const Patch& p = mesh.patches[(*component)[t * component->size() / samples]];
        Vec3 centre{};
        for (int k = 0; k < cornerCount(p); ++k) centre += mesh.positions[p.v[k]] / double(cornerCount(p));
        const double w = std::abs(windingNumber(mesh, walls, centre));
        if (w > 0.75) inside = decided = true;
        if (w < 0.25) decided = true;
      }
      if (inside) {
        for (uint32_t k : *component) out.of[k] = int(r);
        break;
      }
    }
  }
  return out;
}

}  // namespace radbake

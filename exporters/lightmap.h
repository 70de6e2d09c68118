// Internal to exporters/: the lightmap atlas behind `radbake bake --lightmap FILE.exr`.
//
// buildAtlas lays every baked primitive instance out in one texture: charts of edge-connected
// triangles that face about the same way, each flattened onto the plane of its average normal and
// packed with an empty gutter around it. rasterize turns per-vertex light into texels exactly as a
// GPU interpolates vertex colors, and dilate fills the gutters, so bilinear filtering and the first
// mip levels never pull black (or another chart's light) into a chart.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/core.h"

namespace radbake {

// One baked primitive instance: an indexed triangle mesh in world space (indices < positions.size()).
struct AtlasPiece {
  std::vector<Vec3> positions;
  std::vector<std::array<uint32_t, 3>> triangles;
};

struct AtlasOptions {
  int size = 1024;       // the largest width and height allowed, in texels
  double texelSize = 0;  // world units per texel; 0: the finest that fits in size × size
  int padding = 4;       // texels of empty gutter between charts (half of it along the image border)
};

// One piece in the atlas. Vertices are split where charts meet, so the piece gets its own output
// vertices; triangles keep their order (output triangle i is input triangle i). Input vertices that
// no triangle uses are dropped.
struct AtlasPieceLayout {
  std::vector<uint32_t> vertexSource;              // input vertex of each output vertex
  // Per output vertex, glTF TEXCOORD convention: u = (x + 0.5) / width for texel column x, and
  // v = (y + 0.5) / height for texel row y, row 0 being the top row of the stored image. buildAtlas
  // puts every vertex on a texel center, so sampling the image there returns that texel exactly.
  std::vector<std::array<float, 2>> uv;
  std::vector<std::array<uint32_t, 3>> triangles;  // output vertex indices
  std::vector<int> chart;                          // per triangle, a chart id unique in the atlas
};

struct Atlas {
  int width = 0, height = 0;  // at most AtlasOptions::size each, multiples of 4 where that allows
  double texelSize = 0;       // world units per texel: the requested one, or the one chosen
  int charts = 0;
  double fill = 0;            // the fraction of the image inside the charts' triangles
  std::vector<AtlasPieceLayout> pieces;  // one per input piece, in order
};

// Throws Error(kUsage) with one line naming the needed and the allowed size when the charts do not
// fit: at the requested texel size, or (texelSize 0) even at one texel per chart. Also Error(kUsage)
// for a size below 1, a negative padding, or a negative or non-finite texel size.
Atlas buildAtlas(const std::vector<AtlasPiece>& pieces, const AtlasOptions& options = {});

struct LightmapImage {
  int width = 0, height = 0;
  std::vector<float> rgb;  // width × height × 3, linear, row 0 at the top
  std::vector<int> owner;  // width × height: the chart whose light a texel holds; -1: empty
};

// values[piece][output vertex]: linear light. A texel whose center lies in a triangle gets the
// barycentric interpolation of its vertices; a texel a triangle only partly covers gets the value at
// the nearest point of the nearest triangle (of any chart within reach: that chart becomes its
// owner), so no texel a triangle covers stays empty. Works for any UVs (an asset's own TEXCOORD_1
// too, with a chart id per piece or per UV island); UVs outside [0, 1] are clipped.
LightmapImage rasterize(int width, int height, const std::vector<AtlasPieceLayout>& layout,
                        const std::vector<std::vector<Vec3>>& values);

// Why a UV layout (an asset's own TEXCOORD_1) cannot hold a width × height lightmap, in one line:
// a used UV outside [0, 1], or a texel center inside two triangles (real overlap: centers on a shared
// edge or vertex go to one triangle by the GPU's fill rule). Empty when the layout is usable.
std::string lightmapLayoutProblem(int width, int height, const std::vector<AtlasPieceLayout>& layout);

// Fills every empty texel (owner −1) with the light of its nearest written texel, counted in
// 8-connected steps; written texels and the owner image stay as they are.
void dilate(LightmapImage& image);

}  // namespace radbake

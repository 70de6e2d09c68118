// Lightmap atlas tests. The expected answers come from the geometry (areas, chart counts, a linear
// light field evaluated at world points found by inverting the layout with this file's own
// barycentrics) and from an independent coverage test (clipping each triangle against each texel).
#include "exporters/lightmap.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <optional>
#include <random>
#include <set>
#include <string>

#include "core/core.h"

namespace radbake {
namespace {

using ::testing::HasSubstr;

struct P2 {
  double x, y;
};

// ---- meshes ----

// The unit square in z = 0, n × n quads on shared vertices, facing +z.
AtlasPiece unitSquare(int n) {
  AtlasPiece piece;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) piece.positions.push_back({double(i) / n, double(j) / n, 0});
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const uint32_t a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      piece.triangles.push_back({a, b, d});
      piece.triangles.push_back({a, d, c});
    }
  return piece;
}

// The unit cube [0,1]³, four vertices of its own per face, faces counter-clockwise from outside.
AtlasPiece cube() {
  AtlasPiece piece;
  const Vec3 corner[8] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  const int faces[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {2, 3, 7, 6}, {0, 4, 7, 3}, {1, 2, 6, 5}};
  for (const auto& f : faces) {
    const uint32_t base = uint32_t(piece.positions.size());
    for (int k : f) piece.positions.push_back(corner[k]);
    piece.triangles.push_back({base, base + 1, base + 2});
    piece.triangles.push_back({base, base + 2, base + 3});
  }
  return piece;
}

// A grid of `around` × `along` quads bent into a cylinder of radius 1 and height 3, outward, with a
// duplicated column of vertices at the seam (as glTF has where the texture wraps).
AtlasPiece cylinder(int around, int along) {
  AtlasPiece piece;
  for (int j = 0; j <= along; ++j)
    for (int i = 0; i <= around; ++i) {
      const double phi = 2 * std::numbers::pi * i / around;
      piece.positions.push_back({std::cos(phi), std::sin(phi), 3.0 * j / along});
    }
  for (int j = 0; j < along; ++j)
    for (int i = 0; i < around; ++i) {
      const uint32_t a = j * (around + 1) + i, b = a + 1, c = a + around + 1, d = c + 1;
      piece.triangles.push_back({a, b, d});
      piece.triangles.push_back({a, d, c});
    }
  return piece;
}

// `count` separate small triangles, randomly placed and turned: as many charts.
AtlasPiece scatteredTriangles(int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> pos(0, 10), dir(-1, 1), len(0.01, 0.05);
  AtlasPiece piece;
  for (int i = 0; i < count; ++i) {
    const Vec3 o{pos(rng), pos(rng), pos(rng)};
    const Vec3 e1 = normalize(Vec3{dir(rng), dir(rng), dir(rng)}) * len(rng);
    const Vec3 e2 = normalize(cross(e1, Vec3{dir(rng), dir(rng), dir(rng)})) * len(rng) + e1 * 0.3;
    const uint32_t base = uint32_t(piece.positions.size());
    piece.positions.insert(piece.positions.end(), {o, o + e1, o + e2});
    piece.triangles.push_back({base, base + 1, base + 2});
  }
  return piece;
}

// ---- independent geometry on the layout ----

std::array<P2, 3> texelTriangle(const AtlasPieceLayout& piece, size_t t, int width, int height) {
  std::array<P2, 3> r;
  for (int k = 0; k < 3; ++k) {
    const auto& uv = piece.uv[piece.triangles[t][k]];
    r[k] = {double(uv[0]) * width, double(uv[1]) * height};
  }
  return r;
}

double signedArea(P2 a, P2 b, P2 c) { return ((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x)) / 2; }

// The area the triangle shares with texel (x, y): the triangle clipped by the texel's four sides.
double overlapArea(const std::array<P2, 3>& tri, int x, int y) {
  std::array<P2, 8> poly{tri[0], tri[1], tri[2]};  // a triangle clipped by four lines: 7 corners at most
  size_t n = 3;
  const auto clip = [&](auto inside, auto cut) {
    std::array<P2, 8> out;
    size_t m = 0;
    for (size_t i = 0; i < n; ++i) {
      const P2 a = poly[i], b = poly[(i + 1) % n];
      if (inside(a)) out[m++] = a;
      if (inside(a) != inside(b)) out[m++] = cut(a, b);
    }
    poly = out;
    n = m;
  };
  const auto atX = [](double c) {
    return [c](P2 a, P2 b) { const double f = (c - a.x) / (b.x - a.x); return P2{c, a.y + f * (b.y - a.y)}; };
  };
  const auto atY = [](double c) {
    return [c](P2 a, P2 b) { const double f = (c - a.y) / (b.y - a.y); return P2{a.x + f * (b.x - a.x), c}; };
  };
  clip([&](P2 p) { return p.x >= x; }, atX(x));
  clip([&](P2 p) { return p.x <= x + 1; }, atX(x + 1));
  clip([&](P2 p) { return p.y >= y; }, atY(y));
  clip([&](P2 p) { return p.y <= y + 1; }, atY(y + 1));
  double a = 0;
  for (size_t i = 1; i + 1 < n; ++i) a += signedArea(poly[0], poly[i], poly[i + 1]);
  return std::abs(a);
}

// Barycentric weights of p in the triangle (nullopt when degenerate).
std::optional<std::array<double, 3>> barycentric(const std::array<P2, 3>& t, P2 p) {
  const double area = signedArea(t[0], t[1], t[2]);
  if (std::abs(area) < 1e-9) return std::nullopt;
  return std::array<double, 3>{signedArea(p, t[1], t[2]) / area, signedArea(t[0], p, t[2]) / area,
                               signedArea(t[0], t[1], p) / area};
}

// The charts whose triangles cover a texel with some area (the first two; -1: none).
struct Cover {
  int first = -1, second = -1;
  void add(int chart) {
    if (first < 0) first = chart;
    else if (chart != first && second < 0) second = chart;
  }
  bool has(int chart) const { return chart >= 0 && (chart == first || chart == second); }
};

std::vector<Cover> coveredTexels(const std::vector<AtlasPieceLayout>& layout, int width, int height) {
  std::vector<Cover> covered(size_t(width) * height);
  for (const AtlasPieceLayout& piece : layout)
    for (size_t t = 0; t < piece.triangles.size(); ++t) {
      const auto tri = texelTriangle(piece, t, width, height);
      const int x0 = std::max(0, int(std::floor(std::min({tri[0].x, tri[1].x, tri[2].x})))),
                x1 = std::min(width - 1, int(std::floor(std::max({tri[0].x, tri[1].x, tri[2].x}))));
      const int y0 = std::max(0, int(std::floor(std::min({tri[0].y, tri[1].y, tri[2].y})))),
                y1 = std::min(height - 1, int(std::floor(std::max({tri[0].y, tri[1].y, tri[2].y}))));
      for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x)
          if (overlapArea(tri, x, y) > 1e-9) covered[size_t(y) * width + x].add(piece.chart[t]);
    }
  return covered;
}

// A linear light field over world space, different per channel.
Vec3 linearField(const Vec3& p) {
  return {0.5 + 0.2 * p.x - 0.1 * p.y + 0.05 * p.z, 1.0 - 0.15 * p.x + 0.3 * p.y + 0.1 * p.z, 0.25 + 0.05 * p.x + 0.05 * p.y - 0.2 * p.z};
}

std::vector<std::vector<Vec3>> fieldAtVertices(const Atlas& atlas, const std::vector<AtlasPiece>& pieces) {
  std::vector<std::vector<Vec3>> values(pieces.size());
  for (size_t p = 0; p < pieces.size(); ++p)
    for (uint32_t v : atlas.pieces[p].vertexSource) values[p].push_back(linearField(pieces[p].positions[v]));
  return values;
}

Vec3 texelValue(const LightmapImage& image, size_t k) {
  return {image.rgb[3 * k], image.rgb[3 * k + 1], image.rgb[3 * k + 2]};
}

// The whole contract of rasterize on an atlas built from `pieces` with the linear field: every
// covered texel is written by a chart covering it; every texel center inside a triangle holds the
// field at the world point it maps to; every written texel holds a value of its own chart's field.
void expectExactLinearLightmap(const Atlas& atlas, const std::vector<AtlasPiece>& pieces) {
  const auto values = fieldAtVertices(atlas, pieces);
  const LightmapImage image = rasterize(atlas.width, atlas.height, atlas.pieces, values);
  ASSERT_EQ(image.rgb.size(), size_t(atlas.width) * atlas.height * 3);

  const std::vector<Cover> covered = coveredTexels(atlas.pieces, atlas.width, atlas.height);
  for (size_t k = 0; k < covered.size(); ++k) {
    if (covered[k].first < 0) continue;
    ASSERT_GE(image.owner[k], 0) << "covered texel " << k % atlas.width << "," << k / atlas.width << " left empty";
    ASSERT_TRUE(covered[k].has(image.owner[k])) << "texel owned by a chart that does not cover it";
  }
  size_t checkedCenters = 0;
  for (size_t p = 0; p < pieces.size(); ++p) {
    const AtlasPieceLayout& piece = atlas.pieces[p];
    for (size_t t = 0; t < piece.triangles.size(); ++t) {
      const auto tri = texelTriangle(piece, t, atlas.width, atlas.height);
      const int x0 = int(std::floor(std::min({tri[0].x, tri[1].x, tri[2].x}))), x1 = int(std::ceil(std::max({tri[0].x, tri[1].x, tri[2].x})));
      const int y0 = int(std::floor(std::min({tri[0].y, tri[1].y, tri[2].y}))), y1 = int(std::ceil(std::max({tri[0].y, tri[1].y, tri[2].y})));
      for (int y = std::max(0, y0); y <= std::min(atlas.height - 1, y1); ++y)
        for (int x = std::max(0, x0); x <= std::min(atlas.width - 1, x1); ++x) {
          const auto w = barycentric(tri, {x + 0.5, y + 0.5});
          if (!w || (*w)[0] < -1e-7 || (*w)[1] < -1e-7 || (*w)[2] < -1e-7) continue;
          Vec3 world;
          for (int k = 0; k < 3; ++k) world += pieces[p].positions[piece.vertexSource[piece.triangles[t][k]]] * (*w)[k];
          const Vec3 expected = linearField(world), got = texelValue(image, size_t(y) * atlas.width + x);
          ASSERT_NEAR(got.x, expected.x, 1e-5) << "texel " << x << "," << y;
          ASSERT_NEAR(got.y, expected.y, 1e-5);
          ASSERT_NEAR(got.z, expected.z, 1e-5);
          ++checkedCenters;
        }
    }
  }
  EXPECT_GT(checkedCenters, 0u);

  // A border texel takes the value at a point of its own chart: within the range of that chart's
  // vertex values (a linear field over triangles never leaves it).
  std::map<int, std::array<double, 6>> range;  // per chart: lowest r, g, b, then highest
  for (size_t p = 0; p < pieces.size(); ++p)
    for (size_t t = 0; t < atlas.pieces[p].triangles.size(); ++t)
      for (uint32_t v : atlas.pieces[p].triangles[t]) {
        auto& r = range.try_emplace(atlas.pieces[p].chart[t], std::array<double, 6>{1e300, 1e300, 1e300, -1e300, -1e300, -1e300})
                      .first->second;
        for (int c = 0; c < 3; ++c) r[c] = std::min(r[c], values[p][v][c]), r[c + 3] = std::max(r[c + 3], values[p][v][c]);
      }
  for (size_t k = 0; k < image.owner.size(); ++k) {
    if (image.owner[k] < 0) continue;
    const auto& r = range.at(image.owner[k]);
    const Vec3 v = texelValue(image, k);
    for (int c = 0; c < 3; ++c) {
      ASSERT_GE(v[c], r[c] - 1e-5);
      ASSERT_LE(v[c], r[c + 3] + 1e-5);
    }
  }
}

// Texels each chart covers, as boxes [x0, x1] × [y0, y1].
std::map<int, std::array<int, 4>> chartBoxes(const Atlas& atlas) {
  std::map<int, std::array<int, 4>> boxes;
  const std::vector<Cover> covered = coveredTexels(atlas.pieces, atlas.width, atlas.height);
  for (size_t k = 0; k < covered.size(); ++k)
    for (int c : {covered[k].first, covered[k].second}) {
      if (c < 0) continue;
      const int x = int(k % atlas.width), y = int(k / atlas.width);
      auto& b = boxes.try_emplace(c, std::array<int, 4>{x, x, y, y}).first->second;
      b = {std::min(b[0], x), std::max(b[1], x), std::min(b[2], y), std::max(b[3], y)};
    }
  return boxes;
}

// Charts' covered texels never meet and have at least `padding` empty texels between them.
void expectSeparated(const Atlas& atlas, int padding) {
  const auto boxes = chartBoxes(atlas);
  std::vector<std::array<int, 4>> list;
  for (const auto& [c, b] : boxes) list.push_back(b);
  for (size_t i = 0; i < list.size(); ++i)
    for (size_t j = i + 1; j < list.size(); ++j) {
      const auto &a = list[i], &b = list[j];
      const int gap = std::max({b[0] - a[1], a[0] - b[1], b[2] - a[3], a[2] - b[3]}) - 1;  // empty texels between
      ASSERT_GE(gap, padding) << "charts " << i << " and " << j;
    }
}

void expectVerticesOnTexelCenters(const Atlas& atlas) {
  for (const AtlasPieceLayout& piece : atlas.pieces)
    for (const auto& uv : piece.uv) {
      ASSERT_GE(uv[0], 0.0f);
      ASSERT_LE(uv[0], 1.0f);
      ASSERT_GE(uv[1], 0.0f);
      ASSERT_LE(uv[1], 1.0f);
      const double x = uv[0] * double(atlas.width) - 0.5, y = uv[1] * double(atlas.height) - 0.5;
      ASSERT_NEAR(x, std::round(x), 1e-4);
      ASSERT_NEAR(y, std::round(y), 1e-4);
    }
}

double uvArea(const Atlas& atlas) {
  double a = 0;
  for (const AtlasPieceLayout& piece : atlas.pieces)
    for (size_t t = 0; t < piece.triangles.size(); ++t) {
      const auto tri = texelTriangle(piece, t, atlas.width, atlas.height);
      a += std::abs(signedArea(tri[0], tri[1], tri[2]));
    }
  return a;
}

// ---- buildAtlas ----

TEST(Atlas, UnitSquareIsOneChartWithItsArea) {
  AtlasOptions o;
  o.texelSize = 1.0 / 64;
  const Atlas atlas = buildAtlas({unitSquare(4)}, o);
  EXPECT_EQ(atlas.charts, 1);
  EXPECT_EQ(atlas.texelSize, 1.0 / 64);
  // 64 texels across from vertex center to vertex center: a box of 65 texels, 4 of gutter, and at
  // most 3 more to round up to a multiple of 4.
  EXPECT_GE(atlas.width, 69);
  EXPECT_LE(atlas.width, 72);
  EXPECT_GE(atlas.height, 69);
  EXPECT_LE(atlas.height, 72);
  EXPECT_NEAR(uvArea(atlas), 64.0 * 64.0, 1e-6 * 64 * 64);  // float UVs
  EXPECT_NEAR(atlas.fill, 64.0 * 64.0 / (atlas.width * atlas.height), 1e-12);
  ASSERT_EQ(atlas.pieces.size(), 1u);
  EXPECT_EQ(atlas.pieces[0].vertexSource.size(), 25u);  // nothing to split
  EXPECT_EQ(atlas.pieces[0].triangles.size(), 32u);
  expectVerticesOnTexelCenters(atlas);
}

TEST(Atlas, DuplicatedSeamVerticesStillJoinOneChart) {
  // Two triangles of a square that share their diagonal by position only.
  AtlasPiece piece;
  piece.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  piece.triangles = {{0, 1, 2}, {3, 4, 5}};
  AtlasOptions o;
  o.texelSize = 1.0 / 16;
  const Atlas atlas = buildAtlas({piece}, o);
  EXPECT_EQ(atlas.charts, 1);
  const AtlasPieceLayout& out = atlas.pieces[0];
  ASSERT_EQ(out.vertexSource.size(), 6u);
  std::map<uint32_t, std::array<float, 2>> uvOf;
  for (size_t i = 0; i < out.vertexSource.size(); ++i) uvOf[out.vertexSource[i]] = out.uv[i];
  EXPECT_EQ(uvOf[0], uvOf[3]);
  EXPECT_EQ(uvOf[2], uvOf[4]);
  EXPECT_NEAR(uvArea(atlas), 16.0 * 16.0, 1e-6 * 16 * 16);
}

TEST(Atlas, CubeHasSixSeparatedFlatCharts) {
  const std::vector<AtlasPiece> pieces = {cube()};
  for (int padding : {0, 1, 4}) {
    AtlasOptions o;
    o.texelSize = 1.0 / 32;
    o.padding = padding;
    const Atlas atlas = buildAtlas(pieces, o);
    EXPECT_EQ(atlas.charts, 6);
    // Each chart is one face: the two triangles of a face share a chart, and no other.
    const auto& chart = atlas.pieces[0].chart;
    ASSERT_EQ(chart.size(), 12u);
    for (int f = 0; f < 6; ++f) EXPECT_EQ(chart[2 * f], chart[2 * f + 1]);
    EXPECT_EQ(std::set<int>(chart.begin(), chart.end()).size(), 6u);
    EXPECT_EQ(atlas.pieces[0].vertexSource.size(), 24u);
    EXPECT_NEAR(uvArea(atlas), 6 * 32.0 * 32.0, 1e-6 * 6 * 32 * 32);
    expectVerticesOnTexelCenters(atlas);
    expectSeparated(atlas, padding);
    EXPECT_EQ(lightmapLayoutProblem(atlas.width, atlas.height, atlas.pieces), "");
  }
}

TEST(Atlas, AutomaticTexelSizeFillsTheAllowedSize) {
  for (int size : {64, 256, 1024}) {
    AtlasOptions o;
    o.size = size;
    const Atlas atlas = buildAtlas({cube()}, o);
    EXPECT_EQ(atlas.charts, 6);
    EXPECT_LE(atlas.width, size);
    EXPECT_LE(atlas.height, size);
    // Six square faces in at most size × size: at least two of them side by side along the longer
    // side, so a face gets at least a third of it (less its gutter and rounding).
    EXPECT_GT(1 / atlas.texelSize, size / 3.0 - 8) << size;
    EXPECT_GT(atlas.fill, size >= 256 ? 0.8 : 0.4) << size;  // the gutters weigh on small sizes
    expectSeparated(atlas, o.padding);
    expectVerticesOnTexelCenters(atlas);
  }
}

TEST(Atlas, NoFitIsAUsageErrorNamingNeededAndAllowedSize) {
  AtlasOptions o;
  o.size = 64;
  o.texelSize = 0.01;
  try {
    buildAtlas({unitSquare(2)}, o);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kUsage);
    // 100 texels across, a box of 101 and 4 of gutter.
    EXPECT_THAT(e.what(), HasSubstr("105x105"));
    EXPECT_THAT(e.what(), HasSubstr("64x64"));
  }
  // Each face fits alone (33 + 4 texels), six of them do not.
  o.texelSize = 1.0 / 32;
  try {
    buildAtlas({cube()}, o);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kUsage);
    EXPECT_THAT(e.what(), HasSubstr("64x64"));
    EXPECT_THAT(e.what(), HasSubstr("the charts need"));
  }
  o.texelSize = -1;
  EXPECT_THROW(buildAtlas({cube()}, o), Error);
}

TEST(Atlas, DegenerateTrianglesGoSomewhereHarmless) {
  AtlasPiece piece = unitSquare(2);
  const uint32_t n = uint32_t(piece.positions.size());
  piece.positions.push_back({0.25, 0, 0});      // on the square's bottom edge
  piece.positions.push_back({5, 5, 5});         // far away
  piece.positions.push_back({6, 5, 5});
  piece.positions.push_back({7, 5, 5});
  piece.triangles.push_back({0, n, 1});          // a sliver along the bottom edge
  piece.triangles.push_back({4, 4, 4});          // a point
  piece.triangles.push_back({n + 1, n + 2, n + 3});  // an isolated segment
  AtlasOptions o;
  o.texelSize = 1.0 / 16;
  const Atlas atlas = buildAtlas({piece}, o);
  const auto& chart = atlas.pieces[0].chart;
  EXPECT_EQ(chart[8], chart[0]);  // the sliver shares an edge with the square
  EXPECT_EQ(chart[9], chart[0]);  // the point shares a vertex with it
  EXPECT_EQ(atlas.charts, 2);     // the segment touches nothing: a chart of its own
  expectVerticesOnTexelCenters(atlas);
  EXPECT_EQ(lightmapLayoutProblem(atlas.width, atlas.height, atlas.pieces), "");
  EXPECT_NEAR(uvArea(atlas), 16.0 * 16.0, 1e-6 * 16 * 16);
}

TEST(Atlas, ThousandsOfTinyChartsPack) {
  const std::vector<AtlasPiece> pieces = {scatteredTriangles(3000, 1), scatteredTriangles(2000, 2)};
  const Atlas atlas = buildAtlas(pieces, {});
  EXPECT_EQ(atlas.charts, 5000);
  EXPECT_LE(atlas.width, 1024);
  EXPECT_LE(atlas.height, 1024);
  expectVerticesOnTexelCenters(atlas);
  expectSeparated(atlas, 4);
  EXPECT_EQ(lightmapLayoutProblem(atlas.width, atlas.height, atlas.pieces), "");
  RecordProperty("fill", std::to_string(atlas.fill));
}

TEST(Atlas, TooManyChartsForTheSizeIsAUsageError) {
  AtlasOptions o;
  o.size = 64;  // room for 12 × 12 boxes of 1 texel and 4 of gutter, fewer than 200
  try {
    buildAtlas({scatteredTriangles(200, 3)}, o);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kUsage);
    EXPECT_THAT(e.what(), HasSubstr("64x64"));
  }
}

// ---- rasterize ----

TEST(Lightmap, EveryVertexTexelHoldsExactlyItsValue) {
  const std::vector<AtlasPiece> pieces = {cube(), unitSquare(4)};
  AtlasOptions o;
  o.texelSize = 1.0 / 20;
  const Atlas atlas = buildAtlas(pieces, o);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> value(1, 100);
  std::vector<std::vector<Vec3>> values(pieces.size());
  for (size_t p = 0; p < pieces.size(); ++p)
    for (size_t v = 0; v < atlas.pieces[p].vertexSource.size(); ++v) values[p].push_back({value(rng), value(rng), value(rng)});
  const LightmapImage image = rasterize(atlas.width, atlas.height, atlas.pieces, values);
  for (size_t p = 0; p < pieces.size(); ++p)
    for (size_t v = 0; v < values[p].size(); ++v) {
      const auto& uv = atlas.pieces[p].uv[v];
      const size_t k = size_t(std::floor(uv[1] * atlas.height)) * atlas.width + size_t(std::floor(uv[0] * atlas.width));
      const Vec3 got = texelValue(image, k);
      // Float UVs put the vertex within 1e-5 texel of the center (far better than half-float
      // precision, which is what the EXR keeps).
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], values[p][v][c], 1e-4 * values[p][v][c]) << "piece " << p << " vertex " << v;
    }
}

TEST(Lightmap, LinearFieldIsExactOnACube) {
  const std::vector<AtlasPiece> pieces = {cube()};
  for (int padding : {0, 4}) {
    AtlasOptions o;
    o.texelSize = 1.0 / 24;
    o.padding = padding;
    expectExactLinearLightmap(buildAtlas(pieces, o), pieces);
  }
}

TEST(Lightmap, LargeCylinderBuildsAndStaysExact) {
  const std::vector<AtlasPiece> pieces = {cylinder(300, 300)};
  const Atlas atlas = buildAtlas(pieces, {});
  ASSERT_EQ(atlas.pieces[0].triangles.size(), 180000u);
  // Charts of at most about 80° of arc: five or so around, none along the straight axis.
  EXPECT_GE(atlas.charts, 4);
  EXPECT_LE(atlas.charts, 12);
  EXPECT_LE(atlas.width, 1024);
  EXPECT_LE(atlas.height, 1024);
  expectVerticesOnTexelCenters(atlas);
  expectSeparated(atlas, 4);
  EXPECT_EQ(lightmapLayoutProblem(atlas.width, atlas.height, atlas.pieces), "");
  expectExactLinearLightmap(atlas, pieces);
  RecordProperty("fill", std::to_string(atlas.fill));
}

TEST(Lightmap, NoTexelHoldsAnotherChartsLight) {
  const std::vector<AtlasPiece> pieces = {cube(), cylinder(24, 6)};
  AtlasOptions o;
  o.texelSize = 1.0 / 16;
  o.padding = 0;  // charts as close as they get
  const Atlas atlas = buildAtlas(pieces, o);
  std::vector<std::vector<Vec3>> values(pieces.size());
  for (size_t p = 0; p < pieces.size(); ++p) {
    values[p].resize(atlas.pieces[p].vertexSource.size());
    for (size_t t = 0; t < atlas.pieces[p].triangles.size(); ++t)
      for (uint32_t v : atlas.pieces[p].triangles[t]) values[p][v] = Vec3{1, 2, 3} * (atlas.pieces[p].chart[t] + 1);
  }
  LightmapImage image = rasterize(atlas.width, atlas.height, atlas.pieces, values);
  const std::vector<Cover> covered = coveredTexels(atlas.pieces, atlas.width, atlas.height);
  for (size_t k = 0; k < covered.size(); ++k) EXPECT_TRUE(covered[k].first < 0 || image.owner[k] >= 0) << "texel " << k;
  for (size_t k = 0; k < image.owner.size(); ++k) {
    const Vec3 v = texelValue(image, k);
    const Vec3 expected = image.owner[k] < 0 ? Vec3{} : Vec3{1, 2, 3} * (image.owner[k] + 1);
    EXPECT_EQ(v, expected) << "texel " << k;
  }

  const LightmapImage before = image;
  dilate(image);
  EXPECT_EQ(image.owner, before.owner);
  for (size_t k = 0; k < image.owner.size(); ++k) {
    const Vec3 v = texelValue(image, k);
    if (before.owner[k] >= 0) {
      EXPECT_EQ(v, texelValue(before, k));
    }
    EXPECT_GT(v.x, 0) << "texel " << k << " left empty by dilate";
    EXPECT_EQ(v.y, 2 * v.x);  // a copy of some chart's light
  }
}

TEST(Lightmap, BorderTexelsTakeTheNearestPointOfTheirTriangle) {
  // A triangle not on texel centers (an asset's own UVs), light = (x, y, 1) at texel position
  // (x, y): a partly covered texel must hold the light at the triangle's point nearest its center.
  const int w = 16, h = 12;
  AtlasPieceLayout piece;
  const std::array<P2, 3> tri = {P2{2.3, 1.7}, P2{13.6, 3.2}, P2{5.1, 10.4}};
  for (const P2& p : tri) piece.uv.push_back({float(p.x / w), float(p.y / h)});
  piece.triangles = {{0, 1, 2}};
  piece.chart = {0};
  piece.vertexSource = {0, 1, 2};
  std::vector<std::vector<Vec3>> values(1);
  std::array<P2, 3> exact;  // where the float UVs put the corners
  for (int k = 0; k < 3; ++k) {
    exact[k] = {double(piece.uv[k][0]) * w, double(piece.uv[k][1]) * h};
    values[0].push_back({exact[k].x, exact[k].y, 1});
  }
  const LightmapImage image = rasterize(w, h, {piece}, values);
  const auto covered = coveredTexels({piece}, w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t k = size_t(y) * w + x;
      if (covered[k].first < 0) {
        EXPECT_EQ(image.owner[k], -1) << x << "," << y;
        continue;
      }
      ASSERT_EQ(image.owner[k], 0);
      // Nearest point by brute force: the center itself when inside, else the closest of many
      // points along the edges.
      const P2 c{x + 0.5, y + 0.5};
      P2 best = c;
      const auto bw = barycentric(exact, c);
      if ((*bw)[0] < 0 || (*bw)[1] < 0 || (*bw)[2] < 0) {
        double bestD = 1e300;
        for (int e = 0; e < 3; ++e)
          for (int s = 0; s <= 20000; ++s) {
            const double f = s / 20000.0;
            const P2 a = exact[e], b = exact[(e + 1) % 3];
            const P2 q{a.x + f * (b.x - a.x), a.y + f * (b.y - a.y)};
            const double d = std::hypot(q.x - c.x, q.y - c.y);
            if (d < bestD) bestD = d, best = q;
          }
      }
      const Vec3 v = texelValue(image, k);
      EXPECT_NEAR(v.x, best.x, 1e-3) << x << "," << y;
      EXPECT_NEAR(v.y, best.y, 1e-3) << x << "," << y;
      EXPECT_NEAR(v.z, 1, 1e-6);
    }
}

// ---- dilate ----

TEST(Lightmap, DilateFillsEveryTexelFromTheNearestWrittenOne) {
  const int w = 9, h = 3;
  LightmapImage image;
  image.width = w;
  image.height = h;
  image.rgb.assign(w * h * 3, 0);
  image.owner.assign(w * h, -1);
  const auto set = [&](int x, int y, float v, int owner) {
    const size_t k = size_t(y) * w + x;
    image.rgb[3 * k] = image.rgb[3 * k + 1] = image.rgb[3 * k + 2] = v;
    image.owner[k] = owner;
  };
  set(0, 1, 10, 0);  // chart 0 at the left edge
  set(5, 1, 0, 1);   // chart 1 in the middle, written black: must stay black
  set(8, 1, 20, 1);  // and at the right edge
  dilate(image);
  // Steps (8-connected) to the three written texels from column x: x, |x − 5|, 8 − x; no ties.
  const float expected[w] = {10, 10, 10, 0, 0, 0, 0, 20, 20};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t k = size_t(y) * w + x;
      for (int c = 0; c < 3; ++c) EXPECT_EQ(image.rgb[3 * k + c], expected[x]) << x << "," << y;
    }
  EXPECT_EQ(image.owner[0], -1);  // dilation claims no texel
}

// ---- lightmapLayoutProblem ----

// A square of four triangles around its center, all corners on texel centers of an 8 × 8 image:
// texel centers lie on every shared edge and on the shared vertex.
AtlasPieceLayout fan(float x0, float y0, float x1, float y1, int chart) {
  AtlasPieceLayout piece;
  const float cx = (x0 + x1) / 2, cy = (y0 + y1) / 2;
  for (const auto& [x, y] : std::vector<std::pair<float, float>>{{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}, {cx, cy}})
    piece.uv.push_back({x / 8, y / 8});
  piece.triangles = {{0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}};
  piece.chart.assign(4, chart);
  piece.vertexSource = {0, 1, 2, 3, 4};
  return piece;
}

TEST(LightmapLayout, SharedEdgesAndVerticesAreNoOverlap) {
  EXPECT_EQ(lightmapLayoutProblem(8, 8, {fan(0.5f, 0.5f, 6.5f, 6.5f, 0)}), "");
  // Two pieces meeting along a whole edge (x = 3.5, through texel centers).
  EXPECT_EQ(lightmapLayoutProblem(8, 8, {fan(0.5f, 0.5f, 3.5f, 3.5f, 0), fan(3.5f, 0.5f, 6.5f, 3.5f, 1)}), "");
  // Clockwise (mirrored) triangles are no overlap either.
  AtlasPieceLayout mirrored = fan(0.5f, 0.5f, 6.5f, 6.5f, 0);
  for (auto& uv : mirrored.uv) uv[0] = 1 - uv[0];
  EXPECT_EQ(lightmapLayoutProblem(8, 8, {mirrored}), "");
}

TEST(LightmapLayout, OverlapIsDetected) {
  const std::string across = lightmapLayoutProblem(8, 8, {fan(0.5f, 0.5f, 4.5f, 4.5f, 0), fan(2.5f, 2.5f, 6.5f, 6.5f, 1)});
  EXPECT_THAT(across, HasSubstr("overlaps"));
  EXPECT_THAT(across, HasSubstr("piece 1"));
  // Two instances of one mesh with the same UVs.
  EXPECT_THAT(lightmapLayoutProblem(8, 8, {fan(0.5f, 0.5f, 4.5f, 4.5f, 0), fan(0.5f, 0.5f, 4.5f, 4.5f, 0)}), HasSubstr("overlaps"));
  // A fold inside one piece: a fifth triangle over the others.
  AtlasPieceLayout folded = fan(0.5f, 0.5f, 6.5f, 6.5f, 0);
  folded.triangles.push_back({0, 2, 1});
  EXPECT_THAT(lightmapLayoutProblem(8, 8, {folded}), HasSubstr("overlaps"));
}

TEST(LightmapLayout, UvOutsideTheUnitSquareIsUnusable) {
  AtlasPieceLayout piece = fan(0.5f, 0.5f, 6.5f, 6.5f, 0);
  piece.uv[2] = {1.25f, 0.5f};
  EXPECT_THAT(lightmapLayoutProblem(8, 8, {piece}), HasSubstr("outside [0, 1]"));
  piece.uv[2] = {std::nanf(""), 0.5f};
  EXPECT_THAT(lightmapLayoutProblem(8, 8, {piece}), HasSubstr("outside [0, 1]"));
}

}  // namespace
}  // namespace radbake

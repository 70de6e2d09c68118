// Internal to exporters/: image files in memory, so that every output of a bake can be written
// (and renamed into place) together, or not at all.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace radbake {

// A half-float RGB OpenEXR file (ZIP compressed) of width × height linear RGB floats, row 0 at the
// top. Values beyond half's range (65504) saturate.
std::string encodeExrHalfRgb(int width, int height, const std::vector<float>& rgb);

// An 8-bit RGB PNG of width × height × 3 bytes, row 0 at the top.
std::string encodePng(int width, int height, const std::vector<uint8_t>& rgb);

}  // namespace radbake

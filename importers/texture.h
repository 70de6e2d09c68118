// Internal to importers/: decoding color textures.
#pragma once

#include <string>
#include <vector>

#include "importers/importers.h"

namespace radbake {

// The image's width and height from its header alone (no pixel is decoded); false if unreadable.
bool imageDimensions(const std::vector<unsigned char>& encoded, int& width, int& height);

// Why an image's header cannot be true (a decompression bomb: a 0.4 MB PNG claiming 20000×20000
// RGBA, more than deflate's 1032:1 can hold), or "".
std::string implausibleImage(const std::vector<unsigned char>& encoded, int width, int height);

// Bytes a decoded texture holds: stb's RGBA8 while decoding plus the float RGB and alpha kept.
constexpr double kDecodedBytesPerTexel = 4 + 16;

// Decodes PNG/JPEG bytes into linear RGB (sRGB decoded). False with `error` set when it cannot.
bool decodeColorTexture(const std::vector<unsigned char>& encoded, Texture& out, std::string& error);

}  // namespace radbake

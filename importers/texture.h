// Internal to importers/: decoding color textures.
#pragma once

#include <string>
#include <vector>

#include "importers/importers.h"

namespace radbake {

// Decodes PNG/JPEG bytes into linear RGB (sRGB decoded). False with `error` set when it cannot.
bool decodeColorTexture(const std::vector<unsigned char>& encoded, Texture& out, std::string& error);

}  // namespace radbake

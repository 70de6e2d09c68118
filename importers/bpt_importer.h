// Internal to importers/: the Bezier patch (.bpt) reader.
#pragma once

#include <cstdint>
#include <string>

#include "importers/importers.h"

namespace radbake {

// Reads the .bpt at `path` (a regular file of at most maxBytes).
Scene importBezierPatches(const std::string& path, uint64_t maxBytes);

// The same from text already read; `path` names it in messages.
Scene parseBezierPatches(const std::string& text, const std::string& path);

}  // namespace radbake

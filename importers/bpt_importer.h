// Internal to importers/: the Bezier patch (.bpt) reader.
#pragma once

#include <string>

#include "importers/importers.h"

namespace radbake {

Scene importBezierPatches(const std::string& path);

}  // namespace radbake

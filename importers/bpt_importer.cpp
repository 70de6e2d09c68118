// .bpt: the classic Bezier patch format (Newell's teapot). First line: the patch count. Each patch:
// a line "du dv" (degrees), then (du+1)(dv+1) lines "x y z", u index outer.
#include "importers/bpt_importer.h"

#include <cmath>
#include <filesystem>
#include <sstream>

namespace radbake {
namespace {

constexpr int kMaxDegree = 16;
constexpr long kMaxPatches = 1 << 22;
constexpr double kBezierReflectance = 0.8;  // a .bpt has no materials: a light grey diffuse

}  // namespace

Scene importBezierPatches(const std::string& path, uint64_t maxBytes) {
  const std::string file = std::filesystem::path(path).filename().string();
  const std::vector<unsigned char> bytes = readRegularFile(path, file.empty() ? path : file, maxBytes);
  return parseBezierPatches(std::string(bytes.begin(), bytes.end()), path);
}

Scene parseBezierPatches(const std::string& text, const std::string& path) {
  Scene scene;
  scene.path = path;
  const std::string file = std::filesystem::path(path).filename().string();
  auto fail = [&](const std::string& message) -> void { throw Error(ExitCode::kInvalidInput, file + ": " + message); };
  std::istringstream in(text);

  int lineNumber = 0;
  std::string line;
  auto nextLine = [&](const std::string& what) {
    while (std::getline(in, line)) {
      ++lineNumber;
      if (line.find_first_not_of(" \t\r") != std::string::npos) return;
    }
    fail("unexpected end of file, expected " + what);
  };
  nextLine("the patch count");
  long count = -1;
  {
    std::istringstream fields(line);
    if (!(fields >> count) || count < 0 || count > kMaxPatches)
      fail("line " + std::to_string(lineNumber) + ": expected a patch count, got \"" + line + "\"");
  }
  Material grey;
  grey.name = "bezier surface (radbake default)";
  grey.reflectance = Vec3{1, 1, 1} * kBezierReflectance;
  scene.materials.push_back(grey);
  for (long p = 0; p < count; ++p) {
    const std::string where = "patch " + std::to_string(p);
    nextLine(where + " degrees");
    BezierPatch patch;
    {
      std::istringstream fields(line);
      if (!(fields >> patch.degreeU >> patch.degreeV) || patch.degreeU < 1 || patch.degreeV < 1 ||
          patch.degreeU > kMaxDegree || patch.degreeV > kMaxDegree)
        fail("line " + std::to_string(lineNumber) + ": " + where + ": expected two degrees 1.." +
             std::to_string(kMaxDegree) + ", got \"" + line + "\"");
    }
    const int points = (patch.degreeU + 1) * (patch.degreeV + 1);
    for (int k = 0; k < points; ++k) {
      nextLine(where + " control point " + std::to_string(k));
      std::istringstream fields(line);
      double x, y, z;
      if (!(fields >> x >> y >> z) || !std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
        fail("line " + std::to_string(lineNumber) + ": " + where + " control point " + std::to_string(k) +
             ": expected three finite numbers, got \"" + line + "\"");
      patch.control.push_back({x, z, -y});  // z up → y up
    }
    scene.bezierPatches.push_back(std::move(patch));
  }
  scene.counts.meshes = count > 0 ? 1 : 0;
  scene.counts.primitives = int(count);
  scene.counts.materials = 0;
  for (const BezierPatch& patch : scene.bezierPatches) scene.counts.vertices += long(patch.control.size());
  return scene;
}

}  // namespace radbake

#include "core/core.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <unistd.h>

namespace radbake {

Matrix4 invertAffine(const Matrix4& m) {
  const double a = m[0], b = m[4], c = m[8], d = m[1], e = m[5], f = m[9], g = m[2], h = m[6], i = m[10];
  const double det = determinant3(m);
  const double r[9] = {(e * i - f * h) / det, (c * h - b * i) / det, (b * f - c * e) / det,
                       (f * g - d * i) / det, (a * i - c * g) / det, (c * d - a * f) / det,
                       (d * h - e * g) / det, (b * g - a * h) / det, (a * e - b * d) / det};  // row-major
  Matrix4 out{r[0], r[3], r[6], 0, r[1], r[4], r[7], 0, r[2], r[5], r[8], 0, 0, 0, 0, 1};
  const double tx = m[12], ty = m[13], tz = m[14];
  out[12] = -(r[0] * tx + r[1] * ty + r[2] * tz);
  out[13] = -(r[3] * tx + r[4] * ty + r[5] * tz);
  out[14] = -(r[6] * tx + r[7] * ty + r[8] * tz);
  return out;
}

void writeFileAtomically(const std::string& path, const std::string& bytes) { writeFilesAtomically({{path, bytes}}); }

void writeFilesAtomically(const std::vector<std::pair<std::string, std::string>>& files) {
  namespace fs = std::filesystem;
  std::vector<fs::path> temps;
  std::error_code ec;
  auto fail = [&](const std::string& path, const std::string& why, size_t renamed) {
    for (size_t i = renamed; i < temps.size(); ++i) fs::remove(temps[i], ec);
    for (size_t i = 0; i < renamed; ++i) fs::remove(files[i].first, ec);  // all or nothing
    throw Error(ExitCode::kCannotWrite, path + ": cannot write: " + why);
  };
  for (const auto& [path, bytes] : files) {
    const fs::path target(path);
    const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
    if (!fs::is_directory(dir, ec)) fail(path, "directory " + dir.string() + " does not exist", 0);
    std::string tempName = ".";
    tempName += target.filename().string();
    tempName += ".radbake-";
    tempName += std::to_string(::getpid());
    tempName += ".tmp";
    temps.push_back(dir / tempName);
    std::ofstream out(temps.back(), std::ios::binary | std::ios::trunc);
    if (out) out.write(bytes.data(), std::streamsize(bytes.size()));
    if (out) out.close();
    if (!out) fail(path, std::strerror(errno), 0);
  }
  for (size_t i = 0; i < files.size(); ++i) {
    fs::rename(temps[i], files[i].first, ec);
    if (ec) fail(files[i].first, ec.message(), i);
  }
}

std::string lowerExtension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext;
}

double srgbEncode(double linear) {
  return linear <= 0.0031308 ? 12.92 * linear : 1.055 * std::pow(linear, 1 / 2.4) - 0.055;
}

}  // namespace radbake

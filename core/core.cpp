#include "core/core.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include <fcntl.h>
#include <sys/stat.h>
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

std::string oneLine(const std::string& text, size_t limit) {
  std::string line;
  for (unsigned char c : text) {
    if (c == '\n' || c == '\r') break;
    if (c < 0x20 || c == 0x7f) continue;  // a tab or an escape sequence must not reach the terminal
    line.push_back(char(c));
    if (line.size() > limit) break;
  }
  while (!line.empty() && line.back() == ' ') line.pop_back();
  if (line.size() > limit) {
    line.resize(limit - 3);
    // Do not leave half a UTF-8 sequence before the dots.
    while (!line.empty() && (static_cast<unsigned char>(line.back()) & 0xC0) == 0x80) line.pop_back();
    if (!line.empty() && static_cast<unsigned char>(line.back()) >= 0xC0) line.pop_back();
    line += "...";
  }
  return line;
}

namespace {

const char* fileKind(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

}  // namespace

std::string regularFileProblem(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0)
    return errno == ENOENT || errno == ENOTDIR ? "cannot open: no such file" : std::string("cannot open: ") + std::strerror(errno);
  if (!S_ISREG(st.st_mode)) return std::string("not a regular file (") + fileKind(st.st_mode) + ")";
  return "";
}

std::vector<unsigned char> readRegularFile(const std::string& path, const std::string& what, uint64_t maxBytes) {
  // O_NONBLOCK: opening a FIFO must not wait for a writer; fstat then refuses it. Checking the
  // open descriptor (not the name) leaves no window for the file to be swapped in between.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
  if (fd < 0) {
    const int e = errno;
    throw Error(ExitCode::kInvalidInput, what + ": cannot open: " +
                                             (e == ENOENT || e == ENOTDIR ? std::string("no such file") : std::strerror(e)));
  }
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) throw Error(ExitCode::kInvalidInput, what + ": cannot open: " + std::strerror(errno));
  if (!S_ISREG(st.st_mode))
    throw Error(ExitCode::kInvalidInput, what + ": not a regular file (" + fileKind(st.st_mode) + "); radbake reads only regular files");
  const uint64_t size = uint64_t(st.st_size);
  if (size > maxBytes)
    throw Error(ExitCode::kUnsupported, what + ": " + formatBytes(double(size)) + " is past the memory budget of " +
                                            formatBytes(double(maxBytes)) + " (--max-memory)");
  std::vector<unsigned char> bytes(size);
  size_t done = 0;
  while (done < size) {
    const ssize_t got = ::read(fd, bytes.data() + done, size - done);
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) throw Error(ExitCode::kInvalidInput, what + ": cannot read: " + std::strerror(errno));
    if (got == 0) break;  // the file shrank while we read it
    done += size_t(got);
  }
  bytes.resize(done);
  return bytes;
}

uint64_t physicalMemoryBytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), pageSize = ::sysconf(_SC_PAGESIZE);
  if (pages <= 0 || pageSize <= 0) return uint64_t(8) << 30;
  return uint64_t(pages) * uint64_t(pageSize);
}

std::optional<uint64_t> parseByteSize(const std::string& text) {
  size_t used = 0;
  double value = 0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    return std::nullopt;
  }
  std::string unit = text.substr(used);
  std::transform(unit.begin(), unit.end(), unit.begin(), [](unsigned char c) { return std::toupper(c); });
  double scale = 0;
  if (unit.empty() || unit == "B") scale = 1;
  else if (unit == "K" || unit == "KB" || unit == "KIB") scale = 1024.0;
  else if (unit == "M" || unit == "MB" || unit == "MIB") scale = 1024.0 * 1024;
  else if (unit == "G" || unit == "GB" || unit == "GIB") scale = 1024.0 * 1024 * 1024;
  else if (unit == "T" || unit == "TB" || unit == "TIB") scale = 1024.0 * 1024 * 1024 * 1024;
  const double bytes = value * scale;
  if (!(scale > 0) || !std::isfinite(bytes) || !(bytes >= 1) || bytes > 1.8e19) return std::nullopt;
  return uint64_t(bytes);
}

std::string formatBytes(double bytes) {
  const char* units[] = {"bytes", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
  int u = 0;
  while (bytes >= 1024 && u < 6) {
    bytes /= 1024;
    ++u;
  }
  char text[48];
  std::snprintf(text, sizeof text, u == 0 ? "%.0f %s" : "%.3g %s", bytes, units[u]);
  return text;
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

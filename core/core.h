// core: what every stage uses (DESIGN.md "Layout"). Geometry (Vec3, Bounds, the affine transforms
// of glTF nodes, π), the Error every stage throws with the command line's exit codes, atomic file
// writes, the sRGB transfer function and file-extension lowercasing.
//
// It depends on nothing of radbake's, so any stage may include it without pulling in another
// stage; stages include each other only for the data that flows between them (Scene, PatchMesh,
// Solution).
#pragma once

#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <numbers>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace radbake {

// ---- Geometry ------------------------------------------------------------------------------

constexpr double kPi = std::numbers::pi;

// Small double-precision 3-vector shared by every stage. Geometry is read from float glTF data but
// all solver math runs in double: form factors near edges need the extra digits.
struct Vec3 {
  double x = 0, y = 0, z = 0;

  constexpr double operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  constexpr Vec3 operator+(const Vec3& o) const { return {x + o.x, y + o.y, z + o.z}; }
  constexpr Vec3 operator-(const Vec3& o) const { return {x - o.x, y - o.y, z - o.z}; }
  constexpr Vec3 operator-() const { return {-x, -y, -z}; }
  constexpr Vec3 operator*(double s) const { return {x * s, y * s, z * s}; }
  constexpr Vec3 operator/(double s) const { return {x / s, y / s, z / s}; }
  Vec3& operator+=(const Vec3& o) { x += o.x; y += o.y; z += o.z; return *this; }
  Vec3& operator-=(const Vec3& o) { x -= o.x; y -= o.y; z -= o.z; return *this; }
  Vec3& operator*=(double s) { x *= s; y *= s; z *= s; return *this; }
  constexpr bool operator==(const Vec3& o) const = default;
};

constexpr Vec3 operator*(double s, const Vec3& v) { return v * s; }
constexpr double dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
constexpr Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double length(const Vec3& v) { return std::sqrt(dot(v, v)); }

// A position's bits as a key (-0 counts as +0): points computed the same way have the same key, so
// patches on either side of an edge find each other's points, and welding needs no tolerance.
inline uint64_t keyBits(double v) { return std::bit_cast<uint64_t>(v == 0.0 ? 0.0 : v); }
inline std::array<uint64_t, 3> positionKey(const Vec3& p) { return {keyBits(p.x), keyBits(p.y), keyBits(p.z)}; }
inline Vec3 normalize(const Vec3& v) {
  const double len = length(v);
  return len > 0 ? v / len : Vec3{};
}
inline bool isFinite(const Vec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

// FNV-1a over 64-bit words: the hash of keys made of exact bit patterns (welded positions, a
// patch's corners), where equal bits are what "the same point" means.
constexpr size_t hashWords(std::span<const uint64_t> words) {
  size_t h = 1469598103934665603ull;
  for (uint64_t v : words) h = (h ^ v) * 1099511628211ull;
  return h;
}
template <size_t N>
struct WordsHash {
  size_t operator()(const std::array<uint64_t, N>& k) const { return hashWords(k); }
};

// Axis-aligned bounds of points, for sizes that set tolerances (welding, ray offsets, rates).
struct Bounds {
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  void add(const Vec3& p) {
    lo = {lo.x < p.x ? lo.x : p.x, lo.y < p.y ? lo.y : p.y, lo.z < p.z ? lo.z : p.z};
    hi = {hi.x > p.x ? hi.x : p.x, hi.y > p.y ? hi.y : p.y, hi.z > p.z ? hi.z : p.z};
  }
  bool empty() const { return lo.x > hi.x; }
  double diagonal() const { return empty() ? 0 : length(hi - lo); }
};

// A node transform: column-major 4×4, as glTF stores it (Primitive::world, node matrices).
using Matrix4 = std::array<double, 16>;

// m applied to the point p (the affine part; the last row is taken to be 0 0 0 1).
inline Vec3 transformPoint(const Matrix4& m, const Vec3& p) {
  return {m[0] * p.x + m[4] * p.y + m[8] * p.z + m[12], m[1] * p.x + m[5] * p.y + m[9] * p.z + m[13],
          m[2] * p.x + m[6] * p.y + m[10] * p.z + m[14]};
}

// Determinant of the 3×3 part of m: negative for a mirroring node, which turns front faces
// clockwise (glTF).
inline double determinant3(const Matrix4& m) {
  return m[0] * (m[5] * m[10] - m[9] * m[6]) - m[4] * (m[1] * m[10] - m[9] * m[2]) + m[8] * (m[1] * m[6] - m[5] * m[2]);
}

// Inverse of an affine m (node to world gives world to node), by the 3×3 adjugate.
Matrix4 invertAffine(const Matrix4& m);

// ---- Errors --------------------------------------------------------------------------------

// Exit codes of the command line, shared by every stage that can fail (DESIGN.md).
enum class ExitCode : int {
  kOk = 0,
  kUsage = 1,
  kInvalidInput = 2,
  kUnsupported = 3,
  kCannotWrite = 4,
  kNotConverged = 5,  // only with --strict: the solve stopped before its tolerance
};

// At most this many characters in a message: a hostile file must not turn one line into megabytes.
constexpr size_t kMaxMessageLength = 400;

// `text` as one bounded line: the first line only, control characters dropped, cut to `limit`
// characters (with "..." at the cut). Every Error message goes through it.
std::string oneLine(const std::string& text, size_t limit = kMaxMessageLength);

// A failure that ends the run: one line naming the file and the element, and the exit code.
class Error : public std::runtime_error {
 public:
  Error(ExitCode code, const std::string& message) : std::runtime_error(oneLine(message)), code_(code) {}
  ExitCode code() const { return code_; }

 private:
  ExitCode code_;
};

// ---- Files ---------------------------------------------------------------------------------

// Reads a regular file whole, refusing anything else before a byte is read: a FIFO (which would
// block), a device (/dev/zero never ends), a directory, or a file past `maxBytes`. Errors are
// kInvalidInput ("<what>: not a regular file (a FIFO)", "<what>: cannot open: no such file"), or
// kUnsupported when it is larger than `maxBytes`. `what` names the file in messages.
std::vector<unsigned char> readRegularFile(const std::string& path, const std::string& what, uint64_t maxBytes);

// Why `path` cannot be read as a regular file ("not a regular file (a FIFO)", "no such file"), or ""
// when it can. Does not open it, so it never blocks.
std::string regularFileProblem(const std::string& path);

// ---- Memory --------------------------------------------------------------------------------

// The machine's physical memory in bytes (the default of --max-memory), or 8 GiB when unknown.
uint64_t physicalMemoryBytes();

// "2G", "512M", "1.5GiB", "4096" (bytes) → bytes; nullopt for anything else (negative, NaN, junk).
std::optional<uint64_t> parseByteSize(const std::string& text);

// "1.5 GiB", "12 MiB", "512 bytes": for messages.
std::string formatBytes(double bytes);

// Writes `bytes` to `path` atomically: a temporary file beside it, then rename.
void writeFileAtomically(const std::string& path, const std::string& bytes);

// Writes several files all or nothing: every temporary first, then the renames; on any failure
// nothing of them is left behind (Error kCannotWrite naming the file).
void writeFilesAtomically(const std::vector<std::pair<std::string, std::string>>& files);

// The extension of `path` with its dot, lowercased ("a/B.GLB" → ".glb"; "" without one): what
// decides a file's format.
std::string lowerExtension(const std::string& path);

// ---- Color ---------------------------------------------------------------------------------

// The sRGB transfer function (IEC 61966-2-1), code value → linear. A template so that each caller
// keeps its precision: the exporter decodes in double, the texture decoder fills a float table.
template <typename T>
T srgbDecode(T code) {
  return code <= T(0.04045) ? code / T(12.92) : std::pow((code + T(0.055)) / T(1.055), T(2.4));
}

// The sRGB transfer function, linear → code value.
double srgbEncode(double linear);

}  // namespace radbake

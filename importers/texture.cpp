// Color textures: decoding (stb_image, Debian's libstb) and sampling.
#include <stb/stb_image.h>

#include <algorithm>
#include <cmath>

#include "core/core.h"
#include "importers/importers.h"
#include "importers/texture.h"

namespace radbake {
namespace {

constexpr int kClampToEdge = 33071;
constexpr int kMirroredRepeat = 33648;

int wrap(int i, int n, int mode) {
  if (mode == kClampToEdge) return std::clamp(i, 0, n - 1);
  if (mode == kMirroredRepeat) {
    const int period = 2 * n;
    int m = ((i % period) + period) % period;
    return m < n ? m : period - 1 - m;
  }
  return ((i % n) + n) % n;
}

}  // namespace

bool imageDimensions(const std::vector<unsigned char>& encoded, int& width, int& height) {
  int channels = 0;
  if (encoded.empty() || encoded.size() > size_t(INT32_MAX)) return false;
  return stbi_info_from_memory(encoded.data(), int(encoded.size()), &width, &height, &channels) == 1;
}

std::string implausibleImage(const std::vector<unsigned char>& encoded, int width, int height) {
  static const unsigned char kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  const double pixels = double(width) * height;
  double limit = 0;  // the most raw bytes the file's size can encode
  double raw = 0;
  if (encoded.size() >= 29 && std::equal(kPng, kPng + 8, encoded.begin())) {
    const int depth = encoded[24], colorType = encoded[25];
    const int channels = colorType == 2 ? 3 : colorType == 4 ? 2 : colorType == 6 ? 4 : 1;
    raw = double(height) * (1 + std::ceil(double(width) * channels * depth / 8));
    limit = 1032.0 * double(encoded.size()) + 65536;  // deflate's largest ratio, with room for headers
  } else {
    raw = pixels / 64;  // JPEG and the rest: at least about one bit per 8×8 block
    limit = 8.0 * double(encoded.size()) + 65536;
  }
  if (raw <= limit) return "";
  return "its header claims " + std::to_string(width) + "x" + std::to_string(height) + " pixels, more than its " +
         std::to_string(encoded.size()) + " bytes can hold (truncated or a decompression bomb)";
}

bool decodeColorTexture(const std::vector<unsigned char>& encoded, Texture& out, std::string& error) {
  int w = 0, h = 0, channels = 0;
  if (encoded.empty() || encoded.size() > size_t(INT32_MAX)) {
    error = "empty or oversized image";
    return false;
  }
  stbi_uc* pixels = stbi_load_from_memory(encoded.data(), int(encoded.size()), &w, &h, &channels, 4);
  if (!pixels) {
    error = stbi_failure_reason() ? stbi_failure_reason() : "cannot decode";
    return false;
  }
  out.width = w;
  out.height = h;
  out.rgb.resize(size_t(w) * h * 3);
  out.alpha.resize(size_t(w) * h);
  float table[256];
  for (int i = 0; i < 256; ++i) table[i] = srgbDecode<float>(i / 255.0f);
  for (size_t i = 0; i < out.alpha.size(); ++i) {
    for (int c = 0; c < 3; ++c) out.rgb[3 * i + c] = table[pixels[4 * i + c]];
    out.alpha[i] = pixels[4 * i + 3] / 255.0f;  // alpha is linear in glTF
  }
  stbi_image_free(pixels);
  return true;
}

// Texture coordinates after KHR_texture_transform, brought near the origin (period 2 keeps
// mirrored repeat right) so texel indices fit an int; false for non-finite coordinates.
static bool transformUV(const TextureRef& ref, double u, double v, double& tu, double& tv) {
  const double c = std::cos(ref.rotation), s = std::sin(ref.rotation);
  const double su = u * ref.scale[0], sv = v * ref.scale[1];
  tu = c * su + s * sv + ref.offset[0];
  tv = -s * su + c * sv + ref.offset[1];
  if (!std::isfinite(tu) || !std::isfinite(tv)) return false;
  if (std::abs(tu) > 1e6) tu = std::fmod(tu, 2.0);
  if (std::abs(tv) > 1e6) tv = std::fmod(tv, 2.0);
  return true;
}

static const Texture* textureOf(const Scene& scene, const TextureRef& ref) {
  if (ref.texture < 0 || ref.texture >= int(scene.textures.size())) return nullptr;
  const Texture& t = scene.textures[ref.texture];
  return t.width > 0 && t.height > 0 ? &t : nullptr;
}

Vec3 sampleTexture(const Scene& scene, const TextureRef& ref, double u, double v) {
  const Texture* tex = textureOf(scene, ref);
  double tu, tv;
  if (!tex || !transformUV(ref, u, v, tu, tv)) return {1, 1, 1};
  const Texture& t = *tex;
  // Texel centres at (i + 0.5) / width; bilinear filtering.
  const double x = tu * t.width - 0.5, y = tv * t.height - 0.5;
  const double fx = std::floor(x), fy = std::floor(y);
  const double ax = x - fx, ay = y - fy;
  auto texel = [&](int i, int j) {
    const size_t k = (size_t(wrap(j, t.height, t.wrapT)) * t.width + wrap(i, t.width, t.wrapS)) * 3;
    return Vec3{t.rgb[k], t.rgb[k + 1], t.rgb[k + 2]};
  };
  const int i = int(fx), j = int(fy);
  return texel(i, j) * ((1 - ax) * (1 - ay)) + texel(i + 1, j) * (ax * (1 - ay)) + texel(i, j + 1) * ((1 - ax) * ay) +
         texel(i + 1, j + 1) * (ax * ay);
}

double sampleAlpha(const Scene& scene, const TextureRef& ref, double u, double v) {
  const Texture* tex = textureOf(scene, ref);
  double tu, tv;
  if (!tex || tex->alpha.empty() || !transformUV(ref, u, v, tu, tv)) return 1;
  const int i = wrap(int(std::floor(tu * tex->width)), tex->width, tex->wrapS);
  const int j = wrap(int(std::floor(tv * tex->height)), tex->height, tex->wrapT);
  return tex->alpha[size_t(j) * tex->width + i];
}

}  // namespace radbake

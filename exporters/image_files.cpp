#include "exporters/image_files.h"

#include <ImfHeader.h>
#include <ImfRgbaFile.h>
#include <ImfStdIO.h>
#include <stb/stb_image_write.h>

#include <algorithm>

namespace radbake {

std::string encodeExrHalfRgb(int width, int height, const std::vector<float>& rgb) {
  std::vector<Imf::Rgba> pixels(size_t(width) * height);
  for (size_t i = 0; i < pixels.size(); ++i) {
    auto toHalf = [](float v) { return half(std::clamp(v, -65504.0f, 65504.0f)); };
    pixels[i] = Imf::Rgba(toHalf(rgb[3 * i]), toHalf(rgb[3 * i + 1]), toHalf(rgb[3 * i + 2]), half(1.0f));
  }
  Imf::StdOSStream stream;
  {
    Imf::Header header(width, height);
    header.compression() = Imf::ZIP_COMPRESSION;
    Imf::RgbaOutputFile file(stream, header, Imf::WRITE_RGB);
    file.setFrameBuffer(pixels.data(), 1, size_t(width));
    file.writePixels(height);
  }  // the file object finishes the EXR (its offset table) when it closes
  return stream.str();
}

std::string encodePng(int width, int height, const std::vector<uint8_t>& rgb) {
  std::string out;
  stbi_write_png_to_func(
      [](void* context, void* data, int size) { static_cast<std::string*>(context)->append(static_cast<char*>(data), size); },
      &out, width, height, 3, rgb.data(), width * 3);
  return out;
}

}  // namespace radbake

// radbake-draco-decode FILE: decodes one KHR_draco_mesh_compression buffer (FILE) and writes the
// mesh to stdout: "RBDR", u32 points, u32 faces, u32 attributes, then per attribute u32 unique id,
// u32 components and points×components f32 (normalized integers mapped as Draco maps them), then
// faces×3 u32 indices. Exit 1 with one line on stderr when it cannot.
//
// Why a separate program: Debian's libdraco carries its own copy of tinygltf, which takes over
// radbake's tinygltf symbols when both are linked into one process.
#include <draco/compression/decode.h>

#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <iterator>
#include <vector>

namespace {

void put(std::vector<char>& out, uint32_t v) { out.insert(out.end(), reinterpret_cast<char*>(&v), reinterpret_cast<char*>(&v) + 4); }

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: radbake-draco-decode FILE\n";
    return 1;
  }
  std::ifstream in(argv[1], std::ios::binary);
  const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), {});
  draco::DecoderBuffer buffer;
  buffer.Init(bytes.data(), bytes.size());
  draco::Decoder decoder;
  auto result = decoder.DecodeMeshFromBuffer(&buffer);
  if (!result.ok()) {
    std::cerr << result.status().error_msg_string() << "\n";
    return 1;
  }
  const std::unique_ptr<draco::Mesh> mesh = std::move(result).value();
  std::vector<char> out{'R', 'B', 'D', 'R'};
  put(out, mesh->num_points());
  put(out, mesh->num_faces());
  put(out, uint32_t(mesh->num_attributes()));
  for (int a = 0; a < mesh->num_attributes(); ++a) {
    const draco::PointAttribute* att = mesh->attribute(a);
    const int components = att->num_components();
    put(out, att->unique_id());
    put(out, uint32_t(components));
    std::vector<float> values(static_cast<size_t>(components));
    for (draco::PointIndex p(0); p < mesh->num_points(); ++p) {
      if (!att->ConvertValue<float>(att->mapped_index(p), int8_t(components), values.data())) {
        std::cerr << "attribute " << att->unique_id() << " cannot be read as numbers\n";
        return 1;
      }
      out.insert(out.end(), reinterpret_cast<char*>(values.data()), reinterpret_cast<char*>(values.data() + components));
    }
  }
  for (draco::FaceIndex f(0); f < mesh->num_faces(); ++f)
    for (int k = 0; k < 3; ++k) put(out, mesh->face(f)[k].value());
  std::fwrite(out.data(), 1, out.size(), stdout);
  return std::fflush(stdout) == 0 ? 0 : 1;
}

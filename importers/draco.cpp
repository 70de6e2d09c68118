#include "importers/draco.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "importers/gltf_document.h"

namespace radbake {
namespace {

constexpr const char* kDraco = "KHR_draco_mesh_compression";

#ifndef RADBAKE_DRACO_DECODER_BUILT
#define RADBAKE_DRACO_DECODER_BUILT ""
#endif

// The helper: $RADBAKE_DRACO_DECODER, else beside the running program, else where the build put it.
std::string decoderPath() {
  if (const char* env = std::getenv("RADBAKE_DRACO_DECODER"); env && *env) return env;
  std::error_code ec;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const auto beside = self.parent_path() / "radbake-draco-decode";
    if (std::filesystem::exists(beside, ec)) return beside.string();
  }
  return RADBAKE_DRACO_DECODER_BUILT;
}

struct DecodedMesh {
  uint32_t points = 0, faces = 0;
  std::vector<std::pair<uint32_t, std::pair<uint32_t, std::vector<float>>>> attributes;  // id → (components, values)
  std::vector<uint32_t> indices;
};

// Runs the helper on the compressed bytes; "" on success.
std::string runDecoder(const unsigned char* data, size_t size, DecodedMesh& mesh) {
  const std::string helper = decoderPath();
  std::error_code ec;
  if (helper.empty() || !std::filesystem::exists(helper, ec)) return "the decoder radbake-draco-decode is not installed";
  const auto temp = std::filesystem::temp_directory_path(ec) / ("radbake-draco-" + std::to_string(::getpid()) + ".drc");
  {
    std::ofstream out(temp, std::ios::binary);
    out.write(reinterpret_cast<const char*>(data), std::streamsize(size));
    if (!out) return "cannot write a temporary file";
  }
  const std::string command = "'" + helper + "' '" + temp.string() + "' 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  std::vector<unsigned char> bytes;
  if (pipe) {
    unsigned char chunk[65536];
    size_t n;
    while ((n = fread(chunk, 1, sizeof chunk, pipe)) > 0) bytes.insert(bytes.end(), chunk, chunk + n);
  }
  const int status = pipe ? pclose(pipe) : -1;
  std::filesystem::remove(temp, ec);
  if (status != 0 || bytes.size() < 16 || std::memcmp(bytes.data(), "RBDR", 4) != 0) {
    std::string message(bytes.begin(), bytes.end());
    message = message.substr(0, message.find('\n'));
    return "cannot decode (" + (message.empty() ? std::string("the decoder failed") : message) + ")";
  }
  size_t at = 4;
  auto u32 = [&](uint32_t& v) {
    if (at + 4 > bytes.size()) return false;
    std::memcpy(&v, &bytes[at], 4);
    at += 4;
    return true;
  };
  uint32_t count = 0;
  if (!u32(mesh.points) || !u32(mesh.faces) || !u32(count)) return "truncated decoder output";
  for (uint32_t a = 0; a < count; ++a) {
    uint32_t id = 0, components = 0;
    if (!u32(id) || !u32(components) || components == 0 || components > 16) return "bad decoder output";
    const size_t floats = size_t(mesh.points) * components;
    if (at + floats * 4 > bytes.size()) return "truncated decoder output";
    std::vector<float> values(floats);
    std::memcpy(values.data(), &bytes[at], floats * 4);
    at += floats * 4;
    mesh.attributes.push_back({id, {components, std::move(values)}});
  }
  mesh.indices.resize(size_t(mesh.faces) * 3);
  if (at + mesh.indices.size() * 4 > bytes.size()) return "truncated decoder output";
  std::memcpy(mesh.indices.data(), &bytes[at], mesh.indices.size() * 4);
  for (uint32_t i : mesh.indices)
    if (i >= mesh.points) return "decoded index out of range";
  return "";
}

void alignTo4(std::vector<unsigned char>& bytes) { bytes.resize((bytes.size() + 3) & ~size_t(3), 0); }

template <typename T>
void append(std::vector<unsigned char>& out, T v) {
  out.insert(out.end(), reinterpret_cast<const unsigned char*>(&v), reinterpret_cast<const unsigned char*>(&v) + sizeof v);
}

// Writes decoded floats as the accessor's component type (normalized integers scaled back).
void appendAs(std::vector<unsigned char>& out, const tinygltf::Accessor& acc, float v) {
  auto integer = [&](double max) { return acc.normalized ? std::round(std::clamp(double(v), -max, max) * max) : std::round(double(v)); };
  switch (acc.componentType) {
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: append(out, uint8_t(std::clamp(integer(255), 0.0, 255.0))); break;
    case TINYGLTF_COMPONENT_TYPE_BYTE: append(out, int8_t(std::clamp(integer(127), -128.0, 127.0))); break;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: append(out, uint16_t(std::clamp(integer(65535), 0.0, 65535.0))); break;
    case TINYGLTF_COMPONENT_TYPE_SHORT: append(out, int16_t(std::clamp(integer(32767), -32768.0, 32767.0))); break;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: append(out, uint32_t(std::clamp(integer(4294967295.0), 0.0, 4294967295.0))); break;
    default: append(out, v); break;
  }
}

}  // namespace

std::string decodeDracoPrimitives(tinygltf::Model& m) {
  std::vector<unsigned char> decoded;
  const int buffer = int(m.buffers.size());
  bool any = false;
  for (size_t mi = 0; mi < m.meshes.size(); ++mi)
    for (size_t pi = 0; pi < m.meshes[mi].primitives.size(); ++pi) {
      tinygltf::Primitive& prim = m.meshes[mi].primitives[pi];
      auto ext = prim.extensions.find(kDraco);
      if (ext == prim.extensions.end()) continue;
      const std::string what = "mesh " + std::to_string(mi) + " primitive " + std::to_string(pi) + " " + kDraco;
      const tinygltf::Value& viewValue = ext->second.Get("bufferView");
      const int view = viewValue.IsInt() || viewValue.IsNumber() ? int(viewValue.GetNumberAsDouble()) : -1;
      if (view < 0 || view >= int(m.bufferViews.size())) return what + ": bufferView missing or out of range";
      const tinygltf::BufferView& bv = m.bufferViews[view];
      if (bv.buffer < 0 || bv.buffer >= int(m.buffers.size()) || bv.byteOffset + bv.byteLength > m.buffers[bv.buffer].data.size())
        return what + ": buffer view " + std::to_string(view) + " is outside its buffer";
      DecodedMesh mesh;
      if (std::string problem = runDecoder(m.buffers[bv.buffer].data.data() + bv.byteOffset, bv.byteLength, mesh); !problem.empty())
        return what + ": " + problem;

      const tinygltf::Value& attributes = ext->second.Get("attributes");
      for (auto& [semantic, accessorIndex] : prim.attributes) {
        const tinygltf::Value& id = attributes.Get(semantic);
        if (!(id.IsInt() || id.IsNumber())) continue;  // not compressed: stays as it is
        auto found = std::find_if(mesh.attributes.begin(), mesh.attributes.end(),
                                  [&](const auto& a) { return a.first == uint32_t(id.GetNumberAsDouble()); });
        if (found == mesh.attributes.end() || accessorIndex < 0 || accessorIndex >= int(m.accessors.size()))
          return what + ": attribute " + semantic + " is not in the compressed data";
        tinygltf::Accessor& acc = m.accessors[accessorIndex];
        const uint32_t components = uint32_t(tinygltf::GetNumComponentsInType(acc.type));
        if (components != found->second.first) return what + ": attribute " + semantic + " has the wrong number of components";
        alignTo4(decoded);
        const size_t offset = decoded.size();
        for (float v : found->second.second) appendAs(decoded, acc, v);
        tinygltf::BufferView out;
        out.buffer = buffer;
        out.byteOffset = offset;
        out.byteLength = decoded.size() - offset;
        out.target = TINYGLTF_TARGET_ARRAY_BUFFER;
        m.bufferViews.push_back(out);
        acc.bufferView = int(m.bufferViews.size()) - 1;
        acc.byteOffset = 0;
        acc.count = mesh.points;
        acc.sparse = {};
        // The file's bounds describe the data before compression; glTF wants them exact for the
        // data now in the buffer (float accessors; integer ones lose them, where they are optional).
        acc.minValues.clear();
        acc.maxValues.clear();
        if (acc.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT && mesh.points > 0)
          setAccessorBounds(acc, found->second.second, int(components));
      }
      alignTo4(decoded);
      tinygltf::BufferView iv;
      iv.buffer = buffer;
      iv.byteOffset = decoded.size();
      for (uint32_t i : mesh.indices) append(decoded, i);
      iv.byteLength = decoded.size() - iv.byteOffset;
      iv.target = TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER;
      m.bufferViews.push_back(iv);
      tinygltf::Accessor ia;
      ia.bufferView = int(m.bufferViews.size()) - 1;
      ia.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
      ia.type = TINYGLTF_TYPE_SCALAR;
      ia.count = mesh.indices.size();
      m.accessors.push_back(ia);
      prim.indices = int(m.accessors.size()) - 1;
      prim.extensions.erase(ext);
      any = true;
    }
  if (any) {
    tinygltf::Buffer b;
    b.data = std::move(decoded);
    m.buffers.push_back(std::move(b));
    for (auto* list : {&m.extensionsUsed, &m.extensionsRequired})
      list->erase(std::remove(list->begin(), list->end(), std::string(kDraco)), list->end());
  }
  return "";
}

}  // namespace radbake

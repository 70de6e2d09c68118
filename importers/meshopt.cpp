#include "importers/meshopt.h"

#include <algorithm>
#include <cmath>
#include <set>

#include <meshoptimizer.h>
#include <nlohmann/json.hpp>

namespace radbake {
namespace {

constexpr const char* kMeshopt = "EXT_meshopt_compression";
constexpr const char* kMeshoptKhr = "KHR_meshopt_compression";
constexpr const char* kStubUri = "data:application/octet-stream;base64,AA==";  // one zero byte

// No meshopt stream decodes to more than this many times its own length: the attribute codec
// spends at least 2 header bits on every 16 bytes it writes (64:1), the triangle codec a byte per
// triangle (at most 12 bytes of indices), the index codec a byte per index (at most 4 bytes). A
// larger claim is corrupt, and is refused before anything is allocated for it.
constexpr uint64_t kMaxExpansion = 64;

// A non-negative whole number from the extension's JSON (tinygltf keeps it as int or double).
bool wholeNumber(const tinygltf::Value& v, uint64_t& out) {
  if (!v.IsNumber()) return false;
  const double d = v.GetNumberAsDouble();
  if (!(d >= 0 && d <= 9007199254740992.0 && d == std::floor(d))) return false;
  out = uint64_t(d);
  return true;
}

}  // namespace

std::string withMeshoptFallbacksStubbed(const std::string& jsonText) {
  nlohmann::json doc = nlohmann::json::parse(jsonText);
  if (!doc.contains("buffers") || !doc.contains("bufferViews")) return "";
  auto& buffers = doc["buffers"];
  std::vector<int> compressedRefs(buffers.size(), 0), plainRefs(buffers.size(), 0);
  std::set<size_t> imageViews;
  for (const auto& image : doc.value("images", nlohmann::json::array()))
    if (image.contains("bufferView")) imageViews.insert(image["bufferView"].get<size_t>());
  std::set<size_t> keep;  // buffers whose bytes are read: an image's, or compressed data's
  const auto& views = doc["bufferViews"];
  for (size_t i = 0; i < views.size(); ++i) {
    const size_t b = views[i]["buffer"].get<size_t>();  // checkGltfSchema: present and in range
    const nlohmann::json* ext = nullptr;
    if (views[i].contains("extensions") && views[i]["extensions"].contains(kMeshopt)) ext = &views[i]["extensions"][kMeshopt];
    ++(ext ? compressedRefs : plainRefs)[b];
    if (imageViews.count(i)) keep.insert(b);
    if (ext && ext->contains("buffer") && (*ext)["buffer"].is_number_unsigned()) keep.insert((*ext)["buffer"].get<size_t>());
  }
  bool changed = false;
  for (size_t b = 0; b < buffers.size(); ++b) {
    auto& buffer = buffers[b];
    const nlohmann::json* tag = nullptr;
    if (buffer.contains("extensions") && buffer["extensions"].contains(kMeshopt)) tag = &buffer["extensions"][kMeshopt];
    const bool tagged = tag && tag->contains("fallback") && (*tag)["fallback"] == true;
    if (keep.count(b) || !(tagged || (compressedRefs[b] > 0 && plainRefs[b] == 0))) continue;
    buffer["uri"] = kStubUri;
    buffer["byteLength"] = 1;
    changed = true;
  }
  return changed ? doc.dump() : "";
}

std::string decodeMeshoptBufferViews(tinygltf::Model& m) {
  std::vector<unsigned char> decoded;
  const int target = int(m.buffers.size());
  std::set<int> emptied;  // fallback and compressed buffers, emptied unless a plain view still uses them
  bool any = false;
  for (size_t i = 0; i < m.bufferViews.size(); ++i) {
    tinygltf::BufferView& view = m.bufferViews[i];
    const std::string name = "buffer view " + std::to_string(i);
    const bool stub = view.buffer >= 0 && view.buffer < target && m.buffers[view.buffer].uri == kStubUri;
    if (auto khr = view.extensions.find(kMeshoptKhr); khr != view.extensions.end()) {
      // Only used, never required (that is refused): the view's own buffer holds the plain data.
      uint64_t source = 0;
      if (wholeNumber(khr->second.Get("buffer"), source) && source < uint64_t(target)) emptied.insert(int(source));
      view.extensions.erase(khr);
      any = true;
    }
    auto ext = view.extensions.find(kMeshopt);
    if (ext == view.extensions.end()) {
      if (stub)
        return name + ": not compressed, but in buffer " + std::to_string(view.buffer) + ", an " + kMeshopt +
               " fallback buffer, whose data radbake does not load";
      continue;
    }
    const std::string what = name + " " + kMeshopt;
    const tinygltf::Value& e = ext->second;
    uint64_t buffer = 0, offset = 0, length = 0, stride = 0, count = 0;
    if (!wholeNumber(e.Get("buffer"), buffer) || !wholeNumber(e.Get("byteLength"), length) ||
        !wholeNumber(e.Get("byteStride"), stride) || !wholeNumber(e.Get("count"), count) ||
        (e.Has("byteOffset") && !wholeNumber(e.Get("byteOffset"), offset)))
      return what + ": buffer, byteLength, byteStride and count must be non-negative integers (and byteOffset, if given)";
    const std::string mode = e.Get("mode").IsString() ? e.Get("mode").Get<std::string>() : "";
    const std::string filter = e.Has("filter") ? (e.Get("filter").IsString() ? e.Get("filter").Get<std::string>() : "?") : "NONE";
    if (mode != "ATTRIBUTES" && mode != "TRIANGLES" && mode != "INDICES")
      return what + ": mode must be ATTRIBUTES, TRIANGLES or INDICES";
    if (filter != "NONE" && filter != "OCTAHEDRAL" && filter != "QUATERNION" && filter != "EXPONENTIAL")
      return what + ": filter must be NONE, OCTAHEDRAL, QUATERNION or EXPONENTIAL";
    if (buffer >= m.buffers.size() || m.buffers[buffer].uri == kStubUri)
      return what + ": buffer " + std::to_string(buffer) + " does not exist or is a fallback buffer";
    const auto& source = m.buffers[buffer].data;
    if (offset > source.size() || length > source.size() - offset)
      return what + ": bytes " + std::to_string(offset) + ".." + std::to_string(offset + length) + " exceed buffer " +
             std::to_string(buffer) + " length " + std::to_string(source.size());
    // The extension's own rules; the decoders assert them, so they are checked first.
    if (mode == "ATTRIBUTES" && (stride == 0 || stride % 4 != 0 || stride > 256))
      return what + ": ATTRIBUTES byteStride " + std::to_string(stride) + " is not a multiple of 4 up to 256";
    if (mode != "ATTRIBUTES" && stride != 2 && stride != 4)
      return what + ": " + mode + " byteStride " + std::to_string(stride) + " must be 2 or 4";
    if (mode == "TRIANGLES" && count % 3 != 0) return what + ": TRIANGLES count " + std::to_string(count) + " is not a multiple of 3";
    if (mode != "ATTRIBUTES" && filter != "NONE") return what + ": " + mode + " data takes no filter";
    if ((filter == "OCTAHEDRAL" && stride != 4 && stride != 8) || (filter == "QUATERNION" && stride != 8))
      return what + ": filter " + filter + " does not take byteStride " + std::to_string(stride);
    if (view.byteStride != 0 && view.byteStride != stride)
      return what + ": byteStride " + std::to_string(stride) + " differs from the buffer view's " + std::to_string(view.byteStride);
    // stride ≤ 256 and count < 2^53: the product cannot overflow.
    if (count * stride != view.byteLength)
      return what + ": count " + std::to_string(count) + " × byteStride " + std::to_string(stride) + " is not the buffer view's byteLength " +
             std::to_string(view.byteLength);
    if (view.byteLength > kMaxExpansion * length)
      return what + ": " + std::to_string(length) + " compressed bytes cannot hold " + std::to_string(view.byteLength) + " bytes";

    decoded.resize((decoded.size() + 3) & ~size_t(3), 0);
    const size_t at = decoded.size();
    decoded.resize(at + view.byteLength);
    unsigned char* out = decoded.data() + at;
    const unsigned char* in = source.data() + offset;
    int rc = 0;
    if (mode == "ATTRIBUTES") rc = meshopt_decodeVertexBuffer(out, count, stride, in, length);
    else if (mode == "TRIANGLES") rc = meshopt_decodeIndexBuffer(out, count, stride, in, length);
    else rc = meshopt_decodeIndexSequence(out, count, stride, in, length);
    if (rc != 0) return what + ": the " + mode + " data is corrupt (meshoptimizer cannot decode it, code " + std::to_string(rc) + ")";
    if (filter == "OCTAHEDRAL") meshopt_decodeFilterOct(out, count, stride);
    if (filter == "QUATERNION") meshopt_decodeFilterQuat(out, count, stride);
    if (filter == "EXPONENTIAL") meshopt_decodeFilterExp(out, count, stride);

    emptied.insert(view.buffer);
    emptied.insert(int(buffer));
    view.buffer = target;
    view.byteOffset = at;
    view.extensions.erase(ext);
    any = true;
  }
  if (!any) return "";
  tinygltf::Buffer b;
  b.data = std::move(decoded);
  m.buffers.push_back(std::move(b));
  for (const auto& view : m.bufferViews) emptied.erase(view.buffer);
  for (int i : emptied)
    if (i >= 0 && i < target) m.buffers[i].data.clear();
  for (auto& buffer : m.buffers) {
    buffer.extensions.erase(kMeshopt);
    buffer.extensions.erase(kMeshoptKhr);
  }
  for (auto* list : {&m.extensionsUsed, &m.extensionsRequired})
    std::erase_if(*list, [](const std::string& ext) { return ext == kMeshopt || ext == kMeshoptKhr; });
  return "";
}

}  // namespace radbake

// Internal to importers/: EXT_meshopt_compression (gltfpack -c/-cc, the usual compression of web
// assets), decoded with Debian's libmeshoptimizer.
#pragma once

#include <string>

#include <tiny_gltf.h>

namespace radbake {

// Before tinygltf parses the JSON: a fallback buffer (tagged "fallback": true, or referenced only by
// compressed buffer views) holds no data radbake needs, often has no uri (tinygltf 2.7 then refuses a
// .gltf, or takes the GLB's BIN chunk for it) or names a file nobody shipped. Each becomes a 1-byte
// stand-in, so nothing is loaded for it. Buffers an image points into are left alone (tinygltf hands
// those bytes to the image loader unchecked). Returns the changed JSON, or "" when nothing changed.
std::string withMeshoptFallbacksStubbed(const std::string& jsonText);

// Decodes every compressed buffer view of `model` in place: the decoded bytes go into a new buffer,
// the view points at them and loses the extension, buffers left with nothing pointing at them are
// emptied, and EXT_meshopt_compression leaves extensionsUsed/extensionsRequired, so the rest of
// radbake (and the written output) sees plain glTF. KHR_meshopt_compression, when only used, is
// dropped the same way (its uncompressed fallback data is read). Returns "" or one line naming the
// buffer view that could not be decoded.
std::string decodeMeshoptBufferViews(tinygltf::Model& model);

}  // namespace radbake

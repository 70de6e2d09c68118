// Internal to importers/: the one way a glTF's buffers and images are found on disk.
//
// A file read from the internet may name any path in its URIs; a bake that follows them could copy
// another user's data into an output shared onward. So URIs are resolved against the asset's own
// folder only (never the working directory), and "..", absolute paths, URI schemes, symlinks that
// leave the folder and anything but a regular file are refused, unless the user allows paths
// outside (--allow-outside-paths). tinygltf reads through the same rules (its FsCallbacks).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

namespace tinygltf {
class TinyGLTF;
}

namespace radbake {

struct AssetFolder {
  std::filesystem::path folder;  // the asset's folder, absolute and canonical
  bool allowOutside = false;
  uint64_t maxBytes = 0;         // no file larger than this is read (the memory budget)
};

// The folder of the asset at `assetPath` (which need not exist: fuzzing reads from memory).
AssetFolder assetFolderOf(const std::string& assetPath, bool allowOutside, uint64_t maxBytes);

// The file `uri` names (percent-decoded as tinygltf decodes it), in `path`; or why it may not be
// read, as "uri \"...\" ..." for a message naming the element.
// `outside` tells whether an allowed path lies outside the folder (worth a warning).
std::string resolveAssetUri(const AssetFolder& folder, const std::string& uri, std::string& path, bool& outside);

// Makes `loader` open files only through these rules; `folder` must outlive the loader's use.
void readAssetFilesThrough(tinygltf::TinyGLTF& loader, const AssetFolder* folder);

}  // namespace radbake

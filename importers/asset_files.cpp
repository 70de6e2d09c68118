#include "importers/asset_files.h"

#include <tiny_gltf.h>

#include <algorithm>

#include "core/core.h"

namespace radbake {
namespace {

namespace fs = std::filesystem;

int hexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// Percent-decoding as tinygltf 2.7 does it ('+' is a space), so that what we check is what it opens;
// unlike it, a malformed escape is refused instead of decoded to an arbitrary byte.
bool decodeUri(const std::string& uri, std::string& out) {
  out.clear();
  for (size_t i = 0; i < uri.size(); ++i) {
    if (uri[i] == '+') {
      out += ' ';
    } else if (uri[i] == '%') {
      if (i + 2 >= uri.size() || hexValue(uri[i + 1]) < 0 || hexValue(uri[i + 2]) < 0) return false;
      out += char(hexValue(uri[i + 1]) * 16 + hexValue(uri[i + 2]));
      i += 2;
    } else {
      out += uri[i];
    }
  }
  return out.find('\0') == std::string::npos;
}

// A URI scheme ("file:", "http:"): letters, digits, "+-." then a colon before any slash.
bool hasScheme(const std::string& uri) {
  const size_t colon = uri.find(':');
  if (colon == std::string::npos || colon == 0 || !std::isalpha(static_cast<unsigned char>(uri[0]))) return false;
  return std::all_of(uri.begin(), uri.begin() + colon,
                     [](unsigned char c) { return std::isalnum(c) || c == '+' || c == '-' || c == '.'; });
}

bool inside(const fs::path& folder, const fs::path& file) {
  std::error_code ec;
  const fs::path real = fs::weakly_canonical(file, ec);
  if (ec) return false;
  auto [f, r] = std::mismatch(folder.begin(), folder.end(), real.begin(), real.end());
  return f == folder.end();
}

std::string quoted(const std::string& uri) { return "uri \"" + oneLine(uri, 80) + "\""; }

bool fileExists(const std::string& path, void* user) {
  const AssetFolder& folder = *static_cast<const AssetFolder*>(user);
  // Every path we let tinygltf form is absolute (base folder + URI); its second try, "./" + URI,
  // is the working directory, which is never searched.
  if (!fs::path(path).is_absolute()) return false;
  return (folder.allowOutside || inside(folder.folder, path)) && regularFileProblem(path).empty();
}

bool readWholeFile(std::vector<unsigned char>* out, std::string* err, const std::string& path, void* user) {
  const AssetFolder& folder = *static_cast<const AssetFolder*>(user);
  if (!fileExists(path, user)) {
    if (err) *err = "refused";
    return false;
  }
  try {
    *out = readRegularFile(path, path, folder.maxBytes);
    return true;
  } catch (const Error& e) {
    if (err) *err = e.what();
    return false;
  }
}

// No ~ or $VAR expansion. tinygltf joins the base folder and the URI even when the URI is an
// absolute path (allowed with --allow-outside-paths): "/base" + "/" + "/abs/x.bin"; undo that join.
std::string expandFilePath(const std::string& path, void* user) {
  const std::string base = static_cast<const AssetFolder*>(user)->folder.string() + "/";
  if (path.size() > base.size() && path.compare(0, base.size(), base) == 0 && path[base.size()] == '/')
    return path.substr(base.size());
  return path;
}

bool refuseWrite(std::string* err, const std::string&, const std::vector<unsigned char>&, void*) {
  if (err) *err = "the importer writes nothing";
  return false;
}

}  // namespace

AssetFolder assetFolderOf(const std::string& assetPath, bool allowOutside, uint64_t maxBytes) {
  std::error_code ec;
  fs::path folder = fs::absolute(fs::path(assetPath), ec).parent_path();
  const fs::path real = fs::weakly_canonical(folder, ec);
  return {ec ? folder : real, allowOutside, maxBytes};
}

std::string resolveAssetUri(const AssetFolder& folder, const std::string& uri, std::string& path, bool& outside) {
  std::string decoded;
  if (!decodeUri(uri, decoded)) return quoted(uri) + " has a malformed percent escape";
  if (hasScheme(uri))
    return quoted(uri) + " is not a relative file path (radbake reads neither URLs nor file: URIs)";
  const fs::path relative(decoded);
  if (!folder.allowOutside) {
    if (relative.is_absolute())
      return quoted(uri) + " is an absolute path; radbake reads only files in the asset's folder (--allow-outside-paths lifts this)";
    for (const fs::path& part : relative)
      if (part == "..")
        return quoted(uri) + " leaves the asset's folder (\"..\"); radbake reads only files in it (--allow-outside-paths lifts this)";
  }
  const fs::path full = relative.is_absolute() ? relative : folder.folder / relative;
  path = full.string();
  if (std::string problem = regularFileProblem(path); !problem.empty())
    return quoted(uri) + ": " + (problem == "cannot open: no such file" ? "no such file in the asset's folder" : problem);
  outside = !inside(folder.folder, full);
  if (outside && !folder.allowOutside)
    return quoted(uri) + " is a link leading out of the asset's folder; radbake reads only files in it (--allow-outside-paths lifts this)";
  return "";
}

void readAssetFilesThrough(tinygltf::TinyGLTF& loader, const AssetFolder* folder) {
  tinygltf::FsCallbacks callbacks{};
  callbacks.FileExists = fileExists;
  callbacks.ExpandFilePath = expandFilePath;
  callbacks.ReadWholeFile = readWholeFile;
  callbacks.WriteWholeFile = refuseWrite;
  callbacks.user_data = const_cast<AssetFolder*>(folder);
  loader.SetFsCallbacks(callbacks);
}

}  // namespace radbake

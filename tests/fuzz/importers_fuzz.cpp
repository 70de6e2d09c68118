// libFuzzer target for the glTF importer (and the tessellator behind it): any input must either
// import or fail with a radbake::Error, never crash, hang, leak or trip a sanitizer.
// Build and run: scripts/fuzz.sh [seconds]
#include <cstddef>
#include <cstdint>
#include <vector>

#include "importers/importers.h"
#include "tessellate/tessellate.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::vector<unsigned char> bytes(data, data + size);
  try {
    // A directory that does not exist: external URIs fail cleanly instead of reading the disk.
    radbake::ImportOptions importOptions;
    importOptions.maxMemoryBytes = uint64_t(256) << 20;  // keeps each run small, as --max-memory would
    const radbake::Scene scene = radbake::importGltfBytes(bytes, "/nonexistent-radbake-fuzz/input.glb", importOptions);
    radbake::TessellateOptions tessellateOptions;
    tessellateOptions.maxMemoryBytes = importOptions.maxMemoryBytes;
    radbake::tessellate(scene, tessellateOptions);
  } catch (const radbake::Error&) {
    // the documented failure
  }
  return 0;
}

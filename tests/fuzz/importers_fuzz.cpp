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
    const radbake::Scene scene = radbake::importGltfBytes(bytes, "/nonexistent-radbake-fuzz/input.glb");
    radbake::tessellate(scene);
  } catch (const radbake::Error&) {
    // the documented failure
  }
  return 0;
}

// libFuzzer target for the Bezier patch (.bpt) reader and its tessellation: any text must either
// import and tessellate or fail with a radbake::Error, never crash, hang or trip a sanitizer.
// Build and run: scripts/fuzz.sh [seconds] bpt
#include <cstddef>
#include <cstdint>
#include <string>

#include "importers/bpt_importer.h"
#include "tessellate/tessellate.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    const radbake::Scene scene = radbake::parseBezierPatches(std::string(data, data + size), "input.bpt");
    radbake::TessellateOptions options;
    // Keeps each run small, as --max-memory would: 32 MiB is 32k patches. A teapot mutated into a
    // 187k-patch surface tessellates in 0.9 s in a release build but took over libFuzzer's 20 s
    // under ASan + UBSan (the first 30-minute run reported it as a timeout).
    options.maxMemoryBytes = uint64_t(32) << 20;
    radbake::tessellate(scene, options);
  } catch (const radbake::Error&) {
    // the documented failure
  }
  return 0;
}

// libFuzzer target for the command-line parser: the input is split at NUL bytes into arguments
// ("bake", "in.gltf", "-o", ...). Parsing must give options or a usage message, never crash; and
// every number it accepts must be finite (the validators, not CLI11's ranges, which let NaN by).
// Build and run: scripts/fuzz.sh [seconds] options
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "plugin/cli/cli.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::vector<std::string> args;
  std::string current;
  for (size_t i = 0; i < size; ++i) {
    if (data[i] == 0) {
      args.push_back(current);
      current.clear();
    } else {
      current.push_back(char(data[i]));
    }
  }
  args.push_back(current);
  const radbake::ParseResult parsed = radbake::parseCommandLine(args);
  if (parsed.options) {
    const radbake::Options& o = *parsed.options;
    for (double v : {o.maxEdge, o.maxChord, o.texelSize, o.tolerance, o.exposure.value_or(0)})
      if (!std::isfinite(v)) std::abort();
  } else if (parsed.message.starts_with("error: ") && parsed.message.find('\n') != std::string::npos) {
    std::abort();  // a usage error is one line (a bare "radbake" prints the help instead)
  }
  return 0;
}

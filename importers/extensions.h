// What radbake does with each glTF extension it knows: one table, read by the importer (what is
// accepted when a file requires it, what is said when a file uses it) and listed in README.md.
#pragma once

#include <string>
#include <vector>

namespace radbake {

enum class ExtensionUse {
  kBaked,         // the importer reads it: it changes the light or is decoded into the geometry
  kKept,          // no bearing on a diffuse bake: written back unchanged
  kFallback,      // radbake cannot read it, but the core glTF fallback it comes with is exact
  kApproximated,  // it changes the light or the geometry in ways radbake leaves out: a warning
  kRefused,       // radbake cannot even load a file using it (exit 3)
};

struct KnownExtension {
  std::string name;
  ExtensionUse use;
  std::string note;  // what radbake does with it, for the warning and README's table
};

// Every extension radbake knows, in README order.
const std::vector<KnownExtension>& knownExtensions();

// The entry for `name`, or nullptr for an extension radbake does not know (kept when only used,
// refused when required).
const KnownExtension* findExtension(const std::string& name);

// Baked and kept extensions may be required; the others cannot be honoured and are refused then.
bool acceptedWhenRequired(const std::string& name);

}  // namespace radbake

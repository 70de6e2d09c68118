// exporters: write the bake back into glTF (DESIGN.md "What a baked glTF holds").
//
// The output is the input document with, per baked primitive instance, `_RADIANCE` (linear, exact,
// unclamped) and `COLOR_0` (what a stock viewer shows), everything else written back unchanged. All
// buffers and images end up inside the output (one GLB binary chunk, or data URIs in a .gltf), so
// the result is self-contained. The write is atomic: a temporary file renamed into place.
#pragma once

#include <string>
#include <vector>

#include "importers/importers.h"
#include "tessellate/tessellate.h"

namespace radbake {

struct ExportOptions {
  bool pretty = false;  // indent the JSON of a .gltf
};

struct ExportSummary {
  int bakedPrimitives = 0;
  int clonedMeshes = 0;  // meshes duplicated so that each instance carries its own bake
  long long writtenVertices = 0;
};

// vertexRadiance: linear outgoing radiance per PatchMesh vertex; patchRadiance (may be empty): per
// patch, written on tessellations made with flatPatches (the constant method). Throws Error(kCannotWrite) when the
// output cannot be written (and leaves nothing behind), Error(kUsage) for an unknown extension.
ExportSummary writeGltf(const std::string& path, const Scene& scene, const PatchMesh& mesh,
                        const std::vector<Vec3>& vertexRadiance, const std::vector<Vec3>& patchRadiance = {},
                        const ExportOptions& options = {});

// Writes `bytes` to `path` atomically: a temporary file beside it, then rename.
void writeFileAtomically(const std::string& path, const std::string& bytes);

}  // namespace radbake

// exporters: write the bake back into glTF (DESIGN.md "What a baked glTF holds").
//
// The output is the input document with, per baked primitive instance, `_RADIANCE` (linear, exact,
// unclamped) and `COLOR_0` (what a stock viewer shows), everything else written back unchanged. All
// buffers and images end up inside the output (one GLB binary chunk, or data URIs in a .gltf), so
// the result is self-contained. The write is atomic: a temporary file renamed into place.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/core.h"
#include "importers/importers.h"
#include "tessellate/tessellate.h"

namespace radbake {

// How COLOR_0 (and lightmap previews) are shaped for display, with OpenColorIO.
struct DisplayOptions {
  std::string config;   // an .ocio file; empty: the built-in config (no file needed)
  std::string display;  // empty: the config's default display ("sRGB" built in)
  std::string view;     // empty: the display's default view ("ACES 1.0 SDR-video" built in; or "Standard")
  std::optional<double> exposure;  // EV applied to the radiance first; empty: automatic
};

// Automatic exposure puts the 90th percentile, by area, of the lit (non-emitting) surfaces'
// luminance here.
constexpr double kAutoExposureTarget = 0.8;

// The display transform as resolved: names filled in, exposure chosen.
struct DisplayShaping {
  DisplayOptions options;  // display and view set to what was used
  std::string configName;  // the file, or a description of the built-in config
  double exposure = 0;     // EV
  bool automatic = false;
  double keyLuminance = 0;  // automatic: the 90th-percentile luminance (by area) it was set from
};

// Loads or builds the config and checks the display and view: Error(kInvalidInput) naming the file
// for a config OCIO cannot use, Error(kUsage) listing the choices for an unknown display or view.
// `reflected`: radiance of lit, non-emitting surface points, and the area each stands for (empty:
// equal), for the automatic exposure.
DisplayShaping resolveDisplay(const DisplayOptions& options, const std::vector<Vec3>& reflected = {},
                              const std::vector<double>& area = {});

// Scene-linear radiance → display code values in [0,1] (for the built-in display: sRGB encoded).
std::vector<Vec3> toDisplay(const DisplayShaping& shaping, const std::vector<Vec3>& radiance);

// --lightmap: the light goes into an HDR texture atlas instead of COLOR_0 (docs/lightmaps.md).
struct LightmapOptions {
  std::string path;      // the .exr to write; empty: no lightmap, COLOR_0 and unlit materials instead
  int size = 1024;       // the largest atlas width and height, in texels
  double texelSize = 0;  // world units per texel; 0: the finest that fits in size × size
};

struct ExportOptions {
  bool pretty = false;  // indent the JSON of a .gltf
  DisplayOptions display;
  LightmapOptions lightmap;
};

struct LightmapSummary {
  std::string exr, preview;  // the files written beside the glTF
  int width = 0, height = 0, charts = 0;
  double texelSize = 0;      // world units per texel (0 with the asset's own TEXCOORD_1)
  double fill = 0;           // the fraction of texels inside charts
  double intensity = 0;      // MOZ_lightmap.intensity: the embedded PNG holds sRGB(E / intensity)
  bool assetUVs = false;     // the asset's own TEXCOORD_1 was used
  int texCoord = 1;          // the TEXCOORD set the lightmap reads (1 unless a texture uses set 1)
  std::string atlasReason;   // why the asset's TEXCOORD_1 was not used (empty: it was, or there was none)
};

struct ExportSummary {
  int bakedPrimitives = 0;
  int clonedMeshes = 0;  // meshes duplicated so that each instance carries its own bake
  int unlitMaterials = 0;  // materials switched to KHR_materials_unlit
  long long writtenVertices = 0;
  long long clampedColors = 0;  // COLOR_0 components clamped to 1 (light × texture could not reach the display value)
  DisplayShaping display;
  LightmapSummary lightmap;
};

// With options.lightmap.path set, also writes the EXR lightmap and its preview PNG (all files
// together or none). vertexRadiance: linear outgoing radiance per PatchMesh vertex; patchRadiance (may be empty): per
// patch, written on tessellations made with flatPatches (the constant method). Throws Error(kCannotWrite) when the
// output cannot be written (and leaves nothing behind), Error(kUsage) for an unknown extension.
ExportSummary writeGltf(const std::string& path, const Scene& scene, const PatchMesh& mesh,
                        const std::vector<Vec3>& vertexRadiance, const std::vector<Vec3>& patchRadiance = {},
                        const ExportOptions& options = {});

// The same, but the files are appended to `files` (path → bytes, the glTF first) for the caller to
// write together with its own outputs (writeFilesAtomically): the command line's all-or-nothing.
ExportSummary exportGltf(const std::string& path, const Scene& scene, const PatchMesh& mesh,
                         const std::vector<Vec3>& vertexRadiance, const std::vector<Vec3>& patchRadiance,
                         const ExportOptions& options, std::vector<std::pair<std::string, std::string>>& files);

}  // namespace radbake

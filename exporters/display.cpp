// Display shaping with OpenColorIO: scene-linear radiance → display code values (sRGB encoded).
//
// Without a config file radbake builds one in code, so a bake needs no files installed: scene
// reference linear Rec.709, one "sRGB" display, and two views — "Standard" (the sRGB encoding,
// clipping at 1) and "ACES 1.0 SDR-video" (the ACES output transform, which rolls highlights off
// instead of clipping them). The transforms are OCIO's own builtins (no LUT files).
#include <OpenColorIO/OpenColorIO.h>

#include <algorithm>
#include <cmath>

#include "exporters/exporters.h"

namespace OCIO = OCIO_NAMESPACE;

namespace radbake {
namespace {

constexpr const char* kBuiltinName = "built-in (sRGB display: Standard, ACES 1.0 SDR-video)";

// Rec.709 primaries, D65 white → CIE XYZ (the display reference space of OCIO 2 configs).
OCIO::MatrixTransformRcPtr rec709ToXyz() {
  const double m[16] = {0.4123907992659595, 0.3575843393838780, 0.1804807884018343, 0,
                        0.2126390058715104, 0.7151686787677559, 0.0721923153607337, 0,
                        0.0193308187155918, 0.1191947797946259, 0.9505321522496606, 0,
                        0, 0, 0, 1};
  auto t = OCIO::MatrixTransform::Create();
  t->setMatrix(m);
  return t;
}

OCIO::BuiltinTransformRcPtr builtin(const char* style, OCIO::TransformDirection direction = OCIO::TRANSFORM_DIR_FORWARD) {
  auto t = OCIO::BuiltinTransform::Create();
  t->setStyle(style);
  t->setDirection(direction);
  return t;
}

OCIO::ConstConfigRcPtr builtinConfig() {
  auto cfg = OCIO::Config::Create();
  cfg->setName("radbake");

  auto linear = OCIO::ColorSpace::Create(OCIO::REFERENCE_SPACE_SCENE);
  linear->setName("Linear Rec.709");
  linear->setFamily("Scene");
  cfg->addColorSpace(linear);
  for (const char* role : {OCIO::ROLE_SCENE_LINEAR, OCIO::ROLE_DEFAULT, OCIO::ROLE_REFERENCE, OCIO::ROLE_RENDERING,
                           OCIO::ROLE_INTERCHANGE_SCENE, OCIO::ROLE_DATA})
    cfg->setRole(role, "Linear Rec.709");

  // The display colorspace: from XYZ to Rec.709, then the sRGB encoding (piecewise, 2.4 / 0.055).
  auto encode = OCIO::ExponentWithLinearTransform::Create();
  encode->setGamma({2.4, 2.4, 2.4, 1.0});
  encode->setOffset({0.055, 0.055, 0.055, 0.0});
  encode->setDirection(OCIO::TRANSFORM_DIR_INVERSE);  // forward decodes; the display needs encoding
  auto toDisplay = OCIO::GroupTransform::Create();
  auto xyzTo709 = rec709ToXyz();
  xyzTo709->setDirection(OCIO::TRANSFORM_DIR_INVERSE);
  toDisplay->appendTransform(xyzTo709);
  toDisplay->appendTransform(encode);
  auto srgb = OCIO::ColorSpace::Create(OCIO::REFERENCE_SPACE_DISPLAY);
  srgb->setName("sRGB - Display");
  srgb->setFamily("Display");
  srgb->setTransform(toDisplay, OCIO::COLORSPACE_DIR_FROM_REFERENCE);
  cfg->addColorSpace(srgb);
  cfg->setRole(OCIO::ROLE_INTERCHANGE_DISPLAY, "sRGB - Display");

  auto standard = OCIO::ViewTransform::Create(OCIO::REFERENCE_SPACE_SCENE);
  standard->setName("Un-tone-mapped");
  standard->setTransform(rec709ToXyz(), OCIO::VIEWTRANSFORM_DIR_FROM_REFERENCE);
  cfg->addViewTransform(standard);

  auto aces = OCIO::GroupTransform::Create();
  aces->appendTransform(builtin("UTILITY - ACES-AP1_to_LINEAR-REC709_BFD", OCIO::TRANSFORM_DIR_INVERSE));
  aces->appendTransform(builtin("ACEScg_to_ACES2065-1"));
  aces->appendTransform(builtin("ACES-OUTPUT - ACES2065-1_to_CIE-XYZ-D65 - SDR-VIDEO_1.0"));
  auto acesView = OCIO::ViewTransform::Create(OCIO::REFERENCE_SPACE_SCENE);
  acesView->setName("ACES 1.0 SDR-video");
  acesView->setTransform(aces, OCIO::VIEWTRANSFORM_DIR_FROM_REFERENCE);
  cfg->addViewTransform(acesView);

  // The first view is the display's default: highlights roll off, as a lighting artist expects.
  cfg->addDisplayView("sRGB", "ACES 1.0 SDR-video", "ACES 1.0 SDR-video", "sRGB - Display", "", "", "");
  cfg->addDisplayView("sRGB", "Standard", "Un-tone-mapped", "sRGB - Display", "", "", "");
  cfg->validate();
  return cfg;
}

// The config and the names in it; every problem is one line naming the file and what is wrong.
struct ResolvedView {
  OCIO::ConstConfigRcPtr config;
  std::string configName, display, view;
};

ResolvedView resolve(const DisplayOptions& options) {
  ResolvedView r;
  if (options.config.empty()) {
    r.config = builtinConfig();
    r.configName = kBuiltinName;
  } else {
    // Only a regular file: OpenColorIO would block on a FIFO or read a device forever. (A missing
    // file is left to OpenColorIO, whose message says so.)
    if (std::string problem = regularFileProblem(options.config); problem.starts_with("not a regular file"))
      throw Error(ExitCode::kInvalidInput, options.config + ": " + problem);
    try {
      r.config = OCIO::Config::CreateFromFile(options.config.c_str());
      r.config->validate();
    } catch (const OCIO::Exception& e) {
      std::string what = e.what();
      what.erase(std::remove(what.begin(), what.end(), '\n'), what.end());
      throw Error(ExitCode::kInvalidInput, options.config + ": not a usable OpenColorIO config: " + what);
    }
    r.configName = options.config;
  }
  const auto list = [](int n, auto name) {
    std::string s;
    for (int i = 0; i < n; ++i) s += (i ? ", " : "") + std::string(name(i));
    return s;
  };
  const OCIO::Config& cfg = *r.config;
  r.display = options.display.empty() ? cfg.getDefaultDisplay() : options.display;
  bool known = false;
  for (int i = 0; i < cfg.getNumDisplays(); ++i) known |= r.display == cfg.getDisplay(i);
  if (!known)
    throw Error(ExitCode::kUsage, "radbake: --display \"" + r.display + "\" is not in " + r.configName + " (displays: " +
                                      list(cfg.getNumDisplays(), [&](int i) { return cfg.getDisplay(i); }) + ")");
  r.view = options.view.empty() ? cfg.getDefaultView(r.display.c_str()) : options.view;
  known = false;
  for (int i = 0; i < cfg.getNumViews(r.display.c_str()); ++i) known |= r.view == cfg.getView(r.display.c_str(), i);
  if (!known)
    throw Error(ExitCode::kUsage, "radbake: --view \"" + r.view + "\" is not a view of display \"" + r.display + "\" in " +
                                      r.configName + " (views: " +
                                      list(cfg.getNumViews(r.display.c_str()),
                                           [&](int i) { return cfg.getView(r.display.c_str(), i); }) +
                                      ")");
  return r;
}

double luminance(const Vec3& c) { return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z; }

}  // namespace

DisplayShaping resolveDisplay(const DisplayOptions& options, const std::vector<Vec3>& reflected, const std::vector<double>& area) {
  const ResolvedView r = resolve(options);
  DisplayShaping s;
  s.options = options;
  s.options.display = r.display;
  s.options.view = r.view;
  s.configName = r.configName;
  if (options.exposure) {
    s.exposure = *options.exposure;
    return s;
  }
  // Automatic exposure: the 90th percentile of the lit surfaces' luminance, by area, lands on 0.8
  // scene linear, so most of the scene sits in the well-resolved range and emitters may clip or
  // roll off. By area, not by vertex: adaptive refinement crowds vertices into hot spots (a
  // Blender room refined around its lamp was exposed 4.6 EV darker than uniformly split).
  std::vector<std::pair<double, double>> lum;  // luminance, area
  lum.reserve(reflected.size());
  for (size_t i = 0; i < reflected.size(); ++i) {
    const double w = area.empty() ? 1.0 : area[i];
    if (double y = luminance(reflected[i]); y > 0 && std::isfinite(y) && w > 0) lum.push_back({y, w});
  }
  s.automatic = true;
  if (lum.empty()) return s;
  std::sort(lum.begin(), lum.end());
  double total = 0;
  for (const auto& [y, w] : lum) total += w;
  double below = 0;
  size_t k = 0;
  while (k + 1 < lum.size() && below + lum[k].second <= 0.9 * total) below += lum[k++].second;
  s.keyLuminance = lum[k].first;
  s.exposure = std::log2(kAutoExposureTarget / s.keyLuminance);
  return s;
}

std::vector<Vec3> toDisplay(const DisplayShaping& shaping, const std::vector<Vec3>& radiance) {
  const ResolvedView r = resolve(shaping.options);
  auto transform = OCIO::DisplayViewTransform::Create();
  transform->setSrc(OCIO::ROLE_SCENE_LINEAR);
  transform->setDisplay(r.display.c_str());
  transform->setView(r.view.c_str());
  OCIO::ConstCPUProcessorRcPtr cpu;
  try {
    cpu = r.config->getProcessor(transform)->getDefaultCPUProcessor();
  } catch (const OCIO::Exception& e) {
    throw Error(ExitCode::kInvalidInput, r.configName + ": view \"" + r.view + "\" of display \"" + r.display +
                                             "\" cannot be built: " + e.what());
  }
  const double gain = std::exp2(shaping.exposure);
  std::vector<float> pixels;
  pixels.reserve(radiance.size() * 3);
  for (const Vec3& c : radiance)
    pixels.insert(pixels.end(), {float(gain * c.x), float(gain * c.y), float(gain * c.z)});
  if (!pixels.empty()) {
    OCIO::PackedImageDesc image(pixels.data(), long(radiance.size()), 1, 3);
    cpu->apply(image);
  }
  std::vector<Vec3> out(radiance.size());
  for (size_t i = 0; i < out.size(); ++i)
    out[i] = {std::clamp(double(pixels[3 * i]), 0.0, 1.0), std::clamp(double(pixels[3 * i + 1]), 0.0, 1.0),
              std::clamp(double(pixels[3 * i + 2]), 0.0, 1.0)};
  return out;
}

}  // namespace radbake

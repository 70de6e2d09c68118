// The radbake command: parse the command line into Options, run the four stages, map failures to
// exit codes (DESIGN.md). main.cpp only forwards argv here, so all of it is testable in-process.
#pragma once

#include <cstdint>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

namespace radbake {

enum class Command { kNone, kBake, kInfo, kVersion };
enum class ProgressStyle { kAuto, kBar, kJson, kNone };  // auto: a bar when stderr is a terminal

struct Options {
  Command command = Command::kNone;
  std::string input;
  std::string output;
  std::string method = "bilinear";
  std::string contacts = "cut";  // --contacts: cut flat faces where surfaces touch or cross them, or off
  int subdivide = 1;
  double maxEdge = 0;
  double maxChord = 0;
  // --refine E: adaptive refinement to this relative error of the light; the default (0.02) unless
  // --refine off, the constant method, or a uniform mesh asked for with --subdivide or --max-edge.
  std::optional<double> refine;
  bool refineByDefault = false;     // on without being asked for: its budget is no reason to warn
  size_t maxPatches = 0;            // --max-patches: the refinement's budget (0: the default)
  std::string subdivisionSurfaces;  // "", "catmull-clark" or "loop"
  int scene = -1;                   // --scene N
  std::string lightmap;
  int lightmapSize = 1024;
  double texelSize = 0;
  std::optional<double> exposure;
  std::string view, display, ocioConfig;
  std::string probe, probeOut;
  std::string report;
  std::optional<std::string> sky;
  double tolerance = 1e-6;
  std::string transport;  // "exact" or "hierarchical"; empty: hierarchical for the bilinear method, exact for constant
  double accuracy = 1e-3;           // hierarchical: the largest estimated error of one far link
  bool strict = false;               // a solve that does not converge is an error (exit 5)
  bool allowOutsidePaths = false;    // buffers and images may lie outside the asset's folder
  std::optional<uint64_t> maxMemory;  // bytes; default: the machine's physical memory
  int threads = 0;  // 0: all cores
  bool quiet = false;
  bool json = false;  // `info --json`
  ProgressStyle progress = ProgressStyle::kAuto;
};

struct ParseResult {
  std::optional<Options> options;  // empty: exit with `exitCode` after printing `message`
  int exitCode = 0;
  std::string message;
};

ParseResult parseCommandLine(const std::vector<std::string>& args);

// Runs a parsed command. Messages go to `err`, results (info, summaries) to `out`.
int run(const Options& options, std::ostream& out, std::ostream& err);

// parse + run, what main() calls.
int runCommandLine(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace radbake

#pragma once
// Shared pieces of the tet2spline commands (apps only, not a library header).
// Each command file registers its subcommand with add<Name>Command(), which
// returns the CLI11 subcommand and the function that runs it after parsing.

#include <CLI/CLI.hpp>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>

#include "tet2spline/io/solid_loader.h"
#include "tet2spline/param/progress.h"

namespace tet2spline::cli {

using json = nlohmann::ordered_json;

struct Command {
  CLI::App* app = nullptr;
  std::function<int()> run;
};

/// Options of every command that reads a solid (mesh, check, param, convert).
struct InputOptions {
  std::string input;
  double quality = 1.5;
  double minDihedral = 0;
  double maxVolume = 0;
  double size = 0;
  bool voids = false;
  double deflection = 1e-3;
  int solid = 0;
  bool keepSurface = false;

  void addTo(CLI::App* cmd);
  LoadOptions loadOptions(bool validate) const;
};

/// Global flags (before or after the subcommand).
struct GlobalOptions {
  bool quiet = false;
  bool verbose = false;  ///< every progress message as its own log line (diagnostics of long runs)
};
GlobalOptions& globals();

/// Throws Error(Input) when the folder of `path` does not exist or is not
/// writable, so that an expensive run does not end in an I/O error.
void requireWritableOutput(const std::string& path);
/// Creates `dir` if needed (its parent must exist) and checks it is writable.
void requireOutputFolder(const std::string& dir);

/// Sets j at a dotted path ("ot.iterations"), creating the objects on the way.
void setPath(json& j, const std::string& dottedPath, json value);
/// Writes JSON atomically (temporary name, then rename).
void writeJson(const json& j, const std::string& path);

/// A log line per stage: "[  12.3 s] stage: message" on stderr (none with
/// --quiet). On a terminal, intermediate progress overwrites one line; with
/// --verbose every progress message is a line of its own (sub-stages,
/// Newton and untangling iterations), on a terminal or not.
class StageLog {
 public:
  explicit StageLog(bool quiet, bool verbose = false);
  void stage(const std::string& name, const std::string& message);
  /// A progress callback that prints into the current stage's line.
  ProgressCallback progress(const std::string& stageName);
  double elapsed() const;

 private:
  bool quiet_;
  bool verbose_;
  bool tty_;
  double start_;
  bool openLine_ = false;
};

/// The solid's part of every report (design.md keys vertices, tets, genus, voids...).
json solidJson(const LoadedSolid& s);

Command addCheckCommand(CLI::App& app);
Command addMeshCommand(CLI::App& app);
Command addParamCommand(CLI::App& app);
Command addTransportCommand(CLI::App& app);
Command addFitCommand(CLI::App& app);
Command addConvertCommand(CLI::App& app);

}  // namespace tet2spline::cli

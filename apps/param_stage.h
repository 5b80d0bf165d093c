#pragma once
// The param stage as the `param` and `convert` commands run it.
#include <string>
#include <vector>

#include "cli_common.h"
#include "tet2spline/param/parameterize.h"

namespace tet2spline::cli {

struct ParamStageOptions {
  std::string domain = "cube";
  bool noTransport = false;
  std::vector<std::string> densities;  ///< "R=W"
  std::string densityField;
  double voidDensity = 0;
  double tolerance = 1e-6;
  int maxIterations = 100;
  std::string untangler = "lbfgs";
  int boundarySmoothing = BoundarySmoothingOptions().sweeps;
  int interiorSmoothing = BoundarySmoothingOptions().interiorSweeps;
  double siteStretch = ParamOptions().cubeSiteStretch;
  std::string cubeSites = "auto";

  void addTo(CLI::App* cmd);
  /// Throws Error(Usage) for a malformed --density, or --site-stretch with
  /// --cube-sites equal-volume.
  ParamOptions toParamOptions() const;
};

/// The param keys of report.json (design.md and issues 3, 4).
void addParamReport(json& report, const ParamResult& result);

/// The parameterized mesh as `param` writes it: physical positions with the
/// point field "U" (or, when `mapped`, positions U and point field "X"), and
/// cell fields "volume_ratio" (parametric / target volume), "target_volume"
/// and "inverted" (1 where the tet is not positive in U).
TetMesh paramOutputMesh(const ParamResult& result, bool mapped);

/// Runs parameterize() with a stage log; throws Error(Numerical) when it fails
/// (after adding what it reached to `report`).
ParamResult runParamStage(const TetMesh& mesh, const std::string& inputName, const ParamStageOptions& options,
                          StageLog& log, json& report);

}  // namespace tet2spline::cli

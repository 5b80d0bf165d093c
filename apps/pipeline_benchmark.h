#pragma once
/// The whole-pipeline benchmark (issue 7): runs `tet2spline convert` on a
/// model in a child process per repetition, and gathers per-stage seconds
/// from its report.json and the child's own peak resident memory (wait4),
/// so that one model's memory is never mixed with another's.
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace tet2spline::bench {

/// The median of v (0 when empty).
double median(std::vector<double> v);

struct PipelineRun {
  nlohmann::json report;   ///< the run's report.json (empty when it failed before writing one)
  double wallSeconds = 0;  ///< measured around the child
  double peakRssMiB = 0;   ///< the child's peak resident memory
  int exitStatus = 0;      ///< the child's exit status (128 + signal when killed)
  std::string stderrTail;  ///< the last line the child wrote on stderr
  /// `cli fit param.vtu --elements 8` on the run's map, when the run
  /// succeeded with the default 16 elements (empty otherwise): the fit error's
  /// fall from 8³ to 16³ per run (issue 5's halving), outside the timings.
  nlohmann::json coarseFitReport;
};

/// Runs `cli convert model -o <scratch> -q extraArgs...` (then the fit at 8
/// elements, see coarseFitReport) and removes the scratch folder afterwards. Throws Error(Usage) if the program cannot be
/// started.
PipelineRun runConvert(const std::string& cli, const std::string& model, const std::vector<std::string>& extraArgs);

/// A copy of `model` in `dir` whose vertices are scaled by 1 + k·10⁻⁹ about
/// their bounding box's centre (k = 0: the model itself, no copy). Inputs
/// that differ in their last bits, as real inputs do, can take different
/// paths through the pipeline (an untangling that ends in the morph, a
/// transport with more Newton steps), which repeating one input never
/// shows. Surfaces are copied as binary .ply (doubles) and volume meshes as
/// .vtu (regions and fields kept); CAD files cannot be scaled this way and
/// throw Error(Usage).
std::string perturbedCopy(const std::string& model, int k, const std::string& dir);

/// Throws Error(Usage) when perturbedCopy cannot scale `model` (checked
/// before the first run, which is the model itself).
void requirePerturbable(const std::string& model);

/// Medians over runs: every key of timings (seconds), plus wall time, peak
/// memory (the largest, not the median) and the quality figures of the last
/// run that succeeded; "per_run" lists each successful run's total seconds
/// and quality figures, and "total_min"/"total_max" the spread of totals.
nlohmann::json summarize(const std::string& model, const std::vector<PipelineRun>& runs);

}  // namespace tet2spline::bench

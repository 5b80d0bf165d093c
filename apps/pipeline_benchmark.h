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
};

/// Runs `cli convert model -o <scratch> -q extraArgs...` and removes the
/// scratch folder afterwards. Throws Error(Usage) if the program cannot be
/// started.
PipelineRun runConvert(const std::string& cli, const std::string& model, const std::vector<std::string>& extraArgs);

/// Medians over runs: every key of timings (seconds), plus wall time, peak
/// memory (the largest, not the median) and the quality figures of the last
/// run that succeeded.
nlohmann::json summarize(const std::string& model, const std::vector<PipelineRun>& runs);

}  // namespace tet2spline::bench

#include "pipeline_benchmark.h"

#include <fcntl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>

#include "tet2spline/io/mesh_io.h"
#include "tet2spline/param/error.h"

namespace tet2spline::bench {

namespace fs = std::filesystem;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n == 0 ? 0 : (n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]));
}

namespace {

/// to[as] = report[section][key], when the report has it.
void copyFigure(const nlohmann::json& report, const char* section, const char* key, const char* as, nlohmann::json& to) {
  if (report.contains(section) && report[section].contains(key)) to[as] = report[section][key];
}

std::string lastLine(const fs::path& file) {
  std::ifstream in(file);
  std::string line, last;
  while (std::getline(in, line))
    if (!line.empty()) last = line;
  return last;
}

}  // namespace

namespace {

struct ChildRun {
  double wallSeconds = 0, peakRssMiB = 0;
  int exitStatus = 0;
};

/// Runs args[0] with args, stderr to errFile, stdout discarded.
ChildRun runChild(std::vector<std::string> args, const fs::path& errFile) {
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  ChildRun run;
  const auto t0 = std::chrono::steady_clock::now();
  const pid_t pid = ::fork();
  if (pid < 0) throw Error(ErrorKind::Usage, std::string("tet2spline_bench: fork: ") + std::strerror(errno));
  if (pid == 0) {  // child: stderr to a file, stdout discarded
    const int e = ::open(errFile.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int n = ::open("/dev/null", O_WRONLY);
    if (e >= 0) ::dup2(e, 2);
    if (n >= 0) ::dup2(n, 1);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  int status = 0;
  rusage usage{};
  while (::wait4(pid, &status, 0, &usage) < 0 && errno == EINTR) {
  }
  run.wallSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  run.peakRssMiB = static_cast<double>(usage.ru_maxrss) / 1024.0;  // Linux: kilobytes
  run.exitStatus = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return run;
}

nlohmann::json readReport(const fs::path& file) {
  if (!fs::exists(file)) return nlohmann::json();
  std::ifstream in(file);
  nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
  return j.is_discarded() ? nlohmann::json() : j;
}

}  // namespace

PipelineRun runConvert(const std::string& cli, const std::string& model, const std::vector<std::string>& extraArgs) {
  static int counter = 0;
  const fs::path scratch =
      fs::temp_directory_path() / ("t2s_bench_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
  fs::remove_all(scratch);
  fs::create_directories(scratch);
  const fs::path out = scratch / "out", err = scratch / "stderr.txt";
  std::vector<std::string> args = {cli, "convert", model, "-o", out.string(), "-q"};
  args.insert(args.end(), extraArgs.begin(), extraArgs.end());

  PipelineRun run;
  const ChildRun child = runChild(args, err);
  run.wallSeconds = child.wallSeconds;
  run.peakRssMiB = child.peakRssMiB;
  run.exitStatus = child.exitStatus;
  run.stderrTail = lastLine(err);
  if (run.exitStatus == 127 && run.stderrTail.empty()) {
    fs::remove_all(scratch);
    throw Error(ErrorKind::Usage, "tet2spline_bench: cannot run " + cli + " (use --cli)");
  }
  run.report = readReport(out / "report.json");
  // The fit again at 8 elements per direction on the same map, for the
  // error's fall from 8³ to 16³ (issue 5); not timed with the pipeline.
  const bool defaultElements = std::none_of(extraArgs.begin(), extraArgs.end(),
                                            [](const std::string& a) { return a.rfind("--elements", 0) == 0; });
  if (run.exitStatus == 0 && defaultElements && fs::exists(out / "param.vtu") && run.report.contains("fit")) {
    const fs::path coarse = scratch / "fit8";
    if (runChild({cli, "fit", (out / "param.vtu").string(), "-o", coarse.string(), "-q", "--elements", "8"},
                 scratch / "fit8_stderr.txt")
            .exitStatus == 0)
      run.coarseFitReport = readReport(coarse / "report.json");
  }
  fs::remove_all(scratch);
  return run;
}

void requirePerturbable(const std::string& model) {
  const FileFormat f = formatFromPath(model);
  if (!isVolumeFormat(f) && !isSurfaceFormat(f))
    throw Error(ErrorKind::Usage, model + ": --perturb scales mesh inputs only (not CAD files)");
}

std::string perturbedCopy(const std::string& model, int k, const std::string& dir) {
  requirePerturbable(model);
  if (k == 0) return model;
  const FileFormat f = formatFromPath(model);
  const double s = 1.0 + 1e-9 * k;
  auto scale = [s](Eigen::MatrixX3d& V) {
    if (V.rows() == 0) return;
    const Eigen::RowVector3d c = 0.5 * (V.colwise().minCoeff() + V.colwise().maxCoeff());
    V = ((V.rowwise() - c) * s).rowwise() + c;
  };
  const fs::path stem = fs::path(dir) / (fs::path(model).stem().string() + "_perturbed_" + std::to_string(k));
  if (isVolumeFormat(f)) {
    TetMesh mesh = readTetMesh(model);
    scale(mesh.V);
    const std::string path = stem.string() + ".vtu";
    writeTetMesh(mesh, path);
    return path;
  }
  SurfaceMesh surface = readSurface(model);
  scale(surface.V);
  const std::string path = stem.string() + ".ply";
  writeSurface(surface, path);
  return path;
}

nlohmann::json summarize(const std::string& model, const std::vector<PipelineRun>& runs) {
  std::map<std::string, std::vector<double>> seconds;
  std::vector<double> wall;
  double peak = 0;
  int failed = 0;
  const PipelineRun* last = nullptr;
  nlohmann::json perRun = nlohmann::json::array();
  for (const PipelineRun& r : runs) {
    peak = std::max(peak, r.peakRssMiB);
    if (r.exitStatus != 0) {
      ++failed;
      continue;
    }
    last = &r;
    wall.push_back(r.wallSeconds);
    nlohmann::json one = {{"wall_seconds", r.wallSeconds}};
    copyFigure(r.report, "timings", "total", "total", one);
    copyFigure(r.report, "ot", "iterations", "ot_iterations", one);
    copyFigure(r.report, "param", "misplaced_volume", "param_misplaced_volume", one);
    copyFigure(r.report, "fit", "rms_error_relative", "fit_rms_error_relative", one);
    copyFigure(r.coarseFitReport, "fit", "rms_error_relative", "fit_rms_error_relative_8", one);
    if (one.contains("fit_rms_error_relative") && one.contains("fit_rms_error_relative_8"))
      one["fit_rms_ratio_8_to_16"] =
          one["fit_rms_error_relative_8"].get<double>() / one["fit_rms_error_relative"].get<double>();
    if (r.report.contains("param") && r.report["param"].contains("morph"))
      one["morph"] = r.report["param"]["morph"].value("used", false);
    perRun.push_back(one);
    if (r.report.contains("timings"))
      for (const auto& [key, value] : r.report["timings"].items())
        if (value.is_number()) seconds[key].push_back(value.get<double>());
  }
  nlohmann::json j = {{"model", model}, {"runs", runs.size()}, {"failed_runs", failed}, {"peak_rss_mib", peak}};
  if (failed > 0) {
    for (const PipelineRun& r : runs)
      if (r.exitStatus != 0) {
        j["error"] = r.stderrTail;
        j["exit_status"] = r.exitStatus;
        break;
      }
  }
  if (!last) return j;
  j["wall_seconds"] = median(wall);
  nlohmann::json medians = nlohmann::json::object();
  for (const auto& [key, values] : seconds) medians[key] = median(values);
  j["timings"] = medians;
  if (seconds.count("total")) {
    j["total_min"] = *std::min_element(seconds["total"].begin(), seconds["total"].end());
    j["total_max"] = *std::max_element(seconds["total"].begin(), seconds["total"].end());
  }
  j["per_run"] = perRun;
  const nlohmann::json& rep = last->report;
  auto copy = [&](const char* section, const char* key, const char* as) { copyFigure(rep, section, key, as, j); };
  if (rep.contains("vertices")) j["vertices"] = rep["vertices"];
  if (rep.contains("tets")) j["tets"] = rep["tets"];
  copy("param", "vertices", "param_vertices");
  copy("param", "tets", "param_tets");
  copy("ot", "iterations", "ot_iterations");
  copy("ot", "max_relative_mass_error", "ot_max_relative_mass_error");
  copy("param", "inverted_tets", "param_inverted_tets");
  copy("param", "volume_ratio", "param_volume_ratio");
  copy("param", "misplaced_volume", "param_misplaced_volume");
  copy("fit", "rms_error_relative", "fit_rms_error_relative");
  copy("jacobian", "negative_gauss_points", "jacobian_negative_gauss_points");
  copy("jacobian", "min_scaled", "jacobian_min_scaled");
  return j;
}

}  // namespace tet2spline::bench

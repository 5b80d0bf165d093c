// tet2spline_bench: per-stage seconds (median of --repeat runs) and peak
// resident memory for named models of the test data (libcgal-demo meshes).
//
// Default (--stage convert): the whole pipeline, `tet2spline convert` run in
// a child process per repetition (meshing, ball map, transport, untangling,
// fit, every export); the stage seconds come from its report.json, the peak
// memory from the child itself. Arguments after `--` go to convert.
//
// --stage ball: meshing and the ball map alone, in this process (spherical
// map, harmonic map, untangling). Boundary chords are split before the map
// (refine.h), as the pipeline does; --no-split-chords measures the map on
// TetGen's mesh as it is.
//
// --perturb: run k converts the model scaled by 1 + k·1e-9 (pipeline_benchmark.h
// perturbedCopy), so that the runs show the spread of paths the pipeline
// takes on inputs differing in their last bits. With two or more models,
// each after the first gets its growth from the first (total against
// n log n).
//
//   tet2spline_bench --data build/testdata fandisk homer --repeat 3 --json bench.json
//   tet2spline_bench --stage ball bunny00 homer
#include <sys/resource.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <nlohmann/json.hpp>

#include "pipeline_benchmark.h"
#include "tet2spline/io/mesh_io.h"
#include "tet2spline/param/ball_map.h"
#include "tet2spline/param/error.h"
#include "tet2spline/param/refine.h"
#include "tet2spline/param/tetrahedralize.h"

namespace {

namespace fs = std::filesystem;

using tet2spline::bench::median;

double peakResidentMiB() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // Linux: kilobytes
}

std::string modelPath(const std::string& data, const std::string& name) {
  for (const std::string& p : {data + "/meshes/" + name + ".off", data + "/" + name + ".off", name})
    if (std::filesystem::exists(p)) return p;
  throw tet2spline::Error(tet2spline::ErrorKind::Input, name + ": no such model under " + data);
}

std::string defaultCli(const char* argv0) {
  std::error_code ec;
  fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (ec) self = argv0;
  return (self.parent_path() / "tet2spline").string();
}

std::string fixed(double v, int digits) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << v;
  return s.str();
}

/// The whole pipeline, one child `convert` per run; a table on stdout.
int runPipeline(const std::string& cli, const std::string& data, const std::vector<std::string>& models, int repeat,
                bool perturb, const std::vector<std::string>& extra, nlohmann::json& report) {
  using namespace tet2spline;
  // Columns: the stages of convert's report (timings.*), in pipeline order.
  const std::vector<std::pair<std::string, std::string>> columns = {
      {"load", "mesh"},          {"spherical_map", "sphere"}, {"harmonic", "harm"},   {"untangle", "untgl"},
      {"transport", "OT"},       {"final_untangle", "final"}, {"param", "param"},     {"fit", "fit"},
      {"fit_checks", "checks"},  {"export", "export"},        {"total", "total"}};
  std::cout << std::left << std::setw(14) << "model" << std::right << std::setw(8) << "verts" << std::setw(9) << "tets";
  for (const auto& c : columns) std::cout << std::setw(8) << c.second;
  std::cout << std::setw(6) << "OTit" << std::setw(9) << "peakMiB" << std::setw(14) << "total min-max"
            << "  (median seconds of " << repeat << (perturb ? " inputs scaled by 1 + k·1e-9" : " runs") << ")"
            << std::endl;
  int status = 0;
  for (const std::string& name : models) {
    try {
      const std::string path = modelPath(data, name);
      if (perturb) bench::requirePerturbable(path);
      std::vector<bench::PipelineRun> runs;
      {
        // The scaled copies live as long as the model's runs.
        struct Scratch {
          fs::path dir;
          ~Scratch() {
            std::error_code ec;
            if (!dir.empty()) fs::remove_all(dir, ec);
          }
        } copies;
        if (perturb) {
          copies.dir = fs::temp_directory_path() / ("t2s_bench_inputs_" + std::to_string(::getpid()));
          fs::create_directories(copies.dir);
        }
        for (int k = 0; k < repeat; ++k) {
          runs.push_back(bench::runConvert(cli, perturb ? bench::perturbedCopy(path, k, copies.dir.string()) : path, extra));
          if (runs.back().exitStatus != 0) break;  // a failing model fails every time: do not wait for it again
        }
      }
      nlohmann::json j = bench::summarize(name, runs);
      report.push_back(j);
      std::cout << std::left << std::setw(14) << name << std::right;
      if (!j.contains("timings")) {
        std::cout << "  failed (exit " << j.value("exit_status", 0) << "): " << j.value("error", std::string()) << std::endl;
        status = j.value("exit_status", 5);
        continue;
      }
      std::cout << std::setw(8) << j.value("param_vertices", 0L) << std::setw(9) << j.value("param_tets", 0L);
      for (const auto& c : columns)
        std::cout << std::setw(8) << (j["timings"].contains(c.first) ? fixed(j["timings"][c.first].get<double>(), 1) : "-");
      std::cout << std::setw(6) << j.value("ot_iterations", 0) << std::setw(9) << fixed(j["peak_rss_mib"].get<double>(), 0)
                << std::setw(14) << (fixed(j.value("total_min", 0.0), 1) + "-" + fixed(j.value("total_max", 0.0), 1))
                << std::endl;
      std::string ratios;
      for (const auto& one : j["per_run"])
        if (one.contains("fit_rms_ratio_8_to_16"))
          ratios += (ratios.empty() ? "" : ", ") + fixed(one["fit_rms_ratio_8_to_16"].get<double>(), 3);
      if (!ratios.empty()) std::cout << "  fit RMS error 8³ / 16³ elements, per run: " << ratios << std::endl;
      if (j["failed_runs"].get<int>() > 0) status = j.value("exit_status", 5);
    } catch (const Error& e) {
      std::cerr << "tet2spline_bench: " << e.what() << "\n";
      report.push_back({{"model", name}, {"error", e.what()}});
      status = e.exitStatus();
    }
  }
  // Growth (issue 7): each model's median total against the first model's,
  // next to how n log n grows (n: tets of the parameterized mesh), so that
  // "time grows no faster than 1.5 × n log n" can be read off.
  const nlohmann::json* base = nullptr;
  for (auto& j : report) {
    if (!j.contains("timings") || !(j.value("param_tets", 0L) > 1)) continue;
    if (!base) {
      base = &j;
      continue;
    }
    const double n0 = static_cast<double>((*base)["param_tets"].get<long>()), n1 = static_cast<double>(j["param_tets"].get<long>());
    const double time = j["timings"]["total"].get<double>() / std::max(1e-9, (*base)["timings"]["total"].get<double>());
    const double nlogn = n1 * std::log(n1) / (n0 * std::log(n0));
    j["growth"] = {{"from", (*base)["model"]}, {"tets", n1 / n0}, {"n_log_n", nlogn}, {"total", time},
                   {"total_over_n_log_n", time / nlogn}};
    std::cout << "growth " << (*base)["model"].get<std::string>() << " -> " << j["model"].get<std::string>() << ": tets x"
              << fixed(n1 / n0, 2) << ", n log n x" << fixed(nlogn, 2) << ", median total x" << fixed(time, 2) << " ("
              << fixed(time / nlogn, 2) << " times n log n's growth)" << std::endl;
  }
  return status;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"tet2spline_bench: per-stage seconds and peak memory, whole pipeline or ball map"};
  std::string data = "build/testdata";
  std::vector<std::string> models;
  int repeat = 3;
  std::string jsonPath, stage = "convert", cli = defaultCli(argv[0]);
  bool noSplit = false, perturb = false;
  app.add_option("--data", data, "directory holding meshes/<name>.off (the fetched test data)");
  app.add_option("models", models, "model names (e.g. bunny00 homer) or .off paths")->required();
  app.add_option("--repeat", repeat, "runs per model; medians are reported")->check(CLI::PositiveNumber);
  app.add_option("--json", jsonPath, "also write the figures as JSON");
  app.add_option("--stage", stage, "convert: the whole pipeline (default); ball: meshing and the ball map")
      ->check(CLI::IsMember({"convert", "ball"}));
  app.add_option("--cli", cli, "the tet2spline program for --stage convert (default: beside this one)");
  app.add_flag("--perturb", perturb,
               "convert: run k converts the model scaled by 1 + k*1e-9 about its centre (run 0 as given): "
               "the spread of paths inputs differing in their last bits take, not timer noise (mesh inputs)");
  app.add_flag("--no-split-chords", noSplit, "ball: map TetGen's mesh without splitting boundary chords first");
  // Everything after `--` goes to convert (CLI11 would take it as model names).
  int own = argc;
  std::vector<std::string> extra;
  for (int k = 1; k < argc; ++k)
    if (std::string(argv[k]) == "--") {
      own = k;
      extra.assign(argv + k + 1, argv + argc);
      break;
    }
  CLI11_PARSE(app, own, argv);
  if (stage != "convert" && perturb) {
    std::cerr << "tet2spline_bench: --perturb is for --stage convert\n";
    return 2;
  }
  if (stage != "convert" && !extra.empty()) {
    std::cerr << "tet2spline_bench: options after -- are convert's; --stage ball takes none\n";
    return 2;
  }
  if (stage == "convert") {
    nlohmann::json report = nlohmann::json::array();
    const int status = runPipeline(cli, data, models, repeat, perturb, extra, report);
    if (!jsonPath.empty()) {
      std::ofstream out(jsonPath);
      out << std::setw(2) << nlohmann::json{{"stage", "convert"}, {"repeat", repeat}, {"perturb", perturb}, {"models", report}} << "\n";
    }
    return status;
  }

  using namespace tet2spline;
  nlohmann::json report = nlohmann::json::array();
  int status = 0;
  for (const std::string& name : models) {
    try {
      const SurfaceMesh surface = readSurface(modelPath(data, name));
      auto t0 = std::chrono::steady_clock::now();
      TetrahedralizeOptions meshing;
      meshing.radiusEdgeRatio = 1.5;
      TetMesh mesh = tetrahedralize(surface, meshing, name);
      const int chords = noSplit ? 0 : splitBoundaryChords(mesh);
      const double meshSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      std::vector<double> sphere, harmonic, untangle, total;
      BallMapResult r;
      for (int k = 0; k < repeat; ++k) {
        r = mapToBall(mesh);
        sphere.push_back(r.timings.boundary + r.timings.sphere);
        harmonic.push_back(r.timings.harmonic);
        untangle.push_back(r.timings.untangle);
        total.push_back(r.timings.total);
      }
      nlohmann::json j = {
          {"model", name},
          {"vertices", mesh.V.rows()},
          {"tets", mesh.T.rows()},
          {"chords_split", chords},
          {"boundary_vertices", r.boundaryVertices.size()},
          {"timings", {{"tetrahedralize", meshSeconds},
                       {"sphere", median(sphere)},
                       {"harmonic", median(harmonic)},
                       {"untangle", median(untangle)},
                       {"ball_map_total", median(total)}}},
          {"sphere", {{"flipped_triangles", r.sphere.flippedTriangles},
                      {"method", r.sphere.method},
                      {"angle_distortion_mean", r.sphere.angleDistortionMean},
                      {"angle_distortion_max", r.sphere.angleDistortionMax}}},
          {"ball", {{"inverted_tets_before_untangling", r.ball.invertedTetsBeforeUntangling},
                    {"inverted_tets", r.ball.invertedTets},
                    {"harmonic_residual", r.ball.harmonicResidual},
                    {"solver", r.ball.solver},
                    {"boundary_slid", r.ball.boundarySlid},
                    {"untangle_iterations", r.ball.untangleIterations}}},
          {"param", {{"boundary_max_distance", r.boundaryMaxDistance}}},
          {"status", r.status.ok ? "ok" : r.status.message},
          {"repeat", repeat},
          {"peak_rss_mib", peakResidentMiB()},
      };
      std::cout << std::setprecision(4) << name << ": " << mesh.V.rows() << " vertices, " << mesh.T.rows()
                << " tets (" << chords << " chords split); tetrahedralize " << meshSeconds << " s; sphere " << median(sphere) << " s, harmonic "
                << median(harmonic) << " s, untangle " << median(untangle) << " s, ball map "
                << median(total) << " s; flips " << r.sphere.flippedTriangles << " (" << r.sphere.method
                << "), inverted " << r.ball.invertedTetsBeforeUntangling << " -> " << r.ball.invertedTets
                << ", residual " << r.ball.harmonicResidual << ", distortion " << r.sphere.angleDistortionMean << "/"
                << r.sphere.angleDistortionMax << ", peak " << peakResidentMiB() << " MiB"
                << (r.status.ok ? "" : "; " + r.status.message) << std::endl;
      report.push_back(j);
      if (!r.status.ok) status = 5;
    } catch (const Error& e) {
      std::cerr << "tet2spline_bench: " << e.what() << "\n";
      report.push_back({{"model", name}, {"error", e.what()}});
      status = e.exitStatus();
    }
  }
  if (!jsonPath.empty()) {
    std::ofstream out(jsonPath);
    out << std::setw(2) << nlohmann::json{{"models", report}, {"peak_rss_mib", peakResidentMiB()}} << "\n";
  }
  return status;
}

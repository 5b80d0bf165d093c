// tet2spline_bench: per-stage seconds (median of --repeat runs) and peak
// resident memory of meshing and the ball map (spherical map, harmonic map,
// untangling) for named models of the test data (libcgal-demo meshes).
// Boundary chords are split before the map (refine.h), as the pipeline does;
// --no-split-chords measures the map on TetGen's mesh as it is.
//
//   tet2spline_bench --data build/testdata bunny00 homer --repeat 3 --json bench.json
#include <sys/resource.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>

#include "tet2spline/io/mesh_io.h"
#include "tet2spline/param/ball_map.h"
#include "tet2spline/param/error.h"
#include "tet2spline/param/refine.h"
#include "tet2spline/param/tetrahedralize.h"

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n == 0 ? 0 : (n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]));
}

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

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"tet2spline_bench: per-stage seconds and peak memory of the ball map"};
  std::string data = "build/testdata";
  std::vector<std::string> models;
  int repeat = 3;
  std::string jsonPath;
  bool noSplit = false;
  app.add_option("--data", data, "directory holding meshes/<name>.off (the fetched test data)");
  app.add_option("models", models, "model names (e.g. bunny00 homer) or .off paths")->required();
  app.add_option("--repeat", repeat, "runs per model; medians are reported")->check(CLI::PositiveNumber);
  app.add_option("--json", jsonPath, "also write the figures as JSON");
  app.add_flag("--no-split-chords", noSplit, "map TetGen's mesh without splitting boundary chords first");
  CLI11_PARSE(app, argc, argv);

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

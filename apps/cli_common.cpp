#include "cli_common.h"

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "tet2spline/io/atomic_file.h"
#include "tet2spline/param/error.h"

namespace fs = std::filesystem;

namespace tet2spline::cli {

void InputOptions::addTo(CLI::App* cmd) {
  cmd->add_option("IN", input, "input: .mesh .msh .node .ele .vtu .vtk .off .obj .stl .ply .step .stp .iges .igs")
      ->required();
  cmd->add_option("--quality", quality, "TetGen radius-edge bound for surface/CAD input (0 = none)")
      ->check(CLI::Range(0.0, 100.0))->capture_default_str();
  cmd->add_option("--min-dihedral", minDihedral,
                  "TetGen's quality refinement also removes tets with a dihedral angle below this many degrees "
                  "(0 = no angle bound; at most 18)")
      ->check(CLI::Range(0.0, 18.0))->capture_default_str();
  cmd->add_option("--max-volume", maxVolume, "largest tet volume for surface/CAD input (0 = no limit)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--size", size, "target edge length relative to the bounding-box diagonal (0 = none)")
      ->check(CLI::Range(0.0, 1.0));
  cmd->add_flag("--voids", voids, "inner shells of a surface/CAD input are voids (filled, tagged), not materials");
  cmd->add_option("--deflection", deflection, "CAD tessellation deflection relative to the model size")
      ->check(CLI::Range(1e-6, 0.1))->capture_default_str();
  cmd->add_option("--solid", solid, "1-based solid to take from a CAD file holding several")
      ->check(CLI::PositiveNumber);
  cmd->add_flag("--keep-surface", keepSurface,
                "keep every input triangle as its own TetGen facet (boundary exactly on the input triangles); "
                "by default facets within 0.1 degree of coplanar merge and TetGen remeshes them");
}

LoadOptions InputOptions::loadOptions(bool validate) const {
  LoadOptions o;
  o.meshing.radiusEdgeRatio = quality;
  o.meshing.maxVolume = maxVolume;
  o.meshing.minDihedral = minDihedral;
  o.meshing.relativeSize = size;
  o.meshing.voids = voids;
  // Merged facets: TetGen remeshes flat and nearly flat parts of the surface,
  // points stay within ~1e-5 of the size of the input surface. Kept facets
  // carry CAD tessellations' long slivers into the tets: on models/bracket.step
  // the quality refinement then ran for over ten minutes (merged: 5 s), and on
  // models/two_material.off the conformal sphere map of the sliver surface had
  // angle distortion up to 837 and 87 tets that the untangler could not repair
  // (merged: distortion at most 1.37 and no inverted tet).
  o.meshing.exactBoundary = keepSurface;
  o.cad.relativeDeflection = deflection;
  o.cad.solid = solid;
  o.validate = validate;
  return o;
}

GlobalOptions& globals() {
  static GlobalOptions g;
  return g;
}

void requireWritableOutput(const std::string& path) {
  fs::path dir = fs::path(path).parent_path();
  if (dir.empty()) dir = ".";
  if (!fs::is_directory(dir)) throw Error(ErrorKind::Input, path + ": output folder " + dir.string() + " does not exist");
  if (::access(dir.c_str(), W_OK) != 0)
    throw Error(ErrorKind::Input, path + ": output folder " + dir.string() + " is not writable");
}

void requireOutputFolder(const std::string& dir) {
  std::error_code ec;
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec))
    throw Error(ErrorKind::Input, dir + ": exists and is not a folder");
  if (!fs::exists(dir, ec)) {
    fs::path parent = fs::path(dir).parent_path();
    if (parent.empty()) parent = ".";
    if (!fs::is_directory(parent, ec))
      throw Error(ErrorKind::Input, dir + ": parent folder " + parent.string() + " does not exist");
    if (!fs::create_directory(dir, ec))
      throw Error(ErrorKind::Input, dir + ": cannot create the output folder (" + ec.message() + ")");
  }
  if (::access(dir.c_str(), W_OK) != 0) throw Error(ErrorKind::Input, dir + ": output folder is not writable");
}

void setPath(json& j, const std::string& dottedPath, json value) {
  json* node = &j;
  size_t start = 0;
  while (true) {
    const size_t dot = dottedPath.find('.', start);
    const std::string key = dottedPath.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    if (dot == std::string::npos) {
      (*node)[key] = std::move(value);
      return;
    }
    node = &(*node)[key];
    start = dot + 1;
  }
}

void writeJson(const json& j, const std::string& path) {
  AtomicFile file(path);
  file.stream() << j.dump(2) << '\n';
  file.commit();
}

namespace {
double nowSeconds() {
  using namespace std::chrono;
  return duration<double>(steady_clock::now().time_since_epoch()).count();
}
}  // namespace

StageLog::StageLog(bool quiet, bool verbose) : quiet_(quiet), verbose_(verbose && !quiet), tty_(::isatty(STDERR_FILENO) != 0), start_(nowSeconds()) {}

double StageLog::elapsed() const { return nowSeconds() - start_; }

void StageLog::stage(const std::string& name, const std::string& message) {
  if (quiet_) return;
  if (openLine_) std::cerr << '\n';
  openLine_ = false;
  char head[32];
  std::snprintf(head, sizeof head, "[%7.1f s] ", elapsed());
  std::cerr << head << name << ": " << message << '\n';
}

ProgressCallback StageLog::progress(const std::string& stageName) {
  return [this, stageName](double fraction, const std::string& message) {
    if (verbose_) {
      stage(stageName, fraction >= 0 ? std::to_string(static_cast<int>(100 * fraction)) + "% " + message : message);
      return true;
    }
    if (quiet_ || !tty_) return true;  // plain logs get one line per stage only
    char head[48];
    std::snprintf(head, sizeof head, "\r[%7.1f s] ", elapsed());
    std::cerr << head << stageName << ": ";
    if (fraction >= 0) std::cerr << static_cast<int>(100 * fraction) << "% ";
    std::cerr << message.substr(0, 60) << "\033[K" << std::flush;
    openLine_ = true;
    return true;
  };
}

json solidJson(const LoadedSolid& s) {
  const SolidReport& r = s.report;
  json j;
  j["input_kind"] = s.inputKind;
  j["vertices"] = r.vertices;
  j["tets"] = r.tets;
  j["components"] = r.components;
  j["genus"] = r.genus;
  j["voids"] = r.voids;
  j["regions"] = r.regions;
  j["void_regions"] = std::vector<int>(s.mesh.voidRegions.begin(), s.mesh.voidRegions.end());
  j["inverted_tets"] = r.invertedTets;
  j["degenerate_tets"] = r.degenerateTets;
  j["reoriented"] = s.reoriented;
  j["removed_unused_vertices"] = s.removedUnusedVertices;
  j["caps_flipped"] = s.capsFlipped;
  j["tetgen_queue_slots_grown"] = s.tetgenQueueSlotsGrown;
  j["duplicate_vertices"] = r.duplicateVertices;
  j["unused_vertices"] = r.unusedVertices;
  j["nonmanifold_boundary_edges"] = r.nonManifoldBoundaryEdges;
  j["nonmanifold_boundary_vertices"] = r.nonManifoldBoundaryVertices;
  json shells = json::array();
  for (const auto& sh : r.shells)
    shells.push_back({{"vertices", sh.vertices}, {"edges", sh.edges}, {"faces", sh.faces},
                      {"euler_characteristic", sh.eulerCharacteristic}, {"genus", sh.genus},
                      {"closed", sh.closed}, {"enclosed_volume", sh.enclosedVolume}});
  j["shells"] = shells;
  j["valid"] = r.valid();
  j["problems"] = r.problems;
  j["seconds"] = s.seconds;
  return j;
}

}  // namespace tet2spline::cli

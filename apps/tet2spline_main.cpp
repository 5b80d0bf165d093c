// tet2spline: the command-line program (design.md, "Command line and report").
// Exit status: 0 ok, 2 bad command line, 3 malformed input, 4 unsupported
// topology, 5 numerical failure. Errors are one line on stderr.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <new>
#include <nlohmann/json.hpp>

#include "tet2spline/io/mesh_io.h"
#include "tet2spline/io/solid_loader.h"
#include "tet2spline/param/error.h"

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;
using namespace tet2spline;

namespace {

struct InputOptions {
  std::string input;
  double quality = 1.5;
  double maxVolume = 0;
  double size = 0;
  bool voids = false;
  double deflection = 1e-3;
  int solid = 0;

  void addTo(CLI::App* cmd) {
    cmd->add_option("IN", input, "input: .mesh .msh .node .ele .vtu .vtk .off .obj .stl .ply .step .stp .iges .igs")
        ->required();
    cmd->add_option("--quality", quality, "TetGen radius-edge bound for surface/CAD input (0 = none)")
        ->check(CLI::Range(0.0, 100.0))->capture_default_str();
    cmd->add_option("--max-volume", maxVolume, "largest tet volume for surface/CAD input (0 = no limit)")
        ->check(CLI::NonNegativeNumber);
    cmd->add_option("--size", size, "target edge length relative to the bounding-box diagonal (0 = none)")
        ->check(CLI::Range(0.0, 1.0));
    cmd->add_flag("--voids", voids, "inner shells of a surface/CAD input are voids (filled, tagged), not materials");
    cmd->add_option("--deflection", deflection, "CAD tessellation deflection relative to the model size")
        ->check(CLI::Range(1e-6, 0.1))->capture_default_str();
    cmd->add_option("--solid", solid, "1-based solid to take from a CAD file holding several")
        ->check(CLI::PositiveNumber);
  }
  LoadOptions loadOptions(bool validate) const {
    LoadOptions o;
    o.meshing.radiusEdgeRatio = quality;
    o.meshing.maxVolume = maxVolume;
    o.meshing.relativeSize = size;
    o.meshing.voids = voids;
    o.cad.relativeDeflection = deflection;
    o.cad.solid = solid;
    o.validate = validate;
    return o;
  }
};

json reportJson(const LoadedSolid& s) {
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

void printReport(const LoadedSolid& s, const std::string& path) {
  const SolidReport& r = s.report;
  std::cout << path << ": " << s.inputKind << " input, " << r.vertices << " vertices, " << r.tets << " tets\n"
            << "  components " << r.components << ", boundary shells " << r.shells.size() << ", genus " << r.genus
            << ", voids " << r.voids << "\n  regions";
  for (int id : r.regions) std::cout << ' ' << id << (s.mesh.voidRegions.count(id) ? "(void)" : "");
  std::cout << "\n  inverted tets " << r.invertedTets << ", degenerate tets " << r.degenerateTets
            << ", duplicate vertices " << r.duplicateVertices << ", unused vertices " << r.unusedVertices << '\n';
  if (s.reoriented) std::cout << "  every tet was inverted: the mesh was reoriented\n";
  std::cout << (r.valid() ? "  valid solid\n" : "  NOT VALID:\n");
  for (const auto& p : r.problems) std::cout << "  - " << p << '\n';
}

// Fail before any work when the output cannot be written, so that an
// expensive run does not end in an I/O error.
void requireWritableOutput(const std::string& path) {
  fs::path dir = fs::path(path).parent_path();
  if (dir.empty()) dir = ".";
  if (!fs::is_directory(dir)) throw Error(ErrorKind::Input, path + ": output folder " + dir.string() + " does not exist");
  if (::access(dir.c_str(), W_OK) != 0)
    throw Error(ErrorKind::Input, path + ": output folder " + dir.string() + " is not writable");
}

int runCheck(const InputOptions& in, bool asJson) {
  LoadedSolid s = loadSolid(in.input, in.loadOptions(false));
  if (asJson)
    std::cout << reportJson(s).dump(2) << '\n';
  else
    printReport(s, in.input);
  requireValidSolid(s.report, in.input);  // throws with the documented status
  return 0;
}

int runMesh(const InputOptions& in, const std::string& output, bool quiet) {
  const FileFormat f = formatFromPath(output);
  if (f != FileFormat::Medit && f != FileFormat::Gmsh && f != FileFormat::Vtu)
    throw Error(ErrorKind::Usage, output + ": output must end in .mesh, .msh or .vtu");
  requireWritableOutput(output);
  LoadedSolid s = loadSolid(in.input, in.loadOptions(true));
  writeTetMesh(s.mesh, output);
  if (!quiet)
    std::cerr << "tet2spline: " << output << ": " << s.report.vertices << " vertices, " << s.report.tets
              << " tets, " << s.report.regions.size() << " region(s), " << s.report.voids << " void(s) in "
              << s.seconds << " s\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"tet2spline: measure-controlled volumetric parameterization and trivariate B-spline fitting"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "tet2spline 0.1.0");
  bool quiet = false;
  app.add_flag("-q,--quiet", quiet, "print no log lines");

  InputOptions checkIn;
  bool checkJson = false;
  CLI::App* check = app.add_subcommand("check", "report the topology and validity of a solid");
  checkIn.addTo(check);
  check->add_flag("--json", checkJson, "print the report as JSON");

  InputOptions meshIn;
  std::string meshOut;
  CLI::App* mesh = app.add_subcommand("mesh", "tetrahedralize a surface or CAD solid (or convert a tet mesh)");
  meshIn.addTo(mesh);
  mesh->add_option("-o,--output", meshOut, "output .mesh, .msh or .vtu")->required();
  mesh->add_flag("-q,--quiet", quiet, "print no log lines");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    std::cerr << "tet2spline: " << e.what() << " (see tet2spline --help)\n";
    return static_cast<int>(ErrorKind::Usage);
  }

  try {
    if (*check) return runCheck(checkIn, checkJson);
    if (*mesh) return runMesh(meshIn, meshOut, quiet);
  } catch (const Error& e) {
    std::cerr << "tet2spline: " << e.what() << '\n';
    return e.exitStatus();
  } catch (const std::bad_alloc&) {
    std::cerr << "tet2spline: out of memory\n";
    return static_cast<int>(ErrorKind::Numerical);
  } catch (const std::exception& e) {
    std::cerr << "tet2spline: internal error: " << e.what() << '\n';
    return static_cast<int>(ErrorKind::Numerical);
  }
  return 0;
}

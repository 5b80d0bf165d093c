// tet2spline check / mesh (design.md, "Command line and report").
#include <iostream>
#include <memory>

#include "cli_common.h"
#include "tet2spline/io/mesh_io.h"
#include "tet2spline/param/error.h"

namespace tet2spline::cli {
namespace {

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

}  // namespace

Command addCheckCommand(CLI::App& app) {
  struct Options {
    InputOptions in;
    bool json = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("check", "report the topology and validity of a solid");
  o->in.addTo(cmd);
  cmd->add_flag("--json", o->json, "print the report as JSON");
  return {cmd, [o]() {
            LoadedSolid s = loadSolid(o->in.input, o->in.loadOptions(false));
            if (o->json)
              std::cout << solidJson(s).dump(2) << '\n';
            else
              printReport(s, o->in.input);
            requireValidSolid(s.report, o->in.input);  // throws with the documented status
            return 0;
          }};
}

Command addMeshCommand(CLI::App& app) {
  struct Options {
    InputOptions in;
    std::string output;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("mesh", "tetrahedralize a surface or CAD solid (or convert a tet mesh)");
  o->in.addTo(cmd);
  cmd->add_option("-o,--output", o->output, "output .mesh, .msh or .vtu")->required();
  cmd->add_flag("-q,--quiet", globals().quiet, "print no log lines");
  return {cmd, [o]() {
            const FileFormat f = formatFromPath(o->output);
            if (f != FileFormat::Medit && f != FileFormat::Gmsh && f != FileFormat::Vtu)
              throw Error(ErrorKind::Usage, o->output + ": output must end in .mesh, .msh or .vtu");
            requireWritableOutput(o->output);
            LoadedSolid s = loadSolid(o->in.input, o->in.loadOptions(true));
            writeTetMesh(s.mesh, o->output);
            if (!globals().quiet)
              std::cerr << "tet2spline: " << o->output << ": " << s.report.vertices << " vertices, "
                        << s.report.tets << " tets, " << s.report.regions.size() << " region(s), "
                        << s.report.voids << " void(s) in " << s.seconds << " s\n";
            return 0;
          }};
}

}  // namespace tet2spline::cli

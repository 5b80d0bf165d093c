// tet2spline fit IN.vtu -o OUTDIR (design.md, "Command line and report").
#include <filesystem>
#include <iostream>
#include <memory>

#include "cli_common.h"
#include "fit_stage.h"
#include "tet2spline/io/atomic_file.h"
#include "tet2spline/io/mesh_io.h"
#include "tet2spline/param/error.h"

namespace tet2spline::cli {

Command addFitCommand(CLI::App& app) {
  struct Options {
    std::string input;
    std::string output;
    std::string report;
    FitStageOptions fit;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("fit", "fit a trivariate B-spline to a cube parameterization and export it");
  cmd->add_option("IN", o->input, "parameterized tet mesh (.vtu from tet2spline param --domain cube)")->required();
  cmd->add_option("-o,--output", o->output, "output folder (created if its parent exists)")->required();
  cmd->add_option("--report", o->report, "report JSON path (default OUTDIR/report.json)");
  o->fit.addTo(cmd);
  cmd->add_flag("-q,--quiet", globals().quiet, "print no log lines");
  cmd->add_flag("-v,--verbose", globals().verbose, "print every progress message as a log line");
  return {cmd, [o]() {
            o->fit.resolve();
            if (!o->report.empty()) requireWritableOutput(o->report);
            StageLog log(globals().quiet, globals().verbose);
            const TetMesh mesh = readTetMesh(o->input);
            const Eigen::MatrixX3d U = cubeParameters(mesh, o->input);
            log.stage("read", o->input + ": " + std::to_string(mesh.numVertices()) + " vertices, " +
                                  std::to_string(mesh.numTets()) + " tets");
            // A folder made here goes again when the run fails (nothing else is in it then).
            const bool existed = std::filesystem::exists(o->output);
            requireOutputFolder(o->output);
            struct RemoveIfEmpty {
              std::string dir;
              bool armed;
              ~RemoveIfEmpty() {
                std::error_code ec;
                if (armed && std::filesystem::is_empty(dir, ec)) std::filesystem::remove(dir, ec);
              }
            } cleanup{o->output, !existed};
            o->fit.source = o->input;
            StagedFiles out(o->output);
            json report;
            report["input"] = o->input;
            report["vertices"] = static_cast<long>(mesh.numVertices());
            report["tets"] = static_cast<long>(mesh.numTets());
            report.update(runFitStage(mesh, U, o->fit, out, log));
            const std::string reportPath = o->report.empty() ? out.finalPath("report.json") : o->report;
            report["exports"].push_back(reportPath);
            if (o->report.empty()) writeJson(report, out.stagingPath("report.json"));
            out.commit();
            cleanup.armed = false;
            if (!o->report.empty()) writeJson(report, o->report);
            log.stage("done", "outputs in " + o->output);
            return 0;
          }};
}

}  // namespace tet2spline::cli

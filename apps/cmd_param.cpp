// tet2spline param IN -o OUT.vtu --domain {ball,cube} [--density R=W ...] [--report R.json]
#include <iostream>
#include <memory>

#include "cli_common.h"
#include "param_stage.h"
#include "tet2spline/io/mesh_io.h"
#include "tet2spline/param/error.h"

namespace tet2spline::cli {

Command addParamCommand(CLI::App& app) {
  struct Options {
    InputOptions in;
    ParamStageOptions param;
    std::string output;
    std::string report;
    bool mapped = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("param", "measure-controlled parameterization onto the ball or the cube");
  o->in.addTo(cmd);
  o->param.addTo(cmd);
  cmd->add_option("-o,--output", o->output, "output .vtu: the tet mesh with the parameter U as a point field")->required();
  cmd->add_option("--report", o->report, "write the report as JSON here");
  cmd->add_flag("--mapped", o->mapped, "write the mesh at its parameter positions (physical ones as point field X)");
  cmd->add_flag("-q,--quiet", globals().quiet, "print no log lines");
  cmd->add_flag("-v,--verbose", globals().verbose, "print every progress message as a log line");
  return {cmd, [o]() {
            if (formatFromPath(o->output) != FileFormat::Vtu)
              throw Error(ErrorKind::Usage, o->output + ": the param output must be a .vtu file");
            if (o->param.noTransport && o->param.domain != "ball")
              throw Error(ErrorKind::Usage, "--no-transport gives the harmonic ball map: use it with --domain ball");
            ParamOptions checked = o->param.toParamOptions();  // bad --density fails before any work
            (void)checked;
            requireWritableOutput(o->output);
            if (!o->report.empty()) requireWritableOutput(o->report);
            StageLog log(globals().quiet, globals().verbose);
            json report;
            LoadedSolid s = loadSolid(o->in.input, o->in.loadOptions(true));
            report = solidJson(s);
            log.stage("load", s.inputKind + " input, " + std::to_string(s.report.vertices) + " vertices, " +
                                  std::to_string(s.report.tets) + " tets");
            ParamResult r = runParamStage(s.mesh, o->in.input, o->param, log, report);
            writeTetMesh(paramOutputMesh(r, o->mapped), o->output);
            if (!o->report.empty()) writeJson(report, o->report);
            log.stage("param", "wrote " + o->output + (o->report.empty() ? "" : " and " + o->report));
            return 0;
          }};
}

}  // namespace tet2spline::cli

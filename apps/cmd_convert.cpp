// tet2spline convert IN -o OUTDIR: the whole pipeline (design.md "Data flow"):
// load (mesh a surface or CAD solid), validate, parameterize (cube by default),
// fit the spline and write every export, report.json and report.html.
// Everything is staged and moved into OUTDIR only when all stages succeeded.
#include <exception>
#include <filesystem>
#include <iostream>
#include <memory>
#include <thread>

#include "cli_common.h"
#include "fit_stage.h"
#include "html_stage.h"
#include "param_stage.h"
#include "tet2spline/io/atomic_file.h"
#include "tet2spline/io/mesh_io.h"
#include "tet2spline/param/error.h"
#include "tet2spline/spline/bspline_volume.h"

namespace fs = std::filesystem;

namespace tet2spline::cli {
namespace {

// regions[] of the param stage and of the fit stage, joined by id.
json mergeRegions(const json& param, const json& fit) {
  json out = param.is_array() ? param : json::array();
  if (!fit.is_array()) return out;
  for (const auto& f : fit) {
    bool found = false;
    for (auto& p : out)
      if (p.value("id", -1) == f.value("id", -2)) {
        for (const auto& [key, value] : f.items())
          if (!p.contains(key)) p[key] = value;
        found = true;
      }
    if (!found) out.push_back(f);
  }
  return out;
}

}  // namespace

Command addConvertCommand(CLI::App& app) {
  struct Options {
    InputOptions in;
    ParamStageOptions param;
    FitStageOptions fit;
    std::string outDir;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("convert", "the whole pipeline: solid -> parameterization -> B-spline -> exports");
  o->in.addTo(cmd);
  o->param.addTo(cmd);
  o->fit.addTo(cmd);
  cmd->add_option("-o,--output", o->outDir, "output folder (created if needed)")->required();
  cmd->add_flag("-q,--quiet", globals().quiet, "print no log lines");
  cmd->add_flag("-v,--verbose", globals().verbose, "print every progress message as a log line");
  return {cmd, [o]() {
            o->fit.resolve();
            if (o->param.noTransport && o->param.domain != "ball")
              throw Error(ErrorKind::Usage, "--no-transport gives the harmonic ball map: use it with --domain ball");
            (void)o->param.toParamOptions();  // a bad --density fails before any work
            const bool created = !fs::exists(o->outDir);
            requireOutputFolder(o->outDir);
            try {
              StagedFiles out(o->outDir);
              StageLog log(globals().quiet, globals().verbose);
              LoadedSolid s = loadSolid(o->in.input, o->in.loadOptions(true));
              json report = solidJson(s);
              setPath(report, "timings.load", s.seconds);
              log.stage("load", s.inputKind + " input, " + std::to_string(s.report.vertices) + " vertices, " +
                                    std::to_string(s.report.tets) + " tets, " + std::to_string(s.report.regions.size()) +
                                    " region(s), " + std::to_string(s.report.voids) + " void(s)");
              ParamResult p = runParamStage(s.mesh, o->in.input, o->param, log, report);
              // param.vtu is written on a thread of its own while the fit
              // runs (bunny00: 0.5 s on one core between the two stages, in
              // timings.total but in no stage's); joined before the report,
              // and before `out` goes, also on an exception.
              struct ParamWriter {
                std::thread thread;
                std::exception_ptr error;
                ~ParamWriter() {
                  if (thread.joinable()) thread.join();
                }
              } paramWriter;
              {
                const std::string paramPath = out.stagingPath("param.vtu");
                paramWriter.thread = std::thread([&paramWriter, paramPath, mesh = paramOutputMesh(p, false)] {
                  try {
                    writeTetMesh(mesh, paramPath);
                  } catch (...) {
                    paramWriter.error = std::current_exception();
                  }
                });
              }
              json exports = json::array({out.finalPath("param.vtu")});
              std::unique_ptr<spline::BSplineVolume> volume;
              if (o->param.domain == "cube") {
                o->fit.source = o->in.input;
                volume = std::make_unique<spline::BSplineVolume>();
                json fit = runFitStage(p.mesh, p.U, o->fit, out, log, volume.get());
                for (const auto& [key, value] : fit.items()) {
                  if (key == "regions") {
                    report["regions"] = mergeRegions(report["regions"], value);
                  } else if (key == "exports") {
                    for (const auto& e : value) exports.push_back(e);
                  } else if (key == "warnings" || key == "timings") {
                    for (const auto& item : value.items())
                      if (value.is_array()) report[key].push_back(item.value());
                      else report[key][item.key()] = item.value();
                  } else {
                    report[key] = value;
                  }
                }
              } else if (!s.mesh.voidRegions.empty()) {
                report["warnings"].push_back("the ball parameterization keeps the void tets (tagged in param.vtu)");
              }
              paramWriter.thread.join();
              if (paramWriter.error) std::rethrow_exception(paramWriter.error);
              exports.push_back(out.finalPath("report.json"));
              exports.push_back(out.finalPath("report.html"));
              report["exports"] = exports;
              setPath(report, "timings.total", log.elapsed());
              writeJson(report, out.stagingPath("report.json"));
              writeRunHtml(report, &p, volume.get(), o->in.input, out.stagingPath("report.html"));
              out.commit();
              log.stage("done", "wrote " + std::to_string(exports.size()) + " files to " + o->outDir +
                                    " (open report.html in a browser; param.vtu and spline.vtu in ParaView" +
                                    (volume ? "; spline.step in any CAD viewer)" : ")"));
            } catch (...) {
              std::error_code ec;
              if (created && fs::is_empty(o->outDir, ec)) fs::remove(o->outDir, ec);
              throw;
            }
            return 0;
          }};
}

}  // namespace tet2spline::cli

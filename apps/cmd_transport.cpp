// tet2spline transport POINTS -o OUT --domain {cube,ball}: semi-discrete OT of
// a bare weighted point set (issue 4). POINTS: first line N, then N lines
// "x y z mass" ('#' starts a comment). OUT: first line N, then per point
// "psi cx cy cz" (weight and Laguerre-cell centroid), in input order.
#include <iomanip>
#include <iostream>
#include <memory>

#include "cli_common.h"
#include "tet2spline/io/atomic_file.h"
#include "tet2spline/param/error.h"
#include "tet2spline/param/optimal_transport.h"
#include "weighted_points.h"

namespace tet2spline::cli {

Command addTransportCommand(CLI::App& app) {
  struct Options {
    std::string input, output, report, domain = "cube";
    double tolerance = 1e-6;
    int maxIterations = 100;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("transport", "semi-discrete optimal transport from the cube or ball to weighted points");
  cmd->add_option("POINTS", o->input, "text file: N, then N lines 'x y z mass'")->required();
  cmd->add_option("-o,--output", o->output, "output text file: N, then N lines 'psi cx cy cz'")->required();
  cmd->add_option("--domain", o->domain, "cube [0,1]^3 or the unit ball")->check(CLI::IsMember({"cube", "ball"}))->capture_default_str();
  cmd->add_option("--tolerance", o->tolerance, "largest relative cell-mass error")->check(CLI::Range(1e-12, 0.5))->capture_default_str();
  cmd->add_option("--max-iterations", o->maxIterations, "Newton iterations at most")->check(CLI::Range(1, 10000))->capture_default_str();
  cmd->add_option("--report", o->report, "write the ot.* report as JSON here (it is printed on stdout too)");
  cmd->add_flag("-q,--quiet", globals().quiet, "print no log lines");
  cmd->add_flag("-v,--verbose", globals().verbose, "print every progress message as a log line");
  return {cmd, [o]() {
            requireWritableOutput(o->output);
            if (!o->report.empty()) requireWritableOutput(o->report);
            StageLog log(globals().quiet, globals().verbose);
            const WeightedPoints p = readWeightedPoints(o->input);
            log.stage("load", std::to_string(p.points.rows()) + " points");
            const Domain domain = o->domain == "ball" ? Domain::unitBall() : Domain::unitCube();
            OptimalTransportOptions ot;
            ot.maxRelativeMassError = o->tolerance;
            ot.maxNewtonIterations = o->maxIterations;
            ot.progress = log.progress("transport");
            const OptimalTransportResult r = solveOptimalTransport(p.points, p.masses, domain, ot);
            json j;
            setPath(j, "points", p.points.rows());
            setPath(j, "domain", o->domain);
            setPath(j, "domain_volume", domain.volume());
            setPath(j, "ot.iterations", r.iterations);
            setPath(j, "ot.max_relative_mass_error", r.maxRelativeMassError);
            setPath(j, "ot.step_sizes", r.stepSizes);
            setPath(j, "ot.merged_points", r.mergedPoints);
            setPath(j, "ot.converged", r.status.ok);
            setPath(j, "ot.stalled_above_tolerance", r.stalledAboveTolerance);
            double tri = 0, clip = 0, lin = 0, total = r.startSeconds;
            for (const auto& s : r.iterationStats) {
              tri += s.triangulationSeconds, clip += s.clippingSeconds, lin += s.linearSolveSeconds;
              total += s.triangulationSeconds + s.clippingSeconds + s.assemblySeconds + s.linearSolveSeconds;
            }
            setPath(j, "timings.transport", total);
            setPath(j, "timings.transport_triangulation", tri);
            setPath(j, "timings.transport_clipping", clip);
            setPath(j, "timings.transport_linear_solve", lin);
            std::cout << j.dump(2) << '\n';
            if (!r.status.ok) throw Error(ErrorKind::Numerical, o->input + ": transport: " + r.status.message);
            {
              AtomicFile out(o->output);
              out.stream() << std::setprecision(17) << r.weights.size() << '\n';
              for (Eigen::Index i = 0; i < r.weights.size(); ++i)
                out.stream() << r.weights(i) << ' ' << r.centroids(i, 0) << ' ' << r.centroids(i, 1) << ' '
                             << r.centroids(i, 2) << '\n';
              out.commit();
            }
            if (!o->report.empty()) writeJson(j, o->report);
            if (r.stalledAboveTolerance) log.stage("warning", stalledTransportWarning(r, o->tolerance));
            log.stage("transport", std::to_string(r.iterations) + " Newton iterations, max relative mass error " +
                                       std::to_string(r.maxRelativeMassError) + "; wrote " + o->output);
            return 0;
          }};
}

}  // namespace tet2spline::cli

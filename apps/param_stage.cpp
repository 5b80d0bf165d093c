#include "param_stage.h"

#include <cmath>
#include <sstream>

#include "tet2spline/param/error.h"
#include "tet2spline/param/topology.h"

namespace tet2spline::cli {

void ParamStageOptions::addTo(CLI::App* cmd) {
  cmd->add_option("--domain", domain, "parameter domain: cube (for tensor-product splines) or ball (the paper's)")
      ->check(CLI::IsMember({"cube", "ball"}))->capture_default_str();
  cmd->add_flag("--no-transport", noTransport, "stop at the harmonic ball map (no optimal transport; --domain ball)");
  cmd->add_option("--density", densities,
                  "R=W: region R gets W times the parametric volume per unit physical volume (repeatable)");
  cmd->add_option("--density-field", densityField, "per-tet or per-vertex array of the input holding the density");
  cmd->add_option("--void-density", voidDensity, "density of void regions (default: 1, as any region)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--tolerance", tolerance, "largest relative cell-mass error of the transport")
      ->check(CLI::Range(1e-12, 0.5))->capture_default_str();
  cmd->add_option("--max-iterations", maxIterations, "Newton iterations of the transport at most")
      ->check(CLI::Range(1, 10000))->capture_default_str();
  cmd->add_option("--untangler", untangler,
                  "minimiser of the untangling energy: newton (projected Newton, CHOLMOD) or lbfgs")
      ->check(CLI::IsMember({"newton", "lbfgs"}))->capture_default_str();
  cmd->add_option("--boundary-smoothing", boundarySmoothing,
                  "sweeps of tangential smoothing of the boundary after the transport (0 = none)")
      ->check(CLI::Range(0, 100))->capture_default_str();
  cmd->add_option("--site-stretch", siteStretch,
                  "cube: transport sites from the ball map stretched towards the cube by this exponent "
                  "(0 = the inscribed ball; larger is faster on large meshes but places the measure less exactly)")
      ->check(CLI::Range(0.0, 1.0))->capture_default_str();
  cmd->add_option("--cube-sites", cubeSites,
                  "cube: transport sites from the ball map by the radial stretch (--site-stretch) or by a "
                  "volume-preserving map of the ball onto the cube; auto: equal-volume when the boundary is "
                  "smooth and curved (no creases, sharp tips or large planar faces), else stretch")
      ->check(CLI::IsMember({"auto", "stretch", "equal-volume"}))->capture_default_str();
  cmd->add_option("--interior-smoothing", interiorSmoothing,
                  "sweeps of smoothing of the interior after the boundary's (0 = none)")
      ->check(CLI::Range(0, 100))->capture_default_str();
}

ParamOptions ParamStageOptions::toParamOptions() const {
  ParamOptions o;
  o.domain = domain == "ball" ? ParamDomain::Ball : ParamDomain::Cube;
  o.transport = !noTransport;
  o.boundarySmoothing.sweeps = boundarySmoothing;
  o.boundarySmoothing.interiorSweeps = interiorSmoothing;
  o.cubeSiteStretch = siteStretch;
  o.cubeSites = cubeSites == "equal-volume" ? ParamOptions::CubeSites::EqualVolume
                : cubeSites == "stretch"    ? ParamOptions::CubeSites::Stretch
                                            : ParamOptions::CubeSites::Auto;
  if (o.cubeSites == ParamOptions::CubeSites::EqualVolume && siteStretch != 0)
    throw Error(ErrorKind::Usage, "--site-stretch applies to --cube-sites stretch only");
  for (const std::string& d : densities) {
    const size_t eq = d.find('=');
    std::istringstream rs(d.substr(0, eq == std::string::npos ? 0 : eq)), ws(eq == std::string::npos ? "" : d.substr(eq + 1));
    int region = 0;
    double w = 0;
    char extra = 0;
    if (eq == std::string::npos || !(rs >> region) || (rs >> extra) || !(ws >> w) || (ws >> extra))
      throw Error(ErrorKind::Usage, "--density " + d + ": expected REGION=WEIGHT, e.g. --density 2=4");
    if (!(std::isfinite(w) && w > 0)) throw Error(ErrorKind::Usage, "--density " + d + ": the weight must be > 0");
    o.measure.regionDensity[region] = w;
  }
  o.measure.densityField = densityField;
  o.measure.voidDensity = voidDensity;
  o.transportOptions.maxRelativeMassError = tolerance;
  o.transportOptions.maxNewtonIterations = maxIterations;
  const UntangleMethod method = untangler == "lbfgs" ? UntangleMethod::Lbfgs : UntangleMethod::Newton;
  o.untangle.method = method;
  o.ballMap.untangle.method = method;
  return o;
}

namespace {
json ratiosJson(const ParamResult::VolumeRatios& v) {
  return json{{"p1", v.p1}, {"p50", v.p50}, {"p99", v.p99}, {"min", v.min}, {"max", v.max}};
}
}  // namespace

void addParamReport(json& j, const ParamResult& r) {
  for (const std::string& w : r.warnings) j["warnings"].push_back(w);
  setPath(j, "param.chords_split", r.chordsSplit);
  setPath(j, "param.vertices", r.mesh.numVertices());
  setPath(j, "param.tets", r.mesh.numTets());
  setPath(j, "param.domain_volume", r.domainVolume);
  setPath(j, "param.domain_representation", r.domainRepresentation);
  // Σ of the tets' parametric volumes over |Ω|: short of 1 by the chords
  // inside the sphere and, on the cube, by the triangles cutting across edges.
  if (r.parametricVolume.size() > 0 && r.domainVolume > 0)
    setPath(j, "param.covered_volume_fraction", r.parametricVolume.sum() / r.domainVolume);
  setPath(j, "sphere.flipped_triangles", r.sphere.flippedTriangles);
  setPath(j, "sphere.angle_distortion_mean", r.sphere.angleDistortionMean);
  setPath(j, "sphere.angle_distortion_max", r.sphere.angleDistortionMax);
  setPath(j, "sphere.centre_offset", r.sphere.centreOffset);
  setPath(j, "sphere.method", r.sphere.method);
  setPath(j, "sphere.area_correction_iterations", r.sphere.areaCorrectionIterations);
  setPath(j, "sphere.area_divergence_conformal", r.sphere.areaDivergenceBefore);
  setPath(j, "sphere.area_divergence", r.sphere.areaDivergence);
  setPath(j, "sphere.area_ratio_min", r.sphere.areaRatioMin);
  setPath(j, "sphere.area_ratio_max", r.sphere.areaRatioMax);
  setPath(j, "ball.inverted_tets_before_untangling", r.ball.invertedTetsBeforeUntangling);
  setPath(j, "ball.inverted_tets", r.ball.invertedTets);
  setPath(j, "ball.harmonic_residual", r.ball.harmonicResidual);
  setPath(j, "ball.boundary_slid", r.ball.boundarySlid);
  setPath(j, "ball.boundary_max_distance", r.ballBoundaryMaxDistance);
  setPath(j, "ball.volume_ratio", ratiosJson(r.ballVolumeRatio));
  if (r.ot.ran) {
    setPath(j, "ot.iterations", r.ot.iterations);
    setPath(j, "ot.max_relative_mass_error", r.ot.maxRelativeMassError);
    setPath(j, "ot.step_sizes", r.ot.stepSizes);
    setPath(j, "ot.merged_points", r.ot.mergedPoints);
    setPath(j, "ot.solver_switches", r.ot.solverSwitches);
    setPath(j, "ot.stalled_above_tolerance", r.ot.stalledAboveTolerance);
    setPath(j, "ot.linear_solver", r.ot.linearSolver);
    setPath(j, "ot.amg_iterations", r.ot.amgIterations);
  }
  setPath(j, "param.inverted_tets_before_untangling", r.param.invertedTetsBeforeUntangling);
  setPath(j, "param.finishing_rounds", r.param.finishingRounds);
  setPath(j, "param.split_edges", r.param.splitEdges);
  setPath(j, "param.inverted_tets", r.param.invertedTets);
  setPath(j, "param.flipped_boundary_triangles", r.param.flippedBoundaryTriangles);
  setPath(j, "param.boundary_max_distance", r.param.boundaryMaxDistance);
  setPath(j, "param.corner_vertices", r.param.cornerVertices);
  setPath(j, "param.edge_vertices", r.param.edgeVertices);
  json morph{{"used", r.param.morphed}};
  if (r.param.morphed) morph["rms_distance"] = r.param.morphDistance, morph["max_distance"] = r.param.morphMaxDistance;
  setPath(j, "param.morph", morph);
  if (r.ot.ran)
    setPath(j, "param.boundary_smoothing", json{{"moves", r.param.boundarySmoothingMoves},
                                                {"interior_moves", r.param.interiorSmoothingMoves},
                                                {"refused", r.param.boundarySmoothingRefused},
                                                {"rms_move", r.param.boundarySmoothingRms}});
  setPath(j, "param.volume_ratio", ratiosJson(r.param.volumeRatio));
  setPath(j, "param.misplaced_volume", r.param.misplacedVolume);
  json regions = json::array();
  for (const RegionFigures& g : r.regions)
    regions.push_back({{"id", g.id}, {"void", g.isVoid}, {"physical_volume", g.physicalVolume}, {"density", g.density},
                       {"target_volume_fraction", g.targetVolumeFraction},
                       {"achieved_volume_fraction", g.achievedVolumeFraction}});
  j["regions"] = regions;
  setPath(j, "timings.refine", r.timings.refine);
  setPath(j, "timings.spherical_map", r.timings.sphere);
  setPath(j, "timings.harmonic", r.timings.harmonic);
  setPath(j, "timings.untangle", r.timings.untangle);
  setPath(j, "timings.measure", r.timings.measure);
  if (r.ot.ran) {
    setPath(j, "timings.transport", r.timings.transport);
    setPath(j, "timings.transport_triangulation", r.ot.triangulationSeconds);
    setPath(j, "timings.transport_clipping", r.ot.clippingSeconds);
    setPath(j, "timings.transport_assembly", r.ot.assemblySeconds);
    setPath(j, "timings.transport_linear_solve", r.ot.linearSolveSeconds);
    setPath(j, "timings.composition", r.timings.composition);
    setPath(j, "timings.final_untangle", r.timings.finalUntangle);
    setPath(j, "timings.morph", r.timings.morph);
    setPath(j, "timings.relax", r.timings.relax);
    setPath(j, "timings.boundary_smoothing", r.timings.boundarySmoothing);
  }
  setPath(j, "timings.param", r.timings.total);
}

TetMesh paramOutputMesh(const ParamResult& r, bool mapped) {
  TetMesh out = r.mesh;
  const Eigen::Index nt = out.numTets();
  if (mapped) {
    out.pointFields.push_back({"X", r.mesh.V});
    out.V = r.U;
  } else {
    out.pointFields.push_back({"U", r.U});
  }
  Eigen::MatrixXd ratio(nt, 1), target(nt, 1), inverted(nt, 1);
  for (Eigen::Index t = 0; t < nt; ++t) {
    ratio(t, 0) = r.parametricVolume(t) / r.targetVolume(t);
    target(t, 0) = r.targetVolume(t);
    const Eigen::Vector3d a = r.U.row(out.T(t, 0)), b = r.U.row(out.T(t, 1)), c = r.U.row(out.T(t, 2)), d = r.U.row(out.T(t, 3));
    inverted(t, 0) = orient3d(a.data(), b.data(), c.data(), d.data()) <= 0 ? 1 : 0;
  }
  out.cellFields.push_back({"volume_ratio", ratio});
  out.cellFields.push_back({"target_volume", target});
  out.cellFields.push_back({"inverted", inverted});
  return out;
}

ParamResult runParamStage(const TetMesh& mesh, const std::string& inputName, const ParamStageOptions& options,
                          StageLog& log, json& report) {
  ParamOptions po = options.toParamOptions();
  po.progress = log.progress("param");
  ParamResult r = parameterize(mesh, po);
  addParamReport(report, r);
  setPath(report, "param.untangler", options.untangler);
  const bool cubeTransport = po.domain == ParamDomain::Cube && r.ot.ran;
  const bool equalVolume = r.param.cubeSites == ParamOptions::CubeSites::EqualVolume;
  if (cubeTransport) {
    std::ostringstream sites;
    if (equalVolume)
      sites << "equal-volume";
    else
      sites << "stretch " << po.cubeSiteStretch;
    setPath(report, "param.cube_sites", sites.str());
    setPath(report, "param.cube_sites_requested", options.cubeSites);
    setPath(report, "param.boundary_normal_angle_p99", r.param.boundaryNormalAngleP99);
    setPath(report, "param.boundary_planar_share", r.param.boundaryPlanarShare);
  }
  for (const std::string& w : r.warnings) log.stage("warning", w);
  std::ostringstream line;
  line << (r.ot.ran ? options.domain : std::string("ball (harmonic)")) << ", " << r.mesh.numVertices() << " vertices";
  if (r.chordsSplit) line << " (" << r.chordsSplit << " chords split)";
  line << "; ball map " << r.ball.invertedTets << " inverted";
  if (cubeTransport)
    line << "; sites " << (equalVolume ? "equal-volume" : "stretch")
         << " (boundary normal angle p99 " << r.param.boundaryNormalAngleP99 << "°, planar share "
         << r.param.boundaryPlanarShare << ")";
  if (r.ot.ran) line << "; OT " << r.ot.iterations << " Newton iterations, mass error " << r.ot.maxRelativeMassError;
  line << "; " << r.param.invertedTets << " inverted tets, volume ratio p1/p50/p99 " << r.param.volumeRatio.p1 << '/'
       << r.param.volumeRatio.p50 << '/' << r.param.volumeRatio.p99 << " in " << r.timings.total << " s";
  log.stage("param", line.str());
  if (!r.status.ok) {
    if (const char* dump = std::getenv("T2S_FAILED_REPORT")) writeJson(report, dump);  // diagnostics of a failed run
    throw Error(ErrorKind::Numerical, inputName + ": param: " + r.status.message);
  }
  return r;
}

}  // namespace tet2spline::cli

// The fit stage: fit, checks, exports (see fit_stage.h).
#include "fit_stage.h"

#include <Eigen/LU>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <sstream>
#include <thread>

#include "tet2spline/io/cad_export.h"
#include "tet2spline/io/gismo_export.h"
#include "tet2spline/io/mfem_export.h"
#include "tet2spline/io/spline_vtu.h"
#include "tet2spline/param/error.h"
#include "tet2spline/param/topology.h"
#include "tet2spline/spline/boundary_distance.h"
#include "tet2spline/spline/element_regions.h"
#include "tet2spline/spline/face_coverage.h"
#include "tet2spline/spline/fit.h"

namespace tet2spline::cli {
namespace {

double now() {
  using namespace std::chrono;
  return duration<double>(steady_clock::now().time_since_epoch()).count();
}

std::string fmt(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3g", x);
  return b;
}

const char* const kNeedsCube = "fit needs a cube parameterization (tet2spline param --domain cube)";

}  // namespace

void FitStageOptions::addTo(CLI::App* cmd) {
  cmd->add_option("--degree", degree, "spline degree in every direction")->check(CLI::Range(1, 8))->capture_default_str();
  cmd->add_option("--elements", elementsText, "knot spans per direction: N or Nu,Nv,Nw (default 16)");
  cmd->add_option("--smoothing", smoothing, "weight of the thin-plate smoothing term (dimensionless)")
      ->check(CLI::NonNegativeNumber)->capture_default_str();
  cmd->add_option("--target-error", targetError,
                  "refine uniformly (doubling the elements, at most twice) until the RMS error relative to the "
                  "bounding-box diagonal is below this")
      ->check(CLI::Range(0.0, 1.0));
}

void FitStageOptions::resolve() {
  if (elementsText.empty()) return;
  std::vector<int> n;
  std::stringstream ss(elementsText);
  std::string part;
  while (std::getline(ss, part, ',')) {
    size_t used = 0;
    int v = 0;
    try {
      v = std::stoi(part, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != part.size() || v < 1 || v > 256)
      throw Error(ErrorKind::Usage, "--elements " + elementsText + ": expected N or Nu,Nv,Nw with integers in 1..256");
    n.push_back(v);
  }
  if (n.size() == 1) elements = Eigen::Vector3i::Constant(n[0]);
  else if (n.size() == 3) elements = Eigen::Vector3i(n[0], n[1], n[2]);
  else throw Error(ErrorKind::Usage, "--elements " + elementsText + ": expected N or Nu,Nv,Nw");
}

Eigen::MatrixX3d cubeParameters(const TetMesh& mesh, const std::string& path) {
  const Field* f = mesh.pointField("U");
  if (!f || f->values.cols() != 3 || f->values.rows() != mesh.numVertices())
    throw Error(ErrorKind::Input, path + ": no 3-component point field \"U\"; " + kNeedsCube);
  if (!f->values.allFinite()) throw Error(ErrorKind::Input, path + ": point field U is not finite; " + kNeedsCube);
  const double lo = f->values.minCoeff(), hi = f->values.maxCoeff();
  if (lo < -1e-9 || hi > 1 + 1e-9)
    throw Error(ErrorKind::Input, path + ": point field U spans [" + fmt(lo) + ", " + fmt(hi) +
                                      "], not inside [0,1]^3; " + kNeedsCube);
  return f->values;
}

json runFitStage(const TetMesh& mesh, const Eigen::MatrixX3d& U, const FitStageOptions& options, StagedFiles& out,
                 StageLog& log, spline::BSplineVolume* volumeOut) {
  const std::string& src = options.source;
  if (U.rows() != mesh.numVertices())
    throw Error(ErrorKind::Input, src + ": " + std::to_string(U.rows()) + " parameters for " +
                                      std::to_string(mesh.numVertices()) + " vertices");
  if (mesh.numTets() == 0) throw Error(ErrorKind::Input, src + ": no tets");
  json report;

  // Data: every vertex, weighted by its share of the physical volume (so the
  // least-squares term approximates ∫ |x(u(X)) − X|² dX); boundary vertices flagged.
  double t0 = now();
  const Eigen::Index nv = mesh.numVertices();
  Eigen::VectorXd weight = Eigen::VectorXd::Zero(nv);
  for (Eigen::Index t = 0; t < mesh.numTets(); ++t) {
    Eigen::Matrix3d E;
    for (int c = 0; c < 3; ++c) E.col(c) = (mesh.V.row(mesh.T(t, c + 1)) - mesh.V.row(mesh.T(t, 0))).transpose();
    const double share = std::fabs(E.determinant()) / 24.0;
    for (int c = 0; c < 4; ++c) weight[mesh.T(t, c)] += share;
  }
  const Eigen::MatrixX3i F = boundaryFaces(mesh);
  Eigen::Array<bool, Eigen::Dynamic, 1> boundary = Eigen::Array<bool, Eigen::Dynamic, 1>::Constant(nv, false);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) boundary[F(f, c)] = true;

  // The wedges that boundary triangles cut off the cube's edges and corners
  // get data on their faces (face_coverage.h), weighted like boundary
  // vertices per unit of face area. Measured on part.off (a third of the
  // faces' area uncovered): at 8³ spline volume 16% -> 0.6% above the mesh's,
  // boundary Hausdorff 0.108 -> 0.095 of the diagonal; at 16³ Hausdorff 0.074
  // -> 0.058, volume 1.3% above, but the fit 18 -> 34 s (the validity stage
  // now works on the thin layer the wedges map to). Samples weighted 0.1 or
  // 0.3 of this: Hausdorff 0.081 / 0.070, fit 27 s. fandisk (99.5% of the
  // cube covered) at 8³: Hausdorff 0.0245 -> 0.0253, volume unchanged.
  const int perSide = 4 * std::max(1, options.elements.maxCoeff()) + 1;
  const spline::FaceCoverageSamples cover = spline::uncoveredFaceSamples(U, mesh.V, F, perSide, options.threads);
  const long ncover = cover.U.rows();
  Eigen::MatrixX3d dataU = U, dataX = mesh.V;
  Eigen::VectorXd dataWeight = weight;
  Eigen::Array<bool, Eigen::Dynamic, 1> dataBoundary = boundary;
  if (ncover > 0) {
    const long nb = boundary.count();
    double meanBoundaryWeight = 0;
    for (Eigen::Index i = 0; i < nv; ++i)
      if (boundary[i]) meanBoundaryWeight += weight[i];
    meanBoundaryWeight /= static_cast<double>(std::max<long>(1, nb));
    const double h = 1.0 / (perSide - 1);
    const double sampleWeight = meanBoundaryWeight * h * h * static_cast<double>(nb) / std::max(1e-12, cover.coveredArea);
    dataU.conservativeResize(nv + ncover, 3);
    dataX.conservativeResize(nv + ncover, 3);
    dataU.bottomRows(ncover) = cover.U;
    dataX.bottomRows(ncover) = cover.X;
    dataWeight.conservativeResize(nv + ncover);
    dataWeight.tail(ncover).setConstant(sampleWeight);
    dataBoundary.conservativeResize(nv + ncover);
    dataBoundary.tail(ncover) = true;
  }

  spline::FitOptions fo;
  fo.measuredPoints = nv;
  fo.degree = options.degree;
  fo.elements = options.elements;
  fo.smoothingWeight = options.smoothing;
  fo.targetRmsRelative = options.targetError;
  fo.threads = options.threads;
  fo.progress = log.progress("fit");
  std::ostringstream head;
  head << nv << " points (" << boundary.count() << " on the boundary), degree " << options.degree << ", "
       << options.elements[0] << "x" << options.elements[1] << "x" << options.elements[2] << " elements";
  log.stage("fit", head.str());
  spline::FitResult fit;
  try {
    fit = spline::fitBSplineVolume(dataU, dataX, dataWeight, dataBoundary, fo);
  } catch (const Error& e) {
    if (e.kind() == ErrorKind::Usage) throw Error(ErrorKind::Input, src + ": " + e.what());
    throw;
  }
  const double fitSeconds = now() - t0;
  const spline::BSplineVolume& S = fit.volume;
  if (volumeOut) *volumeOut = fit.volume;

  std::ostringstream reached;
  reached << "reached " << fit.elements[0] << "x" << fit.elements[1] << "x" << fit.elements[2]
          << " elements, relative RMS error " << fmt(fit.rmsErrorRelative) << ", " << fit.negativeGaussPoints << " of "
          << fit.gaussPoints << " Gauss points with det J <= 0 (" << fit.negativeGaussPointsBeforeValidity
          << " before the validity stage), min scaled Jacobian " << fmt(fit.minScaledJacobian);
  if (S.numControlPoints() == 0)
    throw Error(ErrorKind::Numerical, src + ": fit failed: " + fit.status.message + "; no output written");
  if (fit.negativeGaussPoints > 0)
    throw Error(ErrorKind::Numerical, src + ": fit: " + fit.status.message + "; " + reached.str() +
                                          "; no output written");
  log.stage("fit", reached.str() + " in " + fmt(fitSeconds) + " s");

  // The outputs' staging paths, in the report's order.
  std::vector<std::string> names;
  auto stage = [&](const std::string& name) {
    names.push_back(name);
    return out.stagingPath(name);
  };
  const std::string stepPath = stage("spline.step"), igesPath = stage("spline.igs"), xmlPath = stage("spline.xml"),
                    mfemPath = stage("spline.mfem"), regionsPath = stage("spline_regions.gf"),
                    vtuPath = stage("spline.vtu"), netPath = stage("control_net.vtu");
  // STEP and IGES (OpenCASCADE, which nothing else here uses) need only the
  // spline: they are written on a thread of their own while the checks and
  // the other exports run (bunny00 at 16 elements: 0.4 s each, one core).
  // Joined before anything leaves this function, also on an exception.
  struct CadExports {
    std::thread thread;
    std::exception_ptr error;
    ~CadExports() {
      if (thread.joinable()) thread.join();
    }
  } cad;
  cad.thread = std::thread([&cad, &S, &stepPath, &igesPath] {
    try {
      writeStep(S, stepPath);
      writeIges(S, igesPath);
    } catch (...) {
      cad.error = std::current_exception();
    }
  });

  // Checks: boundary distance, element regions.
  t0 = now();
  SurfaceMesh surface{mesh.V, F};
  spline::BoundaryDistanceOptions bo;
  bo.threads = options.threads;
  bo.samplesPerSpan = std::max(2, 64 / std::max(1, fit.elements.maxCoeff()));
  const spline::BoundaryDistance bd = spline::boundaryDistance(S, surface, bo);
  const std::vector<int> elementRegion = spline::elementRegions(S, U, mesh.T, mesh.region);
  const std::vector<spline::RegionElementDensity> density =
      spline::regionElementDensity(elementRegion, mesh.V, U, mesh.T, mesh.region);
  double meshVolume = 0;
  for (const auto& r : density) meshVolume += r.volume;
  const double splineVolume = S.volume();
  const double checkSeconds = now() - t0;
  const double diag = fit.boundingBoxDiagonal;
  log.stage("fit", "boundary Hausdorff distance " + fmt(diag > 0 ? bd.hausdorff / diag : 0) +
                       " of the diagonal, spline volume " + fmt(splineVolume) + " vs mesh " + fmt(meshVolume));

  setPath(report, "spline.degree", options.degree);
  setPath(report, "spline.elements", {fit.elements[0], fit.elements[1], fit.elements[2]});
  setPath(report, "spline.control_points", {S.numControl(0), S.numControl(1), S.numControl(2)});
  setPath(report, "spline.volume", splineVolume);
  setPath(report, "spline.mesh_volume", meshVolume);
  setPath(report, "fit.points", static_cast<long>(nv));
  setPath(report, "fit.boundary_points", static_cast<long>(boundary.count()));
  setPath(report, "fit.face_samples", ncover);
  setPath(report, "fit.covered_face_area", cover.coveredArea);
  setPath(report, "fit.smoothing", fit.smoothingWeight);
  setPath(report, "fit.smoothing_requested", options.smoothing);
  setPath(report, "fit.rms_error_relative", fit.rmsErrorRelative);
  setPath(report, "fit.max_error_relative", fit.maxErrorRelative);
  setPath(report, "fit.boundary_hausdorff_relative", diag > 0 ? bd.hausdorff / diag : 0.0);
  setPath(report, "fit.boundary_spline_to_surface_relative", diag > 0 ? bd.splineToSurface / diag : 0.0);
  setPath(report, "fit.boundary_surface_to_spline_relative", diag > 0 ? bd.surfaceToSpline / diag : 0.0);
  // The means over the samples: the Hausdorff distance is one point's, on a
  // creased model a crease's rounding, and moves with the map's last bits.
  setPath(report, "fit.boundary_mean_spline_to_surface_relative", diag > 0 ? bd.meanSplineToSurface / diag : 0.0);
  setPath(report, "fit.boundary_mean_surface_to_spline_relative", diag > 0 ? bd.meanSurfaceToSpline / diag : 0.0);
  setPath(report, "fit.bounding_box_diagonal", diag);
  setPath(report, "fit.refinements", fit.refinements);
  setPath(report, "fit.validity_iterations", fit.validityIterations);
  if (options.targetError > 0) {
    setPath(report, "fit.target_error", options.targetError);
    setPath(report, "fit.target_error_reached", fit.rmsErrorRelative < options.targetError);
  }
  setPath(report, "jacobian.gauss_points", fit.gaussPoints);
  setPath(report, "jacobian.negative_gauss_points", fit.negativeGaussPoints);
  setPath(report, "jacobian.negative_gauss_points_before_validity", fit.negativeGaussPointsBeforeValidity);
  setPath(report, "jacobian.min_scaled", fit.minScaledJacobian);
  setPath(report, "jacobian.min_det_relative", fit.meanDetJ > 0 ? fit.minDetJ / fit.meanDetJ : 0.0);
  json regions = json::array();
  for (const auto& r : density)
    regions.push_back({{"id", r.id},
                       {"void", mesh.voidRegions.count(r.id) > 0},
                       {"elements", r.elements},
                       {"volume", r.volume},
                       {"parametric_volume", r.parametricVolume},
                       {"elements_per_volume", r.elementsPerVolume}});
  report["regions"] = regions;

  json warnings = json::array();
  if (options.targetError > 0 && !(fit.rmsErrorRelative < options.targetError))
    warnings.push_back("fit: relative RMS error " + fmt(fit.rmsErrorRelative) + " is above --target-error " +
                       fmt(options.targetError) + " after " + std::to_string(fit.refinements) + " refinement(s)");
  if (!mesh.voidRegions.empty()) {
    std::string ids;
    for (int id : mesh.voidRegions) ids += (ids.empty() ? "" : ", ") + std::to_string(id);
    warnings.push_back("voids: the spline covers the filled solid; void elements are tagged (region " + ids +
                       ") in spline.vtu, spline.xml and spline_regions.gf, but the STEP/IGES solid is the outer "
                       "boundary only and does not carry the voids as inner shells");
  }

  // The other exports, into the staging folder of `out`; then the CAD ones'
  // end. (timings.export: from here to that end.)
  t0 = now();
  writeGismoXml(S, xmlPath, elementRegion);
  writeMfemNurbsMesh(S, mfemPath);
  writeMfemElementRegions(S, elementRegion, regionsPath);
  SplineVtuOptions vo;
  vo.samplesPerSpan = std::clamp(48 / std::max(1, fit.elements.maxCoeff()), 1, 4);
  writeSplineVtu(S, vtuPath, elementRegion, vo);
  writeControlNetVtu(S, netPath);
  cad.thread.join();
  if (cad.error) std::rethrow_exception(cad.error);
  const double exportSeconds = now() - t0;
  log.stage("export", std::to_string(names.size()) + " files in " + fmt(exportSeconds) + " s");

  setPath(report, "timings.fit", fitSeconds);
  setPath(report, "timings.fit_checks", checkSeconds);
  setPath(report, "timings.export", exportSeconds);
  json exports = json::array();
  for (const auto& n : names) exports.push_back(out.finalPath(n));
  report["exports"] = exports;
  report["warnings"] = warnings;
  for (const auto& w : warnings) log.stage("warning", w.get<std::string>());
  return report;
}

}  // namespace tet2spline::cli

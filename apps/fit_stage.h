#pragma once
// The fit stage of the command line (design.md, "Trivariate B-spline and
// fitting", "Export"): least-squares B-spline fit of a cube-parameterized tet
// mesh, its checks, and every spline export. `tet2spline fit` runs it on a
// param VTU; `tet2spline convert` runs it after the param stage.

#include <Eigen/Core>
#include <string>

#include "cli_common.h"
#include "tet2spline/io/atomic_file.h"
#include "tet2spline/param/tet_mesh.h"
#include "tet2spline/spline/bspline_volume.h"

namespace tet2spline::cli {

struct FitStageOptions {
  int degree = 3;                        ///< --degree
  Eigen::Vector3i elements{16, 16, 16};  ///< --elements (knot spans per direction)
  double smoothing = 1e-8;               ///< --smoothing (λ of spline/fit.h)
  double targetError = 0;                ///< --target-error: relative RMS error to reach by doubling (0 = off)
  int threads = 2;
  std::string source = "input";          ///< names the input in messages ("part.vtu")

  std::string elementsText;              ///< --elements as given, "N" or "Nu,Nv,Nw" (see resolve())

  /// Adds --degree, --elements, --smoothing, --target-error to a command.
  void addTo(CLI::App* cmd);
  /// After parsing: turns elementsText (if any) into `elements`; throws
  /// Error(Usage) for anything but 1 or 3 positive integers.
  void resolve();
};

/// The parameters U (#V × 3) of a cube parameterization: the point field "U"
/// of a param VTU. Throws Error(Input) "path: ...: fit needs a cube
/// parameterization (tet2spline param --domain cube)" when there is no
/// 3-component point field U, it is not finite, or it leaves [0,1]^3 by more
/// than 1e-9.
Eigen::MatrixX3d cubeParameters(const TetMesh& mesh, const std::string& path);

/// Fits x(U) to the mesh (data: every vertex, weighted by its share of the
/// physical volume of its tets; boundary vertices weighted up so that the
/// spline's faces follow the boundary), checks it (errors, boundary Hausdorff
/// distance, Jacobian at Gauss points, regions of the Bézier elements) and
/// writes into `out`:
///   spline.step, spline.igs (boundary B-rep), spline.xml (G+Smo),
///   spline.mfem (MFEM NURBS mesh) + spline_regions.gf (element regions),
///   spline.vtu (sampled hex grid: detJ, scaledJacobian, region),
///   control_net.vtu.
/// Returns the stage's report: spline.*, fit.*, jacobian.*, regions[] (id,
/// void, elements, volume, parametric_volume, elements_per_volume; merge with
/// the param stage's regions[] by id), timings.fit, timings.fit_checks,
/// timings.export, exports[] (final paths in out's folder), warnings[].
/// Nothing appears in the folder until the caller commits `out`.
///
/// Throws Error(Input) when U does not fit the mesh, Error(Numerical) when
/// the fit fails (det J <= 0 remains at some Gauss point after the validity
/// stage, or the linear solve fails): the message says what was reached.
/// Missing --target-error is not a failure: the report says so in warnings.
/// `volumeOut`, when given, receives the fitted spline (for report.html).
json runFitStage(const TetMesh& mesh, const Eigen::MatrixX3d& U, const FitStageOptions& options, StagedFiles& out,
                 StageLog& log, spline::BSplineVolume* volumeOut = nullptr);

}  // namespace tet2spline::cli

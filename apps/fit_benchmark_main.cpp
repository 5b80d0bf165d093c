// Benchmark of the B-spline volume fit: fits samples of a smooth map of the
// unit cube onto a ball-like solid and prints per-stage seconds, errors,
// Jacobian quality and peak memory.
//
//   tet2spline_fit_bench [--points N] [--elements E] [--degree P] [--threads T]
//                        [--solver cholmod|ceres] [--smoothing L] [--fold A]
//
// --fold A adds A·sin(6πu) to x, which folds the map for A > 1/(6π) and
// exercises the validity stage.
#include <tet2spline/spline/fit.h>

#include <sys/resource.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>

#include "allocator_tuning.h"

using namespace tet2spline::spline;

namespace {
/// Smooth, non-polynomial: the cube [0,1]^3 onto a ball-like solid (the
/// classic cube-to-ball map, scaled), slightly sheared.
Eigen::Vector3d ballLike(const Eigen::Vector3d& u, double fold) {
  const double a = 2 * u[0] - 1, b = 2 * u[1] - 1, c = 2 * u[2] - 1;
  Eigen::Vector3d x(a * std::sqrt(1 - b * b / 2 - c * c / 2 + b * b * c * c / 3),
                    b * std::sqrt(1 - c * c / 2 - a * a / 2 + c * c * a * a / 3),
                    c * std::sqrt(1 - a * a / 2 - b * b / 2 + a * a * b * b / 3));
  x[0] += 0.1 * x[1] + fold * std::sin(6 * M_PI * u[0]);
  return 10.0 * x;
}
double peakMemoryMB() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return ru.ru_maxrss / 1024.0;
}
}  // namespace

int main(int argc, char** argv) {
  tet2spline::apps::useHugePages(argv);
  tet2spline::apps::keepFreedMemory();
  long points = 180000;
  int elements = 16, degree = 3, threads = 2;
  double smoothing = FitOptions{}.smoothingWeight, fold = 0.0;
  std::string solver = "cholmod";
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--points") points = std::atol(v.c_str());
    else if (k == "--elements") elements = std::atoi(v.c_str());
    else if (k == "--degree") degree = std::atoi(v.c_str());
    else if (k == "--threads") threads = std::atoi(v.c_str());
    else if (k == "--solver") solver = v;
    else if (k == "--smoothing") smoothing = std::atof(v.c_str());
    else if (k == "--fold") fold = std::atof(v.c_str());
    else {
      std::fprintf(stderr, "tet2spline_fit_bench: unknown option %s\n", k.c_str());
      return 2;
    }
  }
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  Eigen::MatrixX3d U(points, 3), X(points, 3);
  for (long i = 0; i < points; ++i) {
    U.row(i) << uni(rng), uni(rng), uni(rng);
    X.row(i) = ballLike(U.row(i).transpose(), fold).transpose();
  }
  FitOptions opt;
  opt.degree = degree;
  opt.elements = Eigen::Vector3i::Constant(elements);
  opt.threads = threads;
  opt.smoothingWeight = smoothing;
  opt.linearSolver = solver == "ceres" ? FitOptions::LinearSolver::Ceres : FitOptions::LinearSolver::Cholmod;
  opt.progress = [](double, const std::string& m) {
    std::fprintf(stderr, "  %s\n", m.c_str());
    return true;
  };
  const auto t0 = std::chrono::steady_clock::now();
  const FitResult r = fitBSplineVolume(U, X, {}, {}, opt);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("points %ld elements %d^3 degree %d threads %d solver %s smoothing %g\n", points, elements, degree, threads,
              solver.c_str(), smoothing);
  std::printf("control points %ld\n", static_cast<long>(r.volume.numControlPoints()));
  std::printf("seconds: assembly %.3f linear_solve %.3f validity %.3f evaluation %.3f total %.3f (wall %.3f)\n",
              r.timings.assembly, r.timings.linearSolve, r.timings.validity, r.timings.evaluation, r.timings.total, wall);
  std::printf("error: rms %.3e max %.3e rms_rel %.3e max_rel %.3e\n", r.rmsError, r.maxError, r.rmsErrorRelative,
              r.maxErrorRelative);
  std::printf("jacobian: gauss points %ld non-positive %ld (before validity %ld) min scaled %.4f\n", r.gaussPoints,
              r.negativeGaussPoints, r.negativeGaussPointsBeforeValidity, r.minScaledJacobian);
  std::printf("iterations: validity %d solver %d; status %s %s\n", r.validityIterations, r.solverIterations,
              r.status.ok ? "ok" : "FAILED", r.status.message.c_str());
  std::printf("peak memory %.0f MB\n", peakMemoryMB());
  return r.status.ok ? 0 : 5;
}

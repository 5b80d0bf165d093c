// tet2spline_ot_bench: semi-discrete OT benchmark (design.md, "Semi-discrete
// optimal transport"). N points uniform in the ball of radius 0.45 centred in
// the unit cube (fixed seed), masses uniform in [0.5, 1.5], domain the cube,
// solved to a max relative mass error of 1e-6. Prints iterations, the per-
// iteration split (triangulation, clipping, assembly, linear solve), total
// seconds and peak RSS.
//
// Measured 2026-11-22 (build of commit 1abe7a8), 2 cores
// shared with five other builds (load 4–9, so the solver mostly got one
// core: user ≈ wall at 181k). Medians of 3 runs, cube domain, Jacobi-CG:
//   N      it  diagrams  triang.  clipping  assembly  solve   total   peak RSS
//   10k     8     10      0.68 s   0.75 s    0.04 s   0.07 s   1.9 s    26 MiB
//   100k   10     12     16.4 s   15.8 s     1.1 s    4.2 s   40.9 s   200 MiB
//   181k   10     12     19.1 s   20.5 s     1.8 s    6.3 s   51.7 s   331 MiB
// (181k CPU time 49 s user.) Per diagram at 181k: ~1.3 s regular
// triangulation (sequential) + ~1.5 s clipping. Target was 15 s: not met.
// Ball domain (level 6), same cloud centred at the origin, 100k: 6 iterations,
// 16.4 s.
// Measured 2026-12-01 (commit 82ec024), machine otherwise idle, one run:
//   181k: 10 iterations, 16 diagrams, triangulation 22.3 s (1.4 s each, of
//   which CGAL's insertion alone is 1.1–1.2 s), clipping 18.7 s, assembly
//   2.4 s, solve 6.2 s: 52.8 s, 329 MiB. CGAL's Delaunay_triangulation_3 of
//   the same points takes 1.07 s here, so the 15 s target cannot be met with
//   one regular triangulation per diagram and ~10 Newton iterations.
// Measured 2026-12-03 (cells inside the cube measured from the regular
// triangulation's dual, sites in Hilbert order; machine otherwise idle),
// medians of 3 runs:
//   N      it  diagrams  triang.  clipping  assembly  solve   total   peak RSS
//   10k     8     10      0.47 s   0.21 s    0.03 s   0.05 s   0.9 s    26 MiB
//   100k   10     14      8.2 s    2.7 s     0.6 s    1.6 s   14.4 s   198 MiB
//   181k   10     14     16.4 s    4.6 s     1.4 s    3.9 s   29.3 s   298 MiB
// (runs of the same build vary by ±12%: 181k took 25.9, 29.3 and 32.4 s.)
// Per diagram at 181k: CGAL's insertion ~0.95 s, the copy into flat arrays
// and teardown ~0.15 s, neighbour lists 0.09 s, Hilbert sort and the way
// back to input order 0.1 s; measuring: 0.27 s for the 167k inner cells
// from the dual, 0.05 s clipping the 14k cells on the cube's faces (it was
// 0.9 s clipping all of them). What is left is CGAL's sequential insertion
// times 14 diagrams. A multiscale start (Mérigot 2011: points grouped by 8
// along a Morton order, the groups' OT solved first, each point starting
// from its group's weight and affine extension) was tried and dropped: on
// random points the start hides 38–99% of the sites (a coarse weight is off
// the smooth potential by O(coarse spacing²), far above the squared distance
// of close pairs of fine points), and KMT's Newton needs every cell
// non-empty. Tried again 2026-12-04 with groups of 8 along the Hilbert
// order and a curvature term, so that within a group the fine cells are
// the Voronoi cells of the sites translated to the coarse cell's centroid
// (h_i = h_j + c_j·(y_i − y_j) + ½|y_i − ȳ_j|² − ½|y_j − ȳ_j|², h = (|y|² − ψ)/2;
// coarse levels 22625 and 2829 sites, 1.3 s): at 181k the start still hid
// 108089 of the cells (60%). Between groups the coarse potential is off by
// O(H²), and the map's true Hessian (about 1.4 I here, far from I in
// bunny00's crushed ears) is not the identity the translation assumes.
// --points FILE runs a real input: bunny00's cube problem (181313 sites, the
// harmonic images in the ball of radius 1/2, lumped tet volumes; masses span
// 7e-9 .. 2e-5) needs 59 iterations and 500 s: the Voronoi start leaves cells
// with 1e-12 of their mass (the harmonic map crushes the ears; 10% of the
// tets have a ball/physical volume ratio below 3e-7), and the line search's
// first safe step is 2^-33, then doubles once per iteration.
// Measured 2026-12-04 (commit 6cfec9d), machine otherwise idle:
//   181k: 16.25, 16.21, 15.91 s (median 16.2 s; target 15), 10 iterations,
//   14 diagrams: triangulation 10.0–10.2 s (0.72 s per diagram, of which
//   CGAL's range insertion is 0.63–0.74 s and the copy into flat arrays
//   0.03–0.12 s), clipping 2.0 s, linear solve 2.0–2.1 s, start 1.5 s;
//   297 MiB. Copying the cells on both cores (a handle vector, then a
//   parallel loop) measured slower (18.3–19.8 s) and was dropped; inserting
//   the presorted sites one by one with a hint, in Hilbert or in BRIO order,
//   took 0.75–1.0 s against CGAL's range insertion's 0.6 s.
//   bunny00's cube problem (--points, 181313 sites from `param`, since the
//   nearly equiareal sphere): 23 iterations, 40 diagrams, 68.5 s:
//   triangulation 25.4 s, clipping 11.1 s, linear solve 29.9 s. The damped
//   start (steps 2^-13 .. 2^-2) tightens the CG tolerance to 1e-9 and every
//   later solve takes 400–1200 CG iterations; loosening it 100-fold after
//   each step >= 1/2 cut the solves to 26.9 s with the same steps, not
//   landed (it changes every mesh's transport in the last bits).
// Measured 2026-12-04 (trial diagrams repaired by flips from the current
// one, CG started from (1 − t) × the last direction), machine otherwise idle:
//   181k: 13.3, 11.2, 10.8 s (median 11.2 s; target 15), 10 iterations,
//   16 diagrams: triangulation 5.1–6.2 s (a late Newton step: 0–4000 flips,
//   0.15 s with the neighbour lists, against 0.7–1.0 s for CGAL's
//   insertion; the first iteration's trials from the start need 0.8M flips
//   and fall back to CGAL), clipping 1.6–2.4 s, solve 2.0–2.5 s, start 1.5 s;
//   392 MiB (the diagrams now keep their tets). 100k: 5.8 s; 10k: 0.48 s.
//   bunny00's cube problem (--points): 58.6 and 55.6 s (was 68.5 s), 23
//   iterations, 40 diagrams: triangulation 16–18 s (25.4), clipping 11.3–11.7
//   s, linear solve 26.0–26.6 s (29.9; CG's warm start), 307 MiB. Target 30 s:
//   not met; the solve (400–1000 Jacobi-CG iterations at 1e-9 after the
//   damped start) and the 17 extra diagrams of failed trial steps are what
//   is left.
// Measured 2026-12-05 (CG preconditioned by an aggregation AMG W-cycle,
// aggregation_amg.h; machine otherwise idle, one run each):
//   bunny00's cube problem (--points): --solver amg 39.8 s (linear solve
//   7.6 s, 7–27 CG iterations a system; --solver cg 60.7 s, solve 28.5 s,
//   400–1000), the same 23 iterations and 40 diagrams; the default (Jacobi,
//   the AMG once a system takes more than 200 iterations: here from the
//   first) 35.4 s, solve 7.0 s, 313 MiB.
//   Uniform points, linear solve amg / cg: 30k 0.27 / 0.16 s, 100k 1.5 /
//   0.94 s, 181k 2.1 / 1.9 s (totals 11.2 / 12.2 s): on even cells Jacobi's
//   60–160 iterations cost less than the cycle's set-up, and the default
//   keeps Jacobi there.
// Measured 2026-12-06 (Newton on the log-volumes while the max relative
// error is above 0.1, then KMT's; OptimalTransportOptions::logNewtonAbove;
// the machine ran about a quarter slower than on 12-04 all day), one run
// each, --log-newton 0 (KMT only) against the default:
//   bunny00's cube problem (--points, from its TetGen mesh): 16 iterations,
//   26 diagrams, 21.9 s against 9 iterations, 11 diagrams, 11.1 s.
//   Uniform points: 10k 0.50 / 0.48 s (8 / 6 iterations), 100k 6.7 / 6.4 s
//   (10 / 7), 181k 11.5 / 10.8 s (10 / 7); ball, 100k: 4.6 / 4.8 s (6 / 5).
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "allocator_tuning.h"
#include "tet2spline/param/error.h"
#include "tet2spline/param/optimal_transport.h"
#include "weighted_points.h"

using namespace tet2spline;

namespace {
void usage() {
  std::fprintf(stderr,
               "usage: tet2spline_ot_bench [--n N[,N...]] [--solver auto|amg|cg|ic|cholmod] [--cg-tol T] [--start scaled|zero]\n"
               "                           [--log-newton E] [--domain cube|ball] [--seed S] [--points FILE]\n"
               "  default --n 10000,100000,181000; --points reads a point set in the format of\n"
               "  'tet2spline transport' (first line N, then x y z mass per line) instead; --log-newton E: Newton on\n"
               "  the log-volumes while the max relative mass error is above E (default 0.1; 0: KMT's Newton only)\n");
}
double peakRssMiB() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss / 1024.0;  // kB on Linux
}
}  // namespace

int main(int argc, char** argv) {
  tet2spline::apps::useHugePages(argv);
  tet2spline::apps::keepFreedMemory();
  std::vector<int> sizes = {10000, 100000, 181000};
  OptimalTransportOptions options;
  bool ball = false;
  unsigned seed = 20260101;
  std::string pointsFile;
  for (int a = 1; a < argc; ++a) {
    const std::string arg = argv[a];
    const char* value = a + 1 < argc ? argv[a + 1] : nullptr;
    if (arg == "--n" && value) {
      sizes.clear();
      std::string list = value;
      for (std::size_t p = 0; p < list.size();) {
        std::size_t q = list.find(',', p);
        if (q == std::string::npos) q = list.size();
        sizes.push_back(std::atoi(list.substr(p, q - p).c_str()));
        p = q + 1;
      }
      ++a;
    } else if (arg == "--solver" && value) {
      const std::string s = value;
      if (s == "auto") options.linearSolver = OtLinearSolver::JacobiThenAmgCG;
      else if (s == "amg") options.linearSolver = OtLinearSolver::AggregationAmgCG;
      else if (s == "cg") options.linearSolver = OtLinearSolver::ConjugateGradient;
      else if (s == "ic") options.linearSolver = OtLinearSolver::IncompleteCholeskyCG;
      else if (s == "cholmod") options.linearSolver = OtLinearSolver::Cholmod;
      else {
        std::fprintf(stderr, "tet2spline_ot_bench: unknown --solver '%s' (auto, amg, cg, ic or cholmod)\n", value);
        return 2;
      }
      ++a;
    } else if (arg == "--cg-tol" && value) {
      options.cgTolerance = std::atof(value);
      ++a;
    } else if (arg == "--start" && value) {
      options.start = std::string(value) == "zero" ? OtStart::Zero : OtStart::ScaledVoronoi;
      ++a;
    } else if (arg == "--log-newton" && value) {
      options.logNewtonAbove = std::atof(value);
      ++a;
    } else if (arg == "--domain" && value) {
      ball = std::string(value) == "ball";
      ++a;
    } else if (arg == "--points" && value) {
      pointsFile = value;
      ++a;
    } else if (arg == "--seed" && value) {
      seed = static_cast<unsigned>(std::atoi(value));
      ++a;
    } else {
      usage();
      return 2;
    }
  }
  const Domain domain = ball ? Domain::unitBall() : Domain::unitCube();
  const Eigen::Vector3d centre = domain.center();
  int status = 0;
  if (!pointsFile.empty()) sizes = {-1};
  for (int n : sizes) {
    Eigen::MatrixX3d y;
    Eigen::VectorXd nu;
    if (n < 0) {
      try {
        cli::WeightedPoints p = cli::readWeightedPoints(pointsFile);
        y = std::move(p.points);
        nu = std::move(p.masses);
      } catch (const Error& e) {
        std::fprintf(stderr, "tet2spline_ot_bench: %s\n", e.what());
        return 2;
      }
      n = static_cast<int>(y.rows());
    } else {
      std::mt19937_64 rng(seed);
      std::uniform_real_distribution<double> unit(-1, 1), mass(0.5, 1.5);
      y.resize(n, 3);
      for (int i = 0; i < n; ++i) {
        Eigen::Vector3d p;
        do p = Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
        while (p.squaredNorm() > 1);
        y.row(i) = (centre + 0.45 * p).transpose();
      }
      nu.resize(n);
      for (int i = 0; i < n; ++i) nu[i] = mass(rng);
    }

    const auto t0 = std::chrono::steady_clock::now();
    const OptimalTransportResult r = solveOptimalTransport(y, nu, domain, options);
    const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

    std::printf("N = %d  %s  iterations %d  max rel. mass error %.3g\n", n, r.status.ok ? "converged" : "FAILED",
                r.iterations, r.maxRelativeMassError);
    if (!r.status.ok) {
      std::printf("  %s\n", r.status.message.c_str());
      status = 1;
    }
    std::printf("  %4s %10s %5s %8s %8s %8s %6s %8s %8s %8s %8s %10s   (step: L = log-volume Newton; cg: * = AMG)\n",
                "it", "step", "evals", "repaired", "rejected", "flips", "cg", "triang", "clip", "assemble", "solve",
                "rel.err");
    double sums[4] = {0, 0, 0, 0};
    for (std::size_t k = 0; k < r.iterationStats.size(); ++k) {
      const OtIterationStats& s = r.iterationStats[k];
      std::printf("  %4zu %9.3g%c %5d %8d %8d %8ld %5d%c %8.3f %8.3f %8.3f %8.3f %10.3g\n",
                  k + 1, s.stepSize, s.logVolumes ? 'L' : ' ', s.evaluations, s.repairedDiagrams, s.rejectedDiagrams,
                  s.flips, s.linearIterations, s.amg ? '*' : ' ', s.triangulationSeconds, s.clippingSeconds, s.assemblySeconds,
                  s.linearSolveSeconds, s.maxRelativeMassError);
      sums[0] += s.triangulationSeconds;
      sums[1] += s.clippingSeconds;
      sums[2] += s.assemblySeconds;
      sums[3] += s.linearSolveSeconds;
    }
    std::printf("  start %.3f s  triangulation %.3f s  clipping %.3f s  assembly %.3f s  linear solve %.3f s\n",
                r.startSeconds, sums[0], sums[1], sums[2], sums[3]);
    std::printf("  TOTAL %.3f s  peak RSS %.0f MiB\n", total, peakRssMiB());
    std::fflush(stdout);
  }
  return status;
}

#include "tet2spline/param/boundary_smoothing.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>
#include <atomic>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "colouring.h"
#include "spd_solver.h"
#include "tet2spline/param/error.h"
#include "tet2spline/param/topology.h"

namespace tet2spline {
namespace {

double tetVolume6(const Eigen::MatrixX3d& P, const Eigen::MatrixX4i& T, int t) {
  const Eigen::Vector3d a = P.row(T(t, 0));
  return (P.row(T(t, 1)).transpose() - a).cross(P.row(T(t, 2)).transpose() - a).dot(P.row(T(t, 3)).transpose() - a);
}

// Exact orientation of four points (MatrixX3d is column-major: rows are copied).
int orient(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c, const Eigen::Vector3d& d) {
  return orient3d(a.data(), b.data(), c.data(), d.data());
}

// Bits of the coordinates pinned to 0 or 1 (cube); 7 = a corner.
int pinnedBits(const Eigen::RowVector3d& u) {
  int bits = 0;
  for (int k = 0; k < 3; ++k)
    if (u[k] == 0.0 || u[k] == 1.0) bits |= 1 << k;
  return bits;
}

}  // namespace

BoundarySmoothingResult smoothBoundary(const Eigen::MatrixX3d& X, const Eigen::MatrixX4i& T, const Eigen::MatrixX3d& U,
                                       const Eigen::MatrixX3i& faces, const BoundarySmoothingOptions& options) {
  const Eigen::Index nv = X.rows(), nt = T.rows();
  if (U.rows() != nv)
    throw Error(ErrorKind::Input, "smoothBoundary: " + std::to_string(U.rows()) + " parameters for " +
                                      std::to_string(nv) + " vertices");
  if (nt > 0 && (T.minCoeff() < 0 || T.maxCoeff() >= nv))
    throw Error(ErrorKind::Input, "smoothBoundary: a tet's vertex index is out of range");
  if (options.targetVolumes.size() != 0 && options.targetVolumes.size() != nt)
    throw Error(ErrorKind::Input, "smoothBoundary: " + std::to_string(options.targetVolumes.size()) +
                                      " target volumes for " + std::to_string(nt) + " tets");
  if (!options.held.empty() && static_cast<Eigen::Index>(options.held.size()) != nv)
    throw Error(ErrorKind::Input, "smoothBoundary: " + std::to_string(options.held.size()) + " held flags for " +
                                      std::to_string(nv) + " vertices");
  if (faces.rows() > 0 && (faces.minCoeff() < 0 || faces.maxCoeff() >= nv))
    throw Error(ErrorKind::Input, "smoothBoundary: a boundary triangle's vertex index is out of range");

  BoundarySmoothingResult result;
  result.U = U;
  if ((options.sweeps <= 0 && options.interiorSweeps <= 0) || faces.rows() == 0) return result;
  Eigen::MatrixX3d& P = result.U;
  const bool cube = options.shape == BoundaryShape::UnitCube;
  const Eigen::Vector3d apex = cube ? Eigen::Vector3d(0.5, 0.5, 0.5) : Eigen::Vector3d::Zero();

  const detail::VertexTets tetsOf = detail::vertexTets(nv, T);  // corners 4t + k per vertex
  std::vector<std::vector<int>> facesOf(static_cast<size_t>(nv));
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    for (int c = 0; c < 3; ++c) facesOf[static_cast<size_t>(faces(f, c))].push_back(static_cast<int>(f));
  std::vector<int> boundary;
  for (Eigen::Index i = 0; i < nv; ++i)
    if (!facesOf[static_cast<size_t>(i)].empty()) boundary.push_back(static_cast<int>(i));

  // Boundary neighbours of each boundary vertex, and its tangent plane in X.
  std::vector<std::vector<int>> ring(static_cast<size_t>(nv));
  std::vector<Eigen::Matrix<double, 3, 2>> tangent(static_cast<size_t>(nv));
  for (int i : boundary) {
    std::vector<int>& r = ring[static_cast<size_t>(i)];
    Eigen::Vector3d normal = Eigen::Vector3d::Zero();
    for (int f : facesOf[static_cast<size_t>(i)]) {
      for (int c = 0; c < 3; ++c)
        if (faces(f, c) != i) r.push_back(faces(f, c));
      const Eigen::Vector3d a = X.row(faces(f, 0)), b = X.row(faces(f, 1)), c = X.row(faces(f, 2));
      normal += (b - a).cross(c - a);
    }
    std::sort(r.begin(), r.end());
    r.erase(std::unique(r.begin(), r.end()), r.end());
    const Eigen::Vector3d n = normal.normalized();
    const Eigen::Vector3d seed = std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
    const Eigen::Vector3d t1 = n.cross(seed).normalized();
    tangent[static_cast<size_t>(i)].col(0) = t1;
    tangent[static_cast<size_t>(i)].col(1) = n.cross(t1);
  }

  // The value at x_i of the affine function of the tangent coordinates that
  // fits the neighbours' U in least squares; false if they span no plane.
  auto localFit = [&](int i, const std::vector<int>& nb, Eigen::RowVector3d& value) {
    if (nb.size() < 3) return false;
    const Eigen::Matrix<double, 3, 2>& B = tangent[static_cast<size_t>(i)];
    Eigen::Matrix3d AtA = Eigen::Matrix3d::Zero();
    Eigen::Matrix3d AtR = Eigen::Matrix3d::Zero();
    for (int j : nb) {
      const Eigen::Vector2d d = B.transpose() * (X.row(j) - X.row(i)).transpose();
      const Eigen::Vector3d a(1.0, d.x(), d.y());
      AtA += a * a.transpose();
      AtR += a * P.row(j);
    }
    // The neighbours must spread in two directions: the centred scatter's
    // smaller eigenvalue at least 1e-3 of the larger.
    const double m = AtA(0, 0);
    const Eigen::Matrix2d S = AtA.block<2, 2>(1, 1) - AtA.block<2, 1>(1, 0) * AtA.block<1, 2>(0, 1) / m;
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(S, Eigen::EigenvaluesOnly);
    if (!(eig.eigenvalues()(0) > 1e-3 * eig.eigenvalues()(1))) return false;
    value = AtA.ldlt().solve(AtR).row(0);
    return value.allFinite();
  };

  const bool measured = options.targetVolumes.size() == nt;
  auto misfit = [&](int t, double volume6) {  // (a tet without a positive target does not count)
    const double target = options.targetVolumes(t);
    if (!(target > 0) || !std::isfinite(target)) return 0.0;
    const double l = std::log(volume6 / (6 * target));
    return l * l;
  };
  // Per tet: 6 × its volume in P and its misfit, kept up to date as the
  // vertices move (a taken move writes its star's new values), so a vertex's
  // "before" is read, not recomputed with a log per tet: the same values.
  std::vector<double> volume6(static_cast<size_t>(nt)), misfitOf(static_cast<size_t>(measured ? nt : 0));
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, nt, 4096), [&](const tbb::blocked_range<Eigen::Index>& r) {
    for (Eigen::Index t = r.begin(); t != r.end(); ++t) {
      volume6[static_cast<size_t>(t)] = tetVolume6(P, T, static_cast<int>(t));
      if (measured) misfitOf[static_cast<size_t>(t)] = misfit(static_cast<int>(t), volume6[static_cast<size_t>(t)]);
    }
  });
  // A move's scratch (one per thread): the trial's values over the star.
  struct Scratch {
    std::vector<double> after, misfitAfterOf;
    double misfitBefore = 0;
  };
  tbb::enumerable_thread_specific<Scratch> scratches;
  auto acceptable = [&](int i, Scratch& scratch) {
    std::vector<double>& after = scratch.after;
    std::vector<double>& misfitAfterOf = scratch.misfitAfterOf;
    const double misfitBefore = scratch.misfitBefore;
    double misfitAfter = 0;
    after.clear();
    misfitAfterOf.clear();
    // Every test refuses the move, so their order does not change which
    // moves are taken: the cheap volume test first, the exact orientation
    // only for a tet that keeps its volume, and the misfit's partial sum
    // (of terms >= 0, so it never falls) refuses as soon as it is above.
    for (int k = tetsOf.offset[static_cast<size_t>(i)]; k < tetsOf.offset[static_cast<size_t>(i) + 1]; ++k) {
      const int t = tetsOf.corner[static_cast<size_t>(k)] / 4;
      const double v = tetVolume6(P, T, t);
      if (v < options.minVolumeKept * volume6[static_cast<size_t>(t)]) return false;
      if (orient(P.row(T(t, 0)), P.row(T(t, 1)), P.row(T(t, 2)), P.row(T(t, 3))) <= 0) return false;
      after.push_back(v);
      if (measured) {
        misfitAfterOf.push_back(misfit(t, v));
        misfitAfter += misfitAfterOf.back();
        if (misfitAfter > misfitBefore) return false;
      }
    }
    for (int f : facesOf[static_cast<size_t>(i)]) {
      if (orient(apex, P.row(faces(f, 0)), P.row(faces(f, 1)), P.row(faces(f, 2))) <= 0) return false;
    }
    return true;
  };

  // Moves vertex i `step` of the way to target, halving the step up to four
  // times until the move is acceptable; `project` puts a trial position on
  // ∂Ω (false: that trial is skipped). Restores i and returns false if no
  // trial is taken.
  auto moveTowards = [&](int i, const Eigen::RowVector3d& target, const auto& project) {
    Scratch& scratch = scratches.local();
    const Eigen::RowVector3d old = P.row(i);
    const int k0 = tetsOf.offset[static_cast<size_t>(i)], k1 = tetsOf.offset[static_cast<size_t>(i) + 1];
    scratch.misfitBefore = 0;
    if (measured)
      for (int k = k0; k < k1; ++k)
        scratch.misfitBefore += misfitOf[static_cast<size_t>(tetsOf.corner[static_cast<size_t>(k)] / 4)];
    double s = options.step;
    for (int halving = 0; halving <= 4; ++halving, s *= 0.5) {
      Eigen::RowVector3d p = old + s * (target - old);
      if (!project(p)) continue;
      P.row(i) = p;
      if (acceptable(i, scratch)) {
        for (int k = k0; k < k1; ++k) {
          const auto t = static_cast<size_t>(tetsOf.corner[static_cast<size_t>(k)] / 4);
          volume6[t] = scratch.after[static_cast<size_t>(k - k0)];
          if (measured) misfitOf[t] = scratch.misfitAfterOf[static_cast<size_t>(k - k0)];
        }
        return true;
      }
    }
    P.row(i) = old;
    return false;
  };

  auto isHeld = [&](int i) { return !options.held.empty() && options.held[static_cast<size_t>(i)]; };

  // Each vertex's neighbours through its tets (sorted, without repeats).
  std::vector<std::vector<int>> neighbours(static_cast<size_t>(nv));
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, nv, 1024), [&](const tbb::blocked_range<Eigen::Index>& r) {
    for (Eigen::Index iv = r.begin(); iv != r.end(); ++iv) {
      std::vector<int>& nb = neighbours[static_cast<size_t>(iv)];
      for (int k = tetsOf.offset[static_cast<size_t>(iv)]; k < tetsOf.offset[static_cast<size_t>(iv) + 1]; ++k) {
        const int t = tetsOf.corner[static_cast<size_t>(k)] / 4;
        for (int c = 0; c < 4; ++c)
          if (T(t, c) != iv) nb.push_back(T(t, c));
      }
      std::sort(nb.begin(), nb.end());
      nb.erase(std::unique(nb.begin(), nb.end()), nb.end());
    }
  });
  // Colours: greedy in index order, no two vertices of a tet alike. A move
  // reads and writes only its vertex's star (its tets, their volumes and
  // misfits, its neighbours' positions), so the vertices of one colour move
  // independently, on both cores, and the result is the same whatever the
  // threads do. (Sweeps in index order, one core: bunny00's 181k vertices,
  // 2 boundary and 4 interior sweeps, 2.7 s.)
  std::vector<std::vector<int>> colourClasses;
  {
    std::vector<int> all(static_cast<size_t>(nv)), colour(static_cast<size_t>(nv), -1);
    std::iota(all.begin(), all.end(), 0);
    colourClasses = detail::greedyColourClasses(all, colour, [&](int v, const auto& visit) {
      for (int u : neighbours[static_cast<size_t>(v)]) visit(u);
    });
  }
  // Runs move(i) for every vertex of `which`, colour by colour.
  auto sweepByColour = [&](const std::vector<char>& which, const auto& move) {
    for (const std::vector<int>& cls : colourClasses)
      tbb::parallel_for(tbb::blocked_range<size_t>(0, cls.size(), 256), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t q = r.begin(); q != r.end(); ++q)
          if (which[static_cast<size_t>(cls[q])]) move(cls[q]);
      });
  };
  std::atomic<long> moves{0}, interiorMoves{0}, refused{0};

  std::vector<char> movesOnBoundary(static_cast<size_t>(nv), 0);
  for (int i : boundary) movesOnBoundary[static_cast<size_t>(i)] = !isHeld(i);
  for (int sweep = 0; sweep < options.sweeps; ++sweep) {
    sweepByColour(movesOnBoundary, [&](int i) {
      const Eigen::RowVector3d old = P.row(i);
      Eigen::RowVector3d target;
      int pinned = 0;
      if (cube) {
        pinned = pinnedBits(old);
        const int count = __builtin_popcount(static_cast<unsigned>(pinned));
        if (count == 0 || count == 3) return;  // (not on the cube: left alone; corners stay)
        std::vector<int> same;
        for (int j : ring[static_cast<size_t>(i)]) {
          bool onIt = true;
          for (int k = 0; k < 3; ++k)
            if ((pinned >> k & 1) && P(j, k) != old[k]) onIt = false;
          if (onIt) same.push_back(j);
        }
        if (count == 2) {
          if (same.size() != 2) return;
          const double da = (X.row(same[0]) - X.row(i)).norm(), db = (X.row(same[1]) - X.row(i)).norm();
          if (!(da + db > 0)) return;
          target = (db * P.row(same[0]) + da * P.row(same[1])) / (da + db);
        } else {
          if (!localFit(i, same, target)) return;
        }
      } else if (!localFit(i, ring[static_cast<size_t>(i)], target)) {
        return;
      }
      const bool taken = moveTowards(i, target, [&](Eigen::RowVector3d& p) {
        if (!cube) {
          p /= p.norm();
          return true;
        }
        bool inside = true;
        for (int k = 0; k < 3; ++k) {
          if (pinned >> k & 1) p[k] = old[k];
          else if (!(p[k] > 0.0 && p[k] < 1.0)) inside = false;
        }
        return inside;
      });
      if (taken) ++moves;
      else ++refused;
    });
  }
  // Interior sweeps: the same rule with the affine function of x in 3D
  // fitted to the vertex's neighbours through its tets.
  if (options.interiorSweeps > 0) {
    // What depends only on X, once and on both cores: the scale of each
    // interior vertex's neighbours, and the fit's normal matrix AtA,
    // factored, for those whose neighbours spread in three directions (the
    // sweeps then only sum AtR).
    struct InteriorFit {
      double scale = 0;
      Eigen::LDLT<Eigen::Matrix4d> ldlt;
      bool usable = false;
    };
    std::vector<InteriorFit> fits(static_cast<size_t>(nv));
    tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, nv, 1024), [&](const tbb::blocked_range<Eigen::Index>& r) {
      for (Eigen::Index iv = r.begin(); iv != r.end(); ++iv) {
        const int i = static_cast<int>(iv);
        if (!facesOf[static_cast<size_t>(i)].empty()) continue;
        const int k0 = tetsOf.offset[static_cast<size_t>(i)], k1 = tetsOf.offset[static_cast<size_t>(i) + 1];
        if (k0 == k1) continue;
        InteriorFit& fit = fits[static_cast<size_t>(i)];
        const std::vector<int>& nb = neighbours[static_cast<size_t>(i)];
        if (nb.size() < 4) continue;
        double scale = 0;
        for (int j : nb) scale = std::max(scale, (X.row(j) - X.row(i)).norm());
        if (!(scale > 0)) continue;
        Eigen::Matrix4d AtA = Eigen::Matrix4d::Zero();
        for (int j : nb) {
          const Eigen::Vector3d d = (X.row(j) - X.row(i)).transpose() / scale;
          const Eigen::Vector4d a(1.0, d.x(), d.y(), d.z());
          AtA += a * a.transpose();
        }
        // The neighbours must spread in three directions.
        const Eigen::Matrix3d S =
            AtA.block<3, 3>(1, 1) - AtA.block<3, 1>(1, 0) * AtA.block<1, 3>(0, 1) / AtA(0, 0);
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(S, Eigen::EigenvaluesOnly);
        if (!(eig.eigenvalues()(0) > 1e-3 * eig.eigenvalues()(2))) continue;
        fit.scale = scale;
        fit.ldlt.compute(AtA);
        fit.usable = true;
      }
    });
    std::vector<char> movesInside(static_cast<size_t>(nv), 0);
    for (Eigen::Index iv = 0; iv < nv; ++iv)
      movesInside[static_cast<size_t>(iv)] = fits[static_cast<size_t>(iv)].usable && !isHeld(static_cast<int>(iv));
    for (int sweep = 0; sweep < options.interiorSweeps; ++sweep) {
      sweepByColour(movesInside, [&](int i) {
        const InteriorFit& fit = fits[static_cast<size_t>(i)];
        Eigen::Matrix<double, 4, 3> AtR = Eigen::Matrix<double, 4, 3>::Zero();
        for (int j : neighbours[static_cast<size_t>(i)]) {
          const Eigen::Vector3d d = (X.row(j) - X.row(i)).transpose() / fit.scale;
          const Eigen::Vector4d a(1.0, d.x(), d.y(), d.z());
          AtR += a * P.row(j);
        }
        const Eigen::RowVector3d target = fit.ldlt.solve(AtR).row(0);
        if (!target.allFinite()) return;
        if (moveTowards(i, target, [](Eigen::RowVector3d&) { return true; })) ++interiorMoves;
        else ++refused;
      });
    }
  }
  result.moves = moves;
  result.interiorMoves = interiorMoves;
  result.refused = refused;
  double sum = 0;
  for (int i : boundary) sum += (P.row(i) - U.row(i)).squaredNorm();
  result.rmsMove = boundary.empty() ? 0 : std::sqrt(sum / static_cast<double>(boundary.size()));
  return result;
}

}  // namespace tet2spline

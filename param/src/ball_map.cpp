// Solid -> unit ball: spherical map of the outer shell, harmonic interior, untangling.
#include "tet2spline/param/ball_map.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <numeric>
#include <optional>
#include <thread>

#include "harmonic_system.h"
#include "tet_faces.h"
#include "tet2spline/param/harmonic_map.h"
#include "tet2spline/param/topology.h"

namespace tet2spline {

namespace {

double secondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Outward boundary triangles: faces used by one tet, in the order of their
// sorted vertices (detail::tetFaces). For a positive tet (a,b,c,d) the
// faces (b,c,d), (a,d,c), (a,b,d), (a,c,b) face outward.
Eigen::MatrixX3i outwardBoundaryFaces(const Eigen::MatrixX4i& T) {
  const detail::TetFaces faces = detail::tetFaces(T, false);
  if (faces.nonManifoldFaces > 0)
    throw Error(ErrorKind::Topology, "mapToBall: a triangle is shared by " + std::to_string(faces.firstNonManifoldUses) +
                                         " tets (non-manifold solid)");
  return detail::boundaryMatrix(faces);
}

// Number of edge-connected shells of a triangle set.
int countShells(const Eigen::MatrixX3i& F, Eigen::Index nv) {
  std::vector<int> parent(static_cast<size_t>(nv));
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  std::vector<char> used(static_cast<size_t>(nv), 0);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) used[F(f, k)] = 1, parent[find(F(f, k))] = find(F(f, (k + 1) % 3));
  int shells = 0;
  for (Eigen::Index v = 0; v < nv; ++v) shells += used[v] && find(static_cast<int>(v)) == v;
  return shells;
}

}  // namespace

BallMapResult mapToBall(const TetMesh& mesh, const BallMapOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const Eigen::Index nv = mesh.V.rows();
  BallMapResult result;
  auto stopped = [&](double fraction, const std::string& what) {
    if (options.progress && !options.progress(fraction, what)) {
      result.status = Status::failure("mapToBall: stopped by the progress callback after " + what);
      result.stopped = true;
      return true;
    }
    return false;
  };
  if (mesh.T.rows() == 0) throw Error(ErrorKind::Input, "mapToBall: the mesh has no tets");
  if (mesh.T.minCoeff() < 0 || mesh.T.maxCoeff() >= nv)
    throw Error(ErrorKind::Input, "mapToBall: tet vertex index out of range [0, " + std::to_string(nv) + ")");

  // 1. Outer shell, compacted to its own vertices.
  auto t0 = std::chrono::steady_clock::now();
  result.boundaryFaces = outwardBoundaryFaces(mesh.T);
  const int shells = countShells(result.boundaryFaces, nv);
  if (shells != 1)
    throw Error(ErrorKind::Topology, "mapToBall: the boundary has " + std::to_string(shells) +
                                         " shells; fill voids with tets first (only a topological ball maps to a ball)");
  std::vector<int> local(static_cast<size_t>(nv), -1);
  std::vector<int> boundary;
  for (Eigen::Index f = 0; f < result.boundaryFaces.rows(); ++f)
    for (int k = 0; k < 3; ++k) local[result.boundaryFaces(f, k)] = 0;
  for (Eigen::Index v = 0; v < nv; ++v)
    if (local[v] == 0) local[v] = static_cast<int>(boundary.size()), boundary.push_back(static_cast<int>(v));
  result.boundaryVertices = Eigen::Map<const Eigen::VectorXi>(boundary.data(), static_cast<Eigen::Index>(boundary.size()));
  SurfaceMesh shell;
  shell.V.resize(static_cast<Eigen::Index>(boundary.size()), 3);
  for (size_t b = 0; b < boundary.size(); ++b) shell.V.row(static_cast<Eigen::Index>(b)) = mesh.V.row(boundary[b]);
  shell.F.resize(result.boundaryFaces.rows(), 3);
  for (Eigen::Index f = 0; f < shell.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) shell.F(f, k) = local[result.boundaryFaces(f, k)];
  result.timings.boundary = secondsSince(t0);
  if (stopped(0.02, "boundary extraction")) return result;

  // 2. Sphere; beside it, on a thread of its own, the harmonic map's system
  // (stiffness and its factorisation), which needs the boundary vertices
  // but not their places. The spherical map's factorisations run on one
  // core (CHOLMOD with the install's serial BLAS), so the other core did
  // little there. Measured on bunny00 (`convert`, 181k vertices, one run
  // each, the same maps bit for bit): the harmonic stage 0.95 -> 0.05 s,
  // the spherical map 8.15 -> 8.26 s; peak memory 673 -> 725 MiB (`param`).
  // An early return waits for the thread (`join`); its error, if any, is
  // raised when the harmonic map needs it.
  std::optional<detail::HarmonicSystem> harmonicSystem;
  std::exception_ptr harmonicError;
  // (The thread keeps its own copy of the boundary: an early return may move
  // `result` before the guard joins.)
  std::thread prepareHarmonic([&, boundaryVertices = result.boundaryVertices] {
    try {
      harmonicSystem.emplace(mesh.V, mesh.T, boundaryVertices);
    } catch (...) {
      harmonicError = std::current_exception();
    }
  });
  struct Join {
    std::thread& thread;
    ~Join() {
      if (thread.joinable()) thread.join();
    }
  } join{prepareHarmonic};
  t0 = std::chrono::steady_clock::now();
  SphericalMapOptions sphereOptions = options.sphere;
  sphereOptions.progress = {};
  if (options.progress)
    sphereOptions.progress = [&](double f, const std::string& m) { return options.progress(0.02 + 0.23 * f, m); };
  SphericalMapResult sphere = sphericalMap(shell, sphereOptions);
  result.timings.sphere = secondsSince(t0);
  result.sphere.flippedTriangles = sphere.flippedTriangles;
  result.sphere.angleDistortionMean = sphere.angleDistortionMean;
  result.sphere.angleDistortionMax = sphere.angleDistortionMax;
  result.sphere.centreOffset = sphere.centreOffset;
  result.sphere.method = sphere.method;
  result.sphere.areaCorrectionIterations = sphere.areaCorrectionIterations;
  result.sphere.areaDivergenceBefore = sphere.areaDivergenceBefore;
  result.sphere.areaDivergence = sphere.areaDivergence;
  result.sphere.areaRatioMin = sphere.areaRatioMin;
  result.sphere.areaRatioMax = sphere.areaRatioMax;
  if (!sphere.status.ok) {
    result.status = sphere.status;
    return result;
  }
  // Exactly unit length (to rounding) before anything depends on it.
  for (Eigen::Index b = 0; b < sphere.U.rows(); ++b) sphere.U.row(b) /= sphere.U.row(b).norm();
  if (stopped(0.25, "spherical map")) return result;

  // 3. Harmonic interior.
  t0 = std::chrono::steady_clock::now();
  prepareHarmonic.join();
  if (harmonicError) std::rethrow_exception(harmonicError);
  HarmonicMapResult harmonic = harmonicSystem->solve(sphere.U);
  result.timings.harmonic = secondsSince(t0);
  result.ball.harmonicResidual = harmonic.relativeResidual;
  result.ball.solver = harmonic.solver;
  if (!harmonic.status.ok) {
    result.status = harmonic.status;
    return result;
  }
  result.U = std::move(harmonic.U);
  if (stopped(0.6, "harmonic map")) return result;

  // 4. Untangle with the sphere fixed.
  t0 = std::chrono::steady_clock::now();
  std::vector<bool> fixed(static_cast<size_t>(nv), false);
  for (int b : boundary) fixed[b] = true;
  if (options.untangleMap) {
    UntangleOptions untangleOptions = options.untangle;
    untangleOptions.progress = {};
    if (options.progress) untangleOptions.progress = [&](double, const std::string& m) { return options.progress(-1, m); };
    // Inverted tets whose four vertices are on the sphere: only sliding helps.
    int locked = 0;
    for (Eigen::Index t = 0; t < mesh.T.rows(); ++t) {
      Eigen::Vector3d p[4];
      bool onSphere = true;
      for (int k = 0; k < 4; ++k) p[k] = result.U.row(mesh.T(t, k)).transpose(), onSphere = onSphere && fixed[mesh.T(t, k)];
      locked += onSphere && orient3d(p[0].data(), p[1].data(), p[2].data(), p[3].data()) <= 0;
    }
    UntangleResult untangled;
    if (locked == 0) {
      untangled = untangle(mesh.V, mesh.T, result.U, fixed, untangleOptions);
    } else {
      untangled.U = result.U;
      untangled.invertedBefore = untangled.invertedAfter = countNonPositiveTets(result.U, mesh.T);
    }
    result.ball.invertedTetsBeforeUntangling = untangled.invertedBefore;
    result.ball.untangleIterations = untangled.lbfgsIterations + untangled.newtonIterations;
    if (untangled.invertedAfter > 0) {
      // Some inversions need the boundary to move (e.g. a tet with four
      // boundary vertices inverted by the spherical map): let the boundary
      // slide on the sphere, with its triangles kept unflipped.
      untangleOptions.sphereFaces = result.boundaryFaces;
      std::fill(fixed.begin(), fixed.end(), false);
      const int iterations = untangled.lbfgsIterations;
      untangled = untangle(mesh.V, mesh.T, untangled.U, fixed, untangleOptions);
      untangled.lbfgsIterations += iterations;
      result.ball.boundarySlid = true;
      result.sphere.flippedTriangles = untangled.flippedSphereTriangles;
    }
    result.ball.invertedTets = untangled.invertedAfter;
    result.ball.untangleIterations = untangled.lbfgsIterations + untangled.newtonIterations;
    result.U = std::move(untangled.U);
    if (!untangled.status.ok) result.status = untangled.status;
    result.stopped = result.stopped || untangled.stopped;
  } else {
    result.ball.invertedTetsBeforeUntangling = result.ball.invertedTets = countNonPositiveTets(result.U, mesh.T);
  }
  result.timings.untangle = secondsSince(t0);

  for (int b : boundary) result.boundaryMaxDistance = std::max(result.boundaryMaxDistance, std::abs(result.U.row(b).norm() - 1));
  result.timings.total = secondsSince(start);
  if (result.status.ok && result.ball.invertedTets > 0)
    result.status = Status::failure("mapToBall: " + std::to_string(result.ball.invertedTets) + " tets remain inverted");
  stopped(1.0, "ball map");
  return result;
}

}  // namespace tet2spline

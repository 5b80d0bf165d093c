// The param stage: chords, ball map, measure, OT, composition, untangling.
#include "tet2spline/param/parameterize.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <optional>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "cube_map.h"
#include "tet2spline/param/barrier_morph.h"
#include "tet2spline/param/refine.h"
#include "tet2spline/param/topology.h"

namespace tet2spline {
namespace {

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

double signedVolume(const Eigen::MatrixX3d& X, const Eigen::MatrixX4i& T, Eigen::Index t) {
  const Eigen::Vector3d a = X.row(T(t, 0)), b = X.row(T(t, 1)), c = X.row(T(t, 2)), d = X.row(T(t, 3));
  return (b - a).cross(c - a).dot(d - a) / 6.0;
}

Eigen::VectorXd signedVolumes(const Eigen::MatrixX3d& X, const Eigen::MatrixX4i& T) {
  Eigen::VectorXd v(T.rows());
  for (Eigen::Index t = 0; t < T.rows(); ++t) v(t) = signedVolume(X, T, t);
  return v;
}

std::string formatDouble(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

// Percentile (nearest rank on the sorted copy).
double percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0;
  const size_t k = std::min(values.size() - 1, static_cast<size_t>(std::floor(p * static_cast<double>(values.size() - 1) + 0.5)));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

ParamResult::VolumeRatios summarise(std::vector<double> ratios) {
  ParamResult::VolumeRatios s;
  if (ratios.empty()) return s;
  s.p1 = percentile(ratios, 0.01);
  s.p50 = percentile(ratios, 0.5);
  s.p99 = percentile(ratios, 0.99);
  s.min = *std::min_element(ratios.begin(), ratios.end());
  s.max = *std::max_element(ratios.begin(), ratios.end());
  return s;
}

// ---- cube boundary -------------------------------------------------------
// Place of a boundary vertex on the cube: `locks` has bit k when coordinate k
// sits on a face (0 or 1); one bit = face, two = edge, three = corner.

struct CubeEdge {
  int axis;                 // the coordinate that varies along the edge
  Eigen::Vector3d origin;   // the end with that coordinate 0
};

std::array<CubeEdge, 12> cubeEdges() {
  std::array<CubeEdge, 12> edges{};
  int n = 0;
  for (int axis = 0; axis < 3; ++axis)
    for (int a = 0; a < 2; ++a)
      for (int b = 0; b < 2; ++b) {
        Eigen::Vector3d o = Eigen::Vector3d::Zero();
        o((axis + 1) % 3) = a;
        o((axis + 2) % 3) = b;
        edges[static_cast<size_t>(n++)] = {axis, o};
      }
  return edges;
}

struct CubePlacement {
  Eigen::MatrixX3d positions;     // rows of the boundary vertices (others untouched)
  std::vector<std::uint8_t> locks;  // #V
  int corners = 0, edges = 0;
};

// design.md: "on the cube the OT decides which boundary points land on the
// 12 edges and 8 corners". A corner belongs to the boundary vertex whose
// Laguerre cell holds it (least power distance among boundary vertices),
// and so does every point of an edge; a vertex that owns part of an edge
// goes to the middle of its part. The others go from their cell centroid
// to the nearest face.
// `sites` are the OT sites (a vertex at a region interface has one per
// region, see parameterize()), siteStart/siteList the sites of each vertex
// in compressed rows, `centroids` the vertex positions after composition.
CubePlacement placeOnCube(const Eigen::MatrixX3d& sites, const Eigen::VectorXd& psi, const std::vector<int>& siteStart,
                          const Eigen::MatrixX3d& centroids, const Eigen::VectorXi& boundary,
                          const Eigen::MatrixX3i& faces, bool withEdges, bool withCorners) {
  const Eigen::Index nv = centroids.rows();
  CubePlacement out;
  out.positions = centroids;
  out.locks.assign(static_cast<size_t>(nv), 0);
  const Eigen::Index nb = boundary.size();
  auto power = [&](const Eigen::Vector3d& x, int i) { return (x - sites.row(i).transpose()).squaredNorm() - psi(i); };
  // The vertex among `candidates` whose site (any of its sites) has the least power distance to x.
  auto owner = [&](const Eigen::Vector3d& x, const std::vector<int>& candidates) {
    int best = -1;
    double bestPower = std::numeric_limits<double>::infinity();
    for (int i : candidates)
      for (int site = siteStart[static_cast<size_t>(i)]; site < siteStart[static_cast<size_t>(i) + 1]; ++site) {
        const double p = power(x, site);
        if (p < bestPower) bestPower = p, best = i;
      }
    return best;
  };
  std::vector<int> all(boundary.data(), boundary.data() + nb);

  // Faces first, for every boundary vertex: the face nearest to its cell's
  // centroid, except that a vertex none of whose boundary neighbours is on
  // its face joins the face most of them are on (an isolated vertex has
  // triangles reaching across an edge on every side, and its tets cannot
  // all stay positive; measured on blob-closed: 1 tet left inverted).
  std::vector<int> face(static_cast<size_t>(nv), -1);  // 2·axis + side
  auto nearestFace = [](const Eigen::Vector3d& x) {
    int best = 0;
    double distance = std::numeric_limits<double>::infinity();
    for (int j = 0; j < 3; ++j) {
      if (x(j) < distance) distance = x(j), best = 2 * j;
      if (1 - x(j) < distance) distance = 1 - x(j), best = 2 * j + 1;
    }
    return best;
  };
  for (int i : all) face[static_cast<size_t>(i)] = nearestFace(centroids.row(i).transpose());
  std::vector<std::vector<int>> ring(static_cast<size_t>(nv));
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) ring[static_cast<size_t>(faces(f, k))].push_back(faces(f, (k + 1) % 3));
  for (int pass = 0; pass < 10; ++pass) {
    int moved = 0;
    for (int i : all) {
      int votes[6] = {0, 0, 0, 0, 0, 0};
      for (int j : ring[static_cast<size_t>(i)]) ++votes[face[static_cast<size_t>(j)]];
      if (votes[face[static_cast<size_t>(i)]] > 0) continue;
      face[static_cast<size_t>(i)] = static_cast<int>(std::max_element(votes, votes + 6) - votes);
      ++moved;
    }
    if (moved == 0) break;
  }
  for (int i : all) {
    Eigen::Vector3d x = centroids.row(i);
    const int axis = face[static_cast<size_t>(i)] / 2;
    for (int j = 0; j < 3; ++j) x(j) = std::clamp(x(j), 1e-9, 1 - 1e-9);
    x(axis) = face[static_cast<size_t>(i)] % 2;
    out.locks[static_cast<size_t>(i)] = static_cast<std::uint8_t>(1u << axis);
    out.positions.row(i) = x;
  }

  // Edges: sample each edge finely against the boundary cells near it.
  const int samples = std::max(64, static_cast<int>(24 * std::sqrt(static_cast<double>(nb) / 6.0)));
  std::vector<int> edgeOf(static_cast<size_t>(nv), -1), edgeCount(static_cast<size_t>(nv), 0);
  std::vector<double> edgeT(static_cast<size_t>(nv), 0);
  const auto edges = cubeEdges();
  const double reach = std::min(0.5, 8.0 / std::sqrt(std::max<double>(1, static_cast<double>(nb) / 6.0)));
  for (size_t e = 0; e < edges.size(); ++e) {
    const CubeEdge& edge = edges[e];
    std::vector<int> near;
    for (int i : all) {
      Eigen::Vector3d d = centroids.row(i).transpose() - edge.origin;
      d(edge.axis) = 0;
      if (d.norm() < reach) near.push_back(i);
    }
    if (near.empty()) near = all;
    std::vector<int> count(near.size(), 0);
    std::vector<double> sumT(near.size(), 0);
    std::vector<int> local(static_cast<size_t>(nv), -1);
    for (size_t k = 0; k < near.size(); ++k) local[static_cast<size_t>(near[k])] = static_cast<int>(k);
    // The samples' owners on both cores (bunny00: 3303 samples an edge
    // against ~2200 nearby cells, 0.75 s on one core), counted in order.
    std::vector<int> sampleOwner(static_cast<size_t>(samples));
    tbb::parallel_for(tbb::blocked_range<int>(0, samples, 64), [&](const tbb::blocked_range<int>& r) {
      for (int s = r.begin(); s != r.end(); ++s) {
        Eigen::Vector3d x = edge.origin;
        x(edge.axis) = (s + 0.5) / samples;
        sampleOwner[static_cast<size_t>(s)] = owner(x, near);
      }
    });
    for (int s = 0; s < samples; ++s) {
      const double t = (s + 0.5) / samples;
      const int k = local[static_cast<size_t>(sampleOwner[static_cast<size_t>(s)])];
      ++count[static_cast<size_t>(k)];
      sumT[static_cast<size_t>(k)] += t;
    }
    for (size_t k = 0; k < near.size(); ++k) {
      const int i = near[k];
      if (count[k] > edgeCount[static_cast<size_t>(i)]) {
        edgeCount[static_cast<size_t>(i)] = count[k];
        edgeOf[static_cast<size_t>(i)] = static_cast<int>(e);
        edgeT[static_cast<size_t>(i)] = sumT[k] / count[k];
      }
    }
  }
  auto putOnEdge = [&](int i) {
    const CubeEdge& edge = edges[static_cast<size_t>(edgeOf[static_cast<size_t>(i)])];
    Eigen::Vector3d x = edge.origin;
    x(edge.axis) = std::clamp(edgeT[static_cast<size_t>(i)], 1e-9, 1 - 1e-9);
    out.positions.row(i) = x;
    out.locks[static_cast<size_t>(i)] = static_cast<std::uint8_t>(7u & ~(1u << edge.axis));
  };
  for (int i : all)
    if (edgeOf[static_cast<size_t>(i)] >= 0 && withEdges) putOnEdge(i);

  // Corners: the owner among boundary vertices.
  std::vector<char> isCorner(static_cast<size_t>(nv), 0);
  for (int c = 0; c < (withCorners ? 8 : 0); ++c) {
    const Eigen::Vector3d q(c & 1, (c >> 1) & 1, (c >> 2) & 1);
    const int i = owner(q, all);
    if (isCorner[static_cast<size_t>(i)]) continue;  // a vertex owning two corners keeps the first
    isCorner[static_cast<size_t>(i)] = 1;
    out.positions.row(i) = q;
    out.locks[static_cast<size_t>(i)] = 7;
  }

  // A boundary triangle with its three vertices on one edge line would be
  // flat: send the edge vertex with the smallest share of the edge back to
  // its face until there is none.
  auto lineKey = [&](int i) -> int {  // edge line of a vertex on an edge or corner, else -1
    const std::uint8_t l = out.locks[static_cast<size_t>(i)];
    if (l == 7) return 100 + static_cast<int>(i);  // corners: handled pairwise below
    if (__builtin_popcount(l) != 2) return -1;
    return edgeOf[static_cast<size_t>(i)];
  };
  auto onLine = [&](int i, int e) {
    const CubeEdge& edge = edges[static_cast<size_t>(e)];
    for (int j = 0; j < 3; ++j)
      if (j != edge.axis && out.positions(i, j) != edge.origin(j)) return false;
    return true;
  };
  for (int pass = 0; pass < 100; ++pass) {
    bool changed = false;
    for (Eigen::Index f = 0; f < faces.rows(); ++f) {
      int line = -1;
      for (int k = 0; k < 3 && line < 0; ++k) {
        const int key = lineKey(faces(f, k));
        if (key >= 0 && key < 100) line = key;
      }
      if (line < 0) continue;
      if (!onLine(faces(f, 0), line) || !onLine(faces(f, 1), line) || !onLine(faces(f, 2), line)) continue;
      int victim = -1;
      for (int k = 0; k < 3; ++k) {
        const int i = faces(f, k);
        if (out.locks[static_cast<size_t>(i)] == 7) continue;
        if (victim < 0 || edgeCount[static_cast<size_t>(i)] < edgeCount[static_cast<size_t>(victim)]) victim = i;
      }
      if (victim < 0) continue;
      Eigen::Vector3d x = centroids.row(victim);
      const CubeEdge& edge = edges[static_cast<size_t>(line)];
      // The nearer of the edge's two faces.
      const int a = (edge.axis + 1) % 3, b = (edge.axis + 2) % 3;
      const double da = std::abs(x(a) - edge.origin(a)), db = std::abs(x(b) - edge.origin(b));
      const int j = da <= db ? a : b, other = da <= db ? b : a;
      x(j) = edge.origin(j);
      for (int m = 0; m < 3; ++m) if (m != j) x(m) = std::clamp(x(m), 1e-9, 1 - 1e-9);
      (void)other;
      out.positions.row(victim) = x;
      out.locks[static_cast<size_t>(victim)] = static_cast<std::uint8_t>(1u << j);
      edgeOf[static_cast<size_t>(victim)] = -1;
      changed = true;
    }
    if (!changed) break;
  }
  for (int i : all) {
    const int bits = __builtin_popcount(out.locks[static_cast<size_t>(i)]);
    out.corners += bits == 3;
    out.edges += bits == 2;
  }
  return out;
}

// OT sites and masses (design.md, "Measure"). A vertex inside one region is
// one site y_i with mass Σ_{t∋i} τ_t/4 (τ_t the tet's target volume). A
// vertex where regions meet gets one site per region, each with the mass of
// that region's tets only, moved from y_i a quarter of the way towards the
// centroid of those tets: the facets between its sub-cells then follow the
// region interface, and the region volumes come out right instead of being
// smeared over the interface cells (in 1D this makes them exact; measured on
// a sphere holding a density-4 sphere, 2.5k tets: region fraction 0.165
// instead of 0.203 with one site per vertex).
// Per vertex: 1 when its tets do not all have the same density w.
std::vector<char> densityJumps(const TetMesh& mesh, const Eigen::VectorXd& w) {
  const Eigen::Index nv = mesh.numVertices(), nt = mesh.numTets();
  std::vector<char> jump(static_cast<size_t>(nv), 0);
  std::vector<double> first(static_cast<size_t>(nv), -1);
  for (Eigen::Index t = 0; t < nt; ++t)
    for (int k = 0; k < 4; ++k) {
      double& f = first[static_cast<size_t>(mesh.T(t, k))];
      if (f < 0) f = w(t);
      else if (f != w(t)) jump[static_cast<size_t>(mesh.T(t, k))] = 1;
    }
  return jump;
}

void buildSites(const TetMesh& mesh, const Eigen::MatrixX3d& y, const Eigen::VectorXd& target, bool split,
                std::vector<int>& siteStart, Eigen::MatrixX3d& sites, Eigen::VectorXd& masses) {
  const Eigen::Index nv = mesh.numVertices(), nt = mesh.numTets();
  struct Part {
    int region;
    double mass;
    Eigen::Vector3d towards;  // Σ τ_t · centroid_y(t)
  };
  std::vector<std::vector<Part>> parts(static_cast<size_t>(nv));
  for (Eigen::Index t = 0; t < nt; ++t) {
    const Eigen::Vector3d c =
        0.25 * (y.row(mesh.T(t, 0)) + y.row(mesh.T(t, 1)) + y.row(mesh.T(t, 2)) + y.row(mesh.T(t, 3))).transpose();
    for (int k = 0; k < 4; ++k) {
      auto& list = parts[static_cast<size_t>(mesh.T(t, k))];
      const int region = split ? mesh.region(t) : 0;
      auto it = std::find_if(list.begin(), list.end(), [&](const Part& p) { return p.region == region; });
      if (it == list.end()) it = list.insert(list.end(), Part{region, 0, Eigen::Vector3d::Zero()});
      it->mass += target(t) / 4;
      it->towards += target(t) / 4 * c;
    }
  }
  siteStart.assign(static_cast<size_t>(nv) + 1, 0);
  for (Eigen::Index i = 0; i < nv; ++i)
    siteStart[static_cast<size_t>(i) + 1] = siteStart[static_cast<size_t>(i)] + static_cast<int>(parts[static_cast<size_t>(i)].size());
  const int ns = siteStart.back();
  sites.resize(ns, 3);
  masses.resize(ns);
  for (Eigen::Index i = 0; i < nv; ++i) {
    const auto& list = parts[static_cast<size_t>(i)];
    int site = siteStart[static_cast<size_t>(i)];
    for (const Part& p : list) {
      const Eigen::Vector3d yi = y.row(i).transpose();
      sites.row(site) = list.size() == 1 ? yi : Eigen::Vector3d(yi + 0.25 * (p.towards / p.mass - yi));
      masses(site) = p.mass;
      ++site;
    }
  }
}

// Composition: a vertex with one site goes to its cell's centroid; a vertex
// with several (a region interface) goes to the interface between its
// sub-cells: for each pair of its sites, the point where the segment between
// the two sub-cell centroids crosses their power bisector, averaged with the
// pair's masses.
Eigen::MatrixX3d composeVertices(const Eigen::MatrixX3d& y, const std::vector<int>& siteStart, const Eigen::MatrixX3d& sites,
                                 const Eigen::VectorXd& psi, const Eigen::MatrixX3d& centroids,
                                 const Eigen::VectorXd& volumes) {
  const Eigen::Index nv = y.rows();
  Eigen::MatrixX3d U(nv, 3);
  for (Eigen::Index i = 0; i < nv; ++i) {
    const int first = siteStart[static_cast<size_t>(i)], last = siteStart[static_cast<size_t>(i) + 1];
    if (last - first == 1) {
      U.row(i) = centroids.row(first);
      continue;
    }
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    double weight = 0;
    for (int p = first; p < last; ++p)
      for (int q = p + 1; q < last; ++q) {
        const Eigen::Vector3d cp = centroids.row(p).transpose(), cq = centroids.row(q).transpose();
        const Eigen::Vector3d yp = sites.row(p).transpose(), yq = sites.row(q).transpose();
        // f(x) = |x − y_p|² − ψ_p − |x − y_q|² + ψ_q is affine in x.
        auto f = [&](const Eigen::Vector3d& x) { return (x - yp).squaredNorm() - psi(p) - (x - yq).squaredNorm() + psi(q); };
        const double fp = f(cp), fq = f(cq);
        const double s = fp != fq ? std::clamp(fp / (fp - fq), 0.0, 1.0) : 0.5;
        const double wpq = volumes(p) + volumes(q);
        sum += wpq * (cp + s * (cq - cp));
        weight += wpq;
      }
    U.row(i) = (sum / weight).transpose();
  }
  return U;
}

/// Planar faces for ParamOptions::planarBoundaryShare: patches of triangles
/// within this many degrees of coplanar, of at least this share of the
/// boundary's area.
constexpr double kPlanarDegrees = 0.1;
constexpr double kPlanarPatch = 0.01;

/// Rings of boundary vertices around a flipped triangle that slide in the
/// first phase of the final untangling. Measured (cube, final untangling
/// seconds): triceratops 32 (0 rings), 32 (1), 79 (2), 8 (4); fandisk 3 (2),
/// 3.8 (4); homer 83 (2), 91 (4).
constexpr int kSlideRings = 4;

}  // namespace

Eigen::VectorXd tetDensities(const TetMesh& mesh, const MeasureOptions& measure) {
  const Eigen::Index nt = mesh.numTets();
  Eigen::VectorXd w = Eigen::VectorXd::Ones(nt);
  for (const auto& [id, density] : measure.regionDensity) {
    if (!(std::isfinite(density) && density > 0))
      throw Error(ErrorKind::Usage, "--density " + std::to_string(id) + "=" + formatDouble(density) +
                                        ": the density must be a finite number > 0");
    bool found = false;
    for (Eigen::Index t = 0; t < nt; ++t)
      if (mesh.region(t) == id) w(t) = density, found = true;
    if (!found) {
      std::string have;
      std::vector<int> ids(mesh.region.data(), mesh.region.data() + nt);
      std::sort(ids.begin(), ids.end());
      ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
      for (int r : ids) have += (have.empty() ? "" : ", ") + std::to_string(r);
      throw Error(ErrorKind::Usage, "--density " + std::to_string(id) + "=...: the solid has no region " +
                                        std::to_string(id) + " (its regions: " + have + ")");
    }
  }
  if (!measure.densityField.empty()) {
    const Field* cell = mesh.cellField(measure.densityField);
    const Field* point = cell ? nullptr : mesh.pointField(measure.densityField);
    if (!cell && !point)
      throw Error(ErrorKind::Usage, "--density-field " + measure.densityField + ": the input has no such point or cell array");
    const Field& f = cell ? *cell : *point;
    if (f.values.cols() != 1)
      throw Error(ErrorKind::Usage, "--density-field " + measure.densityField + ": the array has " +
                                        std::to_string(f.values.cols()) + " components; a density needs 1");
    for (Eigen::Index i = 0; i < f.values.rows(); ++i)
      if (!(std::isfinite(f.values(i, 0)) && f.values(i, 0) > 0))
        throw Error(ErrorKind::Input, "density field " + measure.densityField + ": value " + formatDouble(f.values(i, 0)) +
                                          " at " + (cell ? "tet " : "vertex ") + std::to_string(i) +
                                          " is not a finite number > 0");
    for (Eigen::Index t = 0; t < nt; ++t) {
      double v = 0;
      if (cell) {
        v = f.values(t, 0);
      } else {
        for (int k = 0; k < 4; ++k) v += f.values(mesh.T(t, k), 0) / 4;
      }
      w(t) = v;
    }
  }
  if (measure.voidDensity > 0) {
    if (!std::isfinite(measure.voidDensity))
      throw Error(ErrorKind::Usage, "--void-density must be a finite number > 0");
    for (Eigen::Index t = 0; t < nt; ++t)
      if (mesh.voidRegions.count(mesh.region(t))) w(t) = measure.voidDensity;
  } else if (measure.voidDensity < 0) {
    throw Error(ErrorKind::Usage, "--void-density must be a finite number > 0");
  }
  return w;
}

// A point of the unit ball stretched towards [0,1]³: ½ + ½ x (|x|₂/|x|_∞)^α
// (α = 1: onto the cube, see below; α = 0: the inscribed ball). Both ends
// without pow, so that they keep the bits they had before α existed.
Eigen::RowVector3d stretchTowardsCube(const Eigen::Vector3d& x, double alpha) {
  const double inf = x.cwiseAbs().maxCoeff();
  if (!(inf > 0)) return Eigen::RowVector3d(0.5, 0.5, 0.5);
  const double ratio = x.norm() / inf;
  const double scale = alpha == 0.0 ? 1.0 : alpha == 1.0 ? ratio : std::pow(ratio, alpha);
  return Eigen::RowVector3d((0.5 * x * scale).array() + 0.5);
}

// A point of the unit ball mapped onto [0,1]³ by the volume-preserving map
// (cube_map.h), moved kSphereShare of the way back towards the inscribed
// ball: the sphere's points would otherwise all lie on the cube's six
// planes, a degenerate input for the regular triangulation (bunny00: 1.6 s
// of triangulation per Newton iteration instead of 0.4 s; the blend's
// determinant stays within 0.2% of constant).
Eigen::RowVector3d equalVolumeSite(const Eigen::Vector3d& x) {
  constexpr double kSphereShare = 0.02;
  const Eigen::Vector3d inscribed = (0.5 * x).array() + 0.5;
  return ((1 - kSphereShare) * detail::equalVolumeBallToCube(x) + kSphereShare * inscribed).transpose();
}

// The ball map stretched onto the cube: x ↦ ½ + ½ x |x|₂/|x|_∞ (see
// below); the vertices of boundaryFaces get their largest coordinate set
// exactly.
Eigen::MatrixX3d stretchOntoCube(const Eigen::MatrixX3d& ball, const Eigen::MatrixX3i& boundaryFaces) {
  std::vector<char> onBoundary(static_cast<size_t>(ball.rows()), 0);
  for (Eigen::Index f = 0; f < boundaryFaces.rows(); ++f)
    for (int k = 0; k < 3; ++k) onBoundary[static_cast<size_t>(boundaryFaces(f, k))] = 1;
  Eigen::MatrixX3d U(ball.rows(), 3);
  for (Eigen::Index v = 0; v < ball.rows(); ++v) {
    const Eigen::Vector3d x = ball.row(v);
    Eigen::Index axis = 0;
    const double inf = x.cwiseAbs().maxCoeff(&axis);
    if (onBoundary[static_cast<size_t>(v)]) {
      U.row(v) = (0.5 * x / inf).array() + 0.5;
      U(v, axis) = x[axis] > 0 ? 1 : 0;
    } else {
      U.row(v) = stretchTowardsCube(x, 1.0);
    }
  }
  return U;
}

// The barrier morph's start (ballStart, untangleStretch below): a bijective map
// onto Ω from the ball map, or an empty matrix when untangling cannot make
// one. The few tets the ball map's
// untangling may have left inverted (spool.off: 1) are untangled again, with
// projected Newton (here it repairs what L-BFGS left) and the sphere
// sliding; that is the start on the ball. On the cube, the ball map stretched
// onto it: x ↦ ½ + ½ x |x|₂/|x|_∞ maps the unit ball onto [0,1]³ (positively
// homogeneous of degree 1, a homeomorphism) and the sphere onto the cube's
// surface (the largest coordinate set exactly to 0 or 1). Every vertex moves
// along its own ray from the centre, so the cones over boundary triangles
// keep their sign; tets that the stretch folds where it bends (the planes
// |x_i| = |x_j|) are untangled by projected Newton with the boundary sliding
// on the cube, across its edges, against one of two reference shapes
// (MorphStartShapes).
//
// The untangler's reference shapes on the cube are the input mesh's tets
// (Input), as everywhere else in the pipeline, or the ball map's own tets
// scaled to the cube's size (BallMap). The latter change little under the
// stretch away from its folds, so their energy is where the folds are.
// Measured (2 cores):
//   models/bracket.step (249k tets; the ball map 1000-fold compressed in the
//   pockets and the hole; the stretch folds 2.9k): Input stalls (min det
//   -0.98 after 100 Newton iterations, 330 s); BallMap untangles in 44
//   iterations (96 s, work 109 tet evaluations per tet), and the morph from
//   it ends 0.20 target edges (rms) from its target.
//   spool.off (6.4k vertices, 2363 chords split): BallMap stalls (min det
//   -0.9 after 580 iterations); Input untangles (73 iterations, work 412).
//   hand.off (12.7k vertices): both untangle, but the morph from BallMap's
//   start ends 20.9 target edges from its target, from Input's 0.69.
// So BallMap goes first within kBallShapesWork per tet, and the pipeline
// keeps its morph only when it ends within kMorphCloseEnough of the target.
enum class MorphStartShapes { BallMap, Input };
constexpr double kBallShapesWork = 250;
constexpr double kMorphCloseEnough = 1;  // target edges, rms
// The final untangling's rounds after its budget is spent (see there).
constexpr int kFinishingRounds = 8;
// Edge splits for the tets those rounds leave (see there): at most this many
// tets, and this many splits.
constexpr int kMaxSplitTets = 64;
constexpr int kSplitRounds = 3;
// ε rounds in a row without progress (none leaving at most three quarters
// of the count after the last that did) that end a region of the final
// untangling once at most kMaxSplitTets are left
// (UntangleOptions::regionStallRounds).
// Not in the ball map's untangling: there it changed the sites, hence the
// transport, of triceratops, spool and hand (hand's morph then ended 3.25
// target edges from the transport's map instead of 0.60).
constexpr int kRegionStallRounds = 4;
// The final untangling's local repair widens to one ring at most once this
// many tets are left (see its use).
constexpr int kRepairFewTets = 10;

// The longest edge in U of every tet that is not positive in U, or with
// `everyEdge` all six, except edges with both ends on the boundary (a
// boundary edge or a chord: its new vertex would have to lie on ∂Ω), without
// repeats.
std::vector<std::pair<int, int>> edgesToSplit(const Eigen::MatrixX3d& U, const Eigen::MatrixX4i& T,
                                              const Eigen::VectorXi& boundaryVertices, bool everyEdge) {
  std::vector<char> onBoundary(static_cast<size_t>(U.rows()), 0);
  for (Eigen::Index k = 0; k < boundaryVertices.size(); ++k) onBoundary[static_cast<size_t>(boundaryVertices(k))] = 1;
  std::vector<std::pair<int, int>> edges;
  for (Eigen::Index t = 0; t < T.rows(); ++t) {
    std::array<Eigen::Vector3d, 4> p;
    for (int k = 0; k < 4; ++k) p[static_cast<size_t>(k)] = U.row(T(t, k)).transpose();
    if (orient3d(p[0].data(), p[1].data(), p[2].data(), p[3].data()) > 0) continue;
    double longest = -1;
    std::pair<int, int> edge{-1, -1};
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) {
        const int a = T(t, i), b = T(t, j);
        if (onBoundary[static_cast<size_t>(a)] && onBoundary[static_cast<size_t>(b)]) continue;
        if (everyEdge) edges.emplace_back(std::min(a, b), std::max(a, b));
        const double length = (p[static_cast<size_t>(i)] - p[static_cast<size_t>(j)]).norm();
        if (length > longest) longest = length, edge = {std::min(a, b), std::max(a, b)};
      }
    if (!everyEdge && edge.first >= 0) edges.push_back(edge);
  }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  return edges;
}

// X (per vertex) grown to the split mesh: each new vertex where its split put it.
void growBySplits(Eigen::MatrixX3d& X, const EdgeSplits& cut, Eigen::Index vertices) {
  X.conservativeResize(vertices, 3);
  for (const EdgeSplit& e : cut.splits) X.row(e.vertex) = (1 - e.t) * X.row(e.a) + e.t * X.row(e.b);
}
// Cells per direction of ParamResult::Figures::misplacedVolume: 8³, the
// scale of the spline's elements at the fit's default of 8 to 16.
constexpr int kMisplacementCells = 8;

// The start on the ball (the ball map, its leftover inversions repaired),
// or an empty matrix.
Eigen::MatrixX3d ballStart(const TetMesh& mesh, const Eigen::MatrixX3d& ballU, const Eigen::MatrixX3i& boundaryFaces,
                           const UntangleOptions& base) {
  if (countNonPositiveTets(ballU, mesh.T) == 0) return ballU;
  UntangleOptions o = base;
  o.method = UntangleMethod::Newton;
  o.sphereFaces = boundaryFaces;
  const UntangleResult u =
      untangle(mesh.V, mesh.T, ballU, std::vector<bool>(static_cast<size_t>(ballU.rows()), false), o);
  if (u.stopped) throw Status::failure("stopped during the morph's start");
  if (u.invertedAfter > 0 || u.flippedBoundaryTriangles > 0) return {};
  return u.U;
}

// The start on the cube: `stretched` (stretchOntoCube of ballStart's
// `ball`) untangled against `shapes`, or an empty matrix.
Eigen::MatrixX3d untangleStretch(const TetMesh& mesh, const Eigen::MatrixX3d& ball, const Eigen::MatrixX3d& stretched,
                                 const Eigen::MatrixX3i& boundaryFaces, MorphStartShapes shapes,
                                 const UntangleOptions& base) {
  UntangleOptions o = base;
  o.method = UntangleMethod::Newton;
  o.cubeFaces = boundaryFaces;
  o.cubeAcrossEdges = true;
  if (shapes == MorphStartShapes::BallMap) o.maxTetEvaluations = kBallShapesWork * static_cast<double>(mesh.numTets());
  const UntangleResult u =
      untangle(shapes == MorphStartShapes::BallMap ? Eigen::MatrixX3d(0.5 * ball) : mesh.V, mesh.T, stretched,
               std::vector<bool>(static_cast<size_t>(ball.rows()), false), o);
  if (u.stopped) throw Status::failure("stopped during the morph's start");
  if (u.invertedAfter > 0 || u.flippedBoundaryTriangles > 0) return {};
  return u.U;
}

namespace {
// misplacedVolumeFraction with the tets' signed volumes in U given
// (parameterize has them already); the arguments checked by the caller.
double misplacedFraction(const Eigen::MatrixX3d& U, const Eigen::MatrixX4i& T, const Eigen::VectorXd& parametricVolumes,
                         const Eigen::VectorXd& targetVolumes, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
                         int cells) {
  const Eigen::Index nt = T.rows();
  const size_t nc = static_cast<size_t>(cells) * static_cast<size_t>(cells) * static_cast<size_t>(cells);
  std::vector<double> difference(nc, 0.0);
  double total = 0;
  for (Eigen::Index t = 0; t < nt; ++t) {
    const Eigen::Vector3d c =
        0.25 * (U.row(T(t, 0)) + U.row(T(t, 1)) + U.row(T(t, 2)) + U.row(T(t, 3))).transpose();
    size_t cell = 0;
    for (int d = 2; d >= 0; --d) {
      const double s = hi[d] > lo[d] ? (c[d] - lo[d]) / (hi[d] - lo[d]) : 0.0;
      const int k = std::clamp(static_cast<int>(std::floor(s * cells)), 0, cells - 1);
      cell = cell * static_cast<size_t>(cells) + static_cast<size_t>(k);
    }
    difference[cell] += parametricVolumes(t) - targetVolumes(t);
    total += targetVolumes(t);
  }
  double misplaced = 0;
  for (const double d : difference) misplaced += std::abs(d);
  return total > 0 ? 0.5 * misplaced / total : 0.0;
}
}  // namespace

double misplacedVolumeFraction(const Eigen::MatrixX3d& U, const Eigen::MatrixX4i& T, const Eigen::VectorXd& targetVolumes,
                               const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int cells) {
  const Eigen::Index nt = T.rows();
  if (targetVolumes.size() != nt)
    throw Error(ErrorKind::Input, "misplacedVolumeFraction: " + std::to_string(targetVolumes.size()) +
                                      " target volumes for " + std::to_string(nt) + " tets");
  if (cells < 1) throw Error(ErrorKind::Input, "misplacedVolumeFraction: cells < 1");
  if (nt > 0 && (T.minCoeff() < 0 || T.maxCoeff() >= U.rows()))
    throw Error(ErrorKind::Input, "misplacedVolumeFraction: a tet's vertex index is out of range");
  return misplacedFraction(U, T, signedVolumes(U, T), targetVolumes, lo, hi, cells);
}

ParamResult parameterize(const TetMesh& input, const ParamOptions& options) {
  const auto start = Clock::now();
  if (!options.transport && options.domain != ParamDomain::Ball)
    throw Error(ErrorKind::Usage, "without transport the parameterization is the harmonic ball map: use --domain ball");
  if (!(options.cubeSiteStretch >= 0 && options.cubeSiteStretch <= 1))
    throw Error(ErrorKind::Usage, "cubeSiteStretch must be in [0, 1]");
  if (!(options.smoothBoundaryDegrees >= 0 && options.smoothBoundaryDegrees <= 180))
    throw Error(ErrorKind::Usage, "smoothBoundaryDegrees must be in [0, 180]");
  if (!(options.planarBoundaryShare >= 0 && options.planarBoundaryShare <= 1))
    throw Error(ErrorKind::Usage, "planarBoundaryShare must be in [0, 1]");
  ParamResult r;
  auto report = [&](double fraction, const std::string& what) {
    if (options.progress && !options.progress(fraction, what)) throw Status::failure("stopped during " + what);
  };

  try {
    // 1. chords
    auto t0 = Clock::now();
    r.mesh = input;
    if (options.splitChords) r.chordsSplit = splitBoundaryChords(r.mesh);
    r.timings.refine = secondsSince(t0);
    const TetMesh& mesh = r.mesh;
    Eigen::Index nv = mesh.numVertices(), nt = mesh.numTets();  // (grown by edge splits before the morph)
    report(0.01, r.chordsSplit ? "split " + std::to_string(r.chordsSplit) + " boundary chords" : "no boundary chords");

    // 2. ball map
    BallMapOptions ballOptions = options.ballMap;
    if (options.transport) ballOptions.sphere.areaCorrectionIterations = options.sphereAreaCorrectionIterations;
    // With transport the ball map only places the sites (below), so its
    // untangling stops growing its regions once a few tets stay put, as the
    // final untangling does (UntangleOptions::stallBelow), and the local
    // repair takes what is left. Measured on bunny00's TetGen mesh with
    // OpenBLAS instead of ATLAS behind CHOLMOD (the harmonic map's last bits
    // differ): 13, 12, 12 tets left over regions of 7843, 25332 and 66713
    // free vertices, 167 s, where the local repair then took the 12 to 0
    // in a fraction of a second (with the rule: 27 s, and the whole `param`
    // 236 -> 105 s). A run that reaches 0 (bunny00 with ATLAS: 117 -> 0 in
    // its second region) does not meet the rule: of the ten genus-0 test
    // meshes (`param`, cube) only spool's and hand's maps changed. spool's
    // ball map keeps 2 inverted tets, and its final untangling then ends
    // valid after 15 edge splits, where before it left 3 for the morph:
    // 75 -> 14 s (volume ratio p1/p99 0.091/4.21 -> 0.060/6.36); hand
    // goes to the morph either way, 126 -> 142 s.
    if (options.transport && ballOptions.untangle.stallBelow == 0) ballOptions.untangle.stallBelow = kMaxSplitTets;
    ballOptions.progress = [&](double f, const std::string& m) {
      return !options.progress || options.progress(f >= 0 ? 0.01 + 0.29 * f : -1, m);
    };
    BallMapResult ball = mapToBall(mesh, ballOptions);
    r.ballU = ball.U;
    r.boundaryVertices = ball.boundaryVertices;
    r.boundaryFaces = ball.boundaryFaces;
    r.sphere = ball.sphere;
    r.ball = ball.ball;
    r.ballBoundaryMaxDistance = ball.boundaryMaxDistance;
    r.timings.sphere = ball.timings.sphere + ball.timings.boundary;
    r.timings.harmonic = ball.timings.harmonic;
    r.timings.untangle = ball.timings.untangle;
    // With transport, the ball map only places the sites: the composition
    // moves every vertex to its cell's centroid and the final untangling
    // repairs whatever that inverts (thousands of tets on fandisk), so a few
    // tets the ball map's untangling could not repair (before its local
    // max-min repair, untangle.h: spool one, det −10⁻⁶) do not make the
    // result invalid;
    // the final map is checked on its own. Without transport the ball map is
    // the result, and it must be bijective.
    const bool onlyInversionsLeft = !ball.stopped && ball.ball.invertedTets > 0 && ball.sphere.flippedTriangles == 0 &&
                                    ball.boundaryMaxDistance < 1e-12;
    // Without transport, a few tets that the ball map's untangling leaves
    // (pinched between their neighbours) get the final untangling's edge
    // splits: the longest edge of each tet left, then (from the ball map
    // again) every edge, each round followed by the untangling with the
    // sphere sliding; kept only when the map ends bijective. Measured: hand
    // scaled by 1 + 10⁻⁹ (`param --domain ball --no-transport`) ended with
    // 2 tets inverted; its scales by 1 + 2, 3, 4·10⁻⁹ were valid.
    if (!options.transport && !ball.status.ok && onlyInversionsLeft && ball.ball.invertedTets <= kMaxSplitTets &&
        ballOptions.untangleMap && ballOptions.untangle.localRepairSweeps > 0) {
      const auto splitStart = Clock::now();
      for (const bool everyEdge : {false, true}) {
        TetMesh refined = r.mesh;
        Eigen::MatrixX3d U = ball.U;
        int splits = 0;
        bool bijective = false;
        for (int round = 0; round < kSplitRounds && !bijective; ++round) {
          const EdgeSplits cut = splitEdges(refined, edgesToSplit(U, refined.T, r.boundaryVertices, everyEdge));
          if (cut.splits.empty()) break;
          growBySplits(U, cut, refined.numVertices());
          splits += static_cast<int>(cut.splits.size());
          UntangleOptions slide = ballOptions.untangle;
          slide.sphereFaces = r.boundaryFaces;
          slide.progress = [&](double, const std::string& m) { return !options.progress || options.progress(-1, m); };
          const UntangleResult u =
              untangle(refined.V, refined.T, U, std::vector<bool>(static_cast<size_t>(refined.numVertices()), false), slide);
          if (u.stopped) throw Status::failure("stopped during the ball map's edge splits");
          U = u.U;
          bijective = u.invertedAfter == 0 && u.flippedSphereTriangles == 0;
        }
        if (!bijective) continue;
        r.mesh = std::move(refined);
        nv = mesh.numVertices(), nt = mesh.numTets();
        r.ballU = std::move(U);
        ball.ball.invertedTets = 0;
        ball.status = Status{};
        r.ball = ball.ball;
        r.ballBoundaryMaxDistance = 0;
        for (Eigen::Index k = 0; k < r.boundaryVertices.size(); ++k)
          r.ballBoundaryMaxDistance =
              std::max(r.ballBoundaryMaxDistance, std::abs(r.ballU.row(r.boundaryVertices(k)).norm() - 1));
        r.param.splitEdges = splits;
        r.warnings.push_back("split " + std::to_string(splits) +
                             " edges of tets the ball map's untangling left inverted (param.split_edges): the "
                             "parameterized mesh has that many more vertices than the input");
        break;
      }
      r.timings.untangle += secondsSince(splitStart);
    }
    if (!ball.status.ok && !(options.transport && onlyInversionsLeft)) throw Status::failure(ball.status.message);
    if (!ball.status.ok)
      r.warnings.push_back("the harmonic ball map kept " + std::to_string(ball.ball.invertedTets) +
                           " inverted tets (ball.inverted_tets); the transport's composition and final untangling "
                           "replaced it, and the parameterization is checked on its own (param.inverted_tets)");

    // 3. measure
    t0 = Clock::now();
    Eigen::VectorXd w = tetDensities(mesh, options.measure);
    Eigen::VectorXd physical, weighted;
    auto measureTets = [&] {  // (again after edge splits)
      physical.resize(nt), weighted.resize(nt);
      for (Eigen::Index t = 0; t < nt; ++t) physical(t) = signedVolume(mesh.V, mesh.T, t), weighted(t) = w(t) * physical(t);
    };
    measureTets();
    const double totalWeighted = weighted.sum();
    int level = options.ballSubdivisions;
    if (level < 0) {
      level = 3;
      while (level < 6 && 10.0 * std::pow(4.0, level) < 2.0 * static_cast<double>(r.boundaryVertices.size())) ++level;
    }
    const Domain domain = options.domain == ParamDomain::Cube ? Domain::unitCube() : Domain::unitBall(level);
    r.domainVolume = options.transport ? domain.volume() : 4.0 * M_PI / 3.0;
    r.domainRepresentation =
        options.domain == ParamDomain::Cube
            ? "unit cube [0,1]^3, exact"
            : "unit ball: OT on the circumscribed polytope of " + std::to_string(domain.planeNormals().rows()) +
                  " tangent planes (volume error " + formatDouble(domain.volume() / (4.0 * M_PI / 3.0) - 1) +
                  " relative); boundary vertices projected radially onto the sphere";
    r.targetVolume = weighted * (r.domainVolume / totalWeighted);
    r.timings.measure = secondsSince(t0);
    {
      // The transport's start against the measure (ParamResult::ballVolumeRatio).
      const Eigen::VectorXd ballVolume = signedVolumes(r.ballU, mesh.T);
      const double ballTotal = ballVolume.sum(), targetTotal = r.targetVolume.sum();
      std::vector<double> ratios(static_cast<size_t>(nt));
      for (Eigen::Index t = 0; t < nt; ++t)
        ratios[static_cast<size_t>(t)] = (ballVolume(t) / ballTotal) / (r.targetVolume(t) / targetTotal);
      r.ballVolumeRatio = summarise(std::move(ratios));
    }

    // The centre of Ω, from which both domains are star-shaped: boundary
    // triangles are flipped when orient3d(apex, a, b, c) <= 0.
    const Eigen::Vector3d apex = options.domain == ParamDomain::Cube ? Eigen::Vector3d(0.5, 0.5, 0.5) : Eigen::Vector3d::Zero();
    if (!options.transport) {
      r.U = r.ballU;
    } else {
      // 4. transport
      t0 = Clock::now();
      Eigen::MatrixX3d y = r.ballU;
      if (options.domain == ParamDomain::Cube) {
        r.param.boundaryNormalAngleP99 = normalAngleQuantile(mesh.V, r.boundaryFaces, 0.99, kPlanarDegrees);
        r.param.boundaryPlanarShare = planarShare(mesh.V, r.boundaryFaces, kPlanarDegrees, kPlanarPatch);
        r.param.cubeSites = options.cubeSites != ParamOptions::CubeSites::Auto ? options.cubeSites
                            : options.cubeSiteStretch > 0 ||
                                      !(r.param.boundaryNormalAngleP99 < options.smoothBoundaryDegrees) ||
                                      !(r.param.boundaryPlanarShare < options.planarBoundaryShare)
                                ? ParamOptions::CubeSites::Stretch
                                : ParamOptions::CubeSites::EqualVolume;
        for (Eigen::Index v = 0; v < nv; ++v)
          y.row(v) = r.param.cubeSites == ParamOptions::CubeSites::EqualVolume
                         ? equalVolumeSite(y.row(v).transpose())
                         : stretchTowardsCube(y.row(v).transpose(), options.cubeSiteStretch);
      }
      std::vector<int> siteStart;
      Eigen::MatrixX3d sites;
      Eigen::VectorXd masses;
      std::vector<char> jumps = densityJumps(mesh, w);
      const bool split = options.interfaceSites == ParamOptions::InterfaceSites::On ||
                         (options.interfaceSites == ParamOptions::InterfaceSites::Auto &&
                          std::find(jumps.begin(), jumps.end(), 1) != jumps.end());
      buildSites(mesh, y, r.targetVolume, split, siteStart, sites, masses);
      OptimalTransportOptions ot = options.transportOptions;
      ot.progress = [&](double f, const std::string& m) {
        return !options.progress || options.progress(f >= 0 ? 0.3 + 0.6 * f : -1, m);
      };
      OptimalTransportResult transport = solveOptimalTransport(sites, masses, domain, ot);
      r.ot.ran = true;
      r.ot.iterations = transport.iterations;
      r.ot.maxRelativeMassError = transport.maxRelativeMassError;
      r.ot.stepSizes = transport.stepSizes;
      r.ot.mergedPoints = transport.mergedPoints;
      r.ot.solverSwitches = transport.solverSwitches;
      r.ot.stalledAboveTolerance = transport.stalledAboveTolerance;
      if (transport.stalledAboveTolerance)
        r.warnings.push_back(stalledTransportWarning(transport, ot.maxRelativeMassError));
      for (const auto& s : transport.iterationStats) {
        r.ot.triangulationSeconds += s.triangulationSeconds;
        r.ot.clippingSeconds += s.clippingSeconds;
        r.ot.assemblySeconds += s.assemblySeconds;
        r.ot.linearSolveSeconds += s.linearSolveSeconds;
        r.ot.amgIterations += s.amg;
      }
      switch (ot.linearSolver) {
        case OtLinearSolver::JacobiThenAmgCG: r.ot.linearSolver = "jacobi-then-amg-cg"; break;
        case OtLinearSolver::AggregationAmgCG: r.ot.linearSolver = "amg-cg"; break;
        case OtLinearSolver::ConjugateGradient: r.ot.linearSolver = "jacobi-cg"; break;
        case OtLinearSolver::IncompleteCholeskyCG: r.ot.linearSolver = "ichol-cg"; break;
        case OtLinearSolver::Cholmod: r.ot.linearSolver = "cholmod"; break;
      }
      r.timings.transport = secondsSince(t0);
      if (!transport.status.ok) throw Status::failure("optimal transport: " + transport.status.message);

      // 5. composition
      t0 = Clock::now();
      report(0.9, "composition");
      r.U = composeVertices(y, siteStart, sites, transport.weights, transport.centroids, transport.cellVolumes);
      std::vector<std::uint8_t> locks;
      if (options.domain == ParamDomain::Cube) {
        CubePlacement placed =
            placeOnCube(sites, transport.weights, siteStart, r.U, r.boundaryVertices, r.boundaryFaces, options.cubeEdges,
                        options.cubeCorners);
        for (Eigen::Index k = 0; k < r.boundaryVertices.size(); ++k)
          r.U.row(r.boundaryVertices(k)) = placed.positions.row(r.boundaryVertices(k));
        r.param.cornerVertices = placed.corners;
        r.param.edgeVertices = placed.edges;
        locks = std::move(placed.locks);
      } else {
        for (Eigen::Index k = 0; k < r.boundaryVertices.size(); ++k) {
          const int i = r.boundaryVertices(k);
          const double n = r.U.row(i).norm();
          r.U.row(i) = n > 0 ? Eigen::RowVector3d(r.U.row(i) / n) : Eigen::RowVector3d(r.ballU.row(i));
        }
      }
      r.timings.composition = secondsSince(t0);

      // 6. untangling with the boundary on ∂Ω
      t0 = Clock::now();
      UntangleOptions untangleOptions = options.untangle;
      // Joint patch moves in the local repair: on the ball only. Measured on
      // bunny00 (767k tets), whose last tets are chaotic either way: on the
      // ball they took the finishing rounds 6 -> 2 -> 1 -> 0 where single
      // moves stopped at 2 (then a morph); on the cube the repair at the
      // spent budget left 15 instead of 53, but the rounds then stopped at 1
      // (24 -> 2, 3 -> 1, 1 -> 1) where without them they reach 0
      // (55 -> 2, 13 -> 0), and the morph took over.
      untangleOptions.localRepairPatches = options.domain == ParamDomain::Ball;
      // With a few tets left, the local repair widens to one ring, not four
      // (UntangleOptions::localRepairFewTets). Measured on bunny00 scaled by
      // 1 + k·10⁻⁹ (cube; `param`, the final untangling in seconds, the
      // same held phase): k = 2 35.0 -> 30.1, k = 3 18.6 -> 13.0, k = 4
      // 27.3 -> 22.0, k = 5 28.4 -> 28.2, as given unchanged (its repairs
      // never widen past one ring with ten or fewer left); each repair of
      // the finishing rounds 90-230 moves and 0.06-0.08 s instead of
      // 4000-11000 and 0.2-0.5 s. The volume ratios' p1 0.236, 0.240,
      // 0.203, 0.214 -> 0.243, 0.240, 0.206, 0.216; one more edge split on
      // k = 4 and two on k = 2.
      untangleOptions.localRepairFewTets = kRepairFewTets;
      untangleOptions.targetVolumes = r.targetVolume;
      // A few tets left that wider regions do not repair: the local repair,
      // the finishing rounds and the edge splits below take them (see
      // UntangleOptions::stallBelow).
      untangleOptions.stallBelow = kMaxSplitTets;
      if (untangleOptions.regionStallRounds == 0) untangleOptions.regionStallRounds = kRegionStallRounds;
      untangleOptions.progress = [&](double, const std::string& m) {
        return !options.progress || options.progress(-1, "final " + m);
      };
      // With the boundary held, the tets on boundary triangles the placement
      // flipped cannot be repaired, so the boundary vertices within
      // kSlideRings rings of them slide on ∂Ω; the rest of the boundary stays
      // where the placement put it, on the cube along its edges. Measured
      // (cube, final untangling): fandisk 26.5 s -> 3 s, retinal 79 -> 7 s.
      std::vector<bool> fixed = holdBoundaryAwayFromFlips(r.U, r.boundaryFaces, apex, kSlideRings);
      if (options.domain == ParamDomain::Ball) {
        untangleOptions.sphereFaces = r.boundaryFaces;
      } else {
        untangleOptions.cubeFaces = r.boundaryFaces;
        untangleOptions.cubeLocks = locks;
      }
      // The morph needs a sphere map with no flipped triangle. The work budget
      // over the phases (finalUntangleWork) applies only where the morph can
      // take over; each phase gets what the ones before left.
      const bool canMorph = options.morphWhenTangled && r.sphere.flippedTriangles == 0;
      const double budget = canMorph && options.finalUntangleWork > 0
                                ? options.finalUntangleWork * static_cast<double>(mesh.numTets())
                                : 0;
      double spent = 0;
      auto runPhase = [&](const Eigen::MatrixX3d& from, bool oneRound = false) {
        // (a budget of one evaluation: the first ε round spends it)
        untangleOptions.maxTetEvaluations = oneRound ? 1 : budget > 0 ? std::max(1.0, budget - spent) : 0;
        UntangleResult u = untangle(mesh.V, mesh.T, from, fixed, untangleOptions);
        spent += u.tetEvaluations;
        return u;
      };
      // The phases after the first let the whole boundary slide, with the
      // wider, longer default runs that sliding needs.
      auto freeTheBoundary = [&] {
        std::fill(fixed.begin(), fixed.end(), false);
        untangleOptions.rings = UntangleOptions().rings;
        untangleOptions.maxLbfgsIterations = UntangleOptions().maxLbfgsIterations;
        untangleOptions.regionRounds = UntangleOptions().regionRounds;
      };
      UntangleResult untangled = runPhase(r.U);
      r.param.invertedTetsBeforeUntangling = untangled.invertedBefore;
      // (the untangler counts the flipped boundary triangles, as cones from apex)
      const int flippedOnCube = options.domain == ParamDomain::Cube ? untangled.flippedBoundaryTriangles : 0;
      if ((untangled.invertedAfter > 0 || flippedOnCube > 0) && !untangled.budgetExhausted && !untangled.stopped) {
        // Let the whole boundary slide on ∂Ω (the faces are set above), flips
        // of its triangles kept out: on the sphere, or on the cube's faces and
        // edges with the coordinates the placement pinned kept (corners never
        // move).
        freeTheBoundary();
        untangled = runPhase(untangled.U);
        if (options.domain == ParamDomain::Cube && (untangled.invertedAfter > 0 || untangled.flippedBoundaryTriangles > 0) &&
            !untangled.budgetExhausted && !untangled.stopped) {
          // Still tangled: a face vertex may be on the wrong side of a cube
          // edge (the placement decides each vertex's face once), which no
          // sliding within that face repairs; now face vertices may cross
          // onto a neighbouring face. Only as a last resort: as the default
          // it lowered fandisk's median volume ratio from 0.91 to 0.81.
          untangleOptions.cubeAcrossEdges = true;
          untangled = runPhase(untangled.U);
        }
      }
      // The budget spent with a few tets left: more ε rounds (on the cube
      // across edges), each with the local repair after it, while each leaves
      // fewer (at most kFinishingRounds). Measured on bunny00 (767k tets):
      // 9 tets and 2 triangles left after the sliding phase (three face
      // vertices slid onto one cube edge from two faces): 7 -> 0 in one round,
      // in well under a second, where the morph's cube start fails; with
      // another transport's last bits, 53 left after the local repair:
      // 55 -> 2 -> 0 in two rounds (5 s), where a single round left 2 and
      // the morph took 931 s for them.
      // The ball gets the same rounds, now that the local repair slides
      // sphere vertices and moves patches jointly (untangle.h,
      // localRepairSweeps): bunny00's ball map, 6 left, 6 -> 2 -> 1 -> 0
      // (since the transport's AMG solves: 8371 left, 11 after the repair,
      // 0 after one round).
      // ε rounds, each with the local repair, while each leaves fewer; the
      // rounds kept. One ε round each also after a stall, where the rest of
      // the budget would pay for growing regions again: measured on bunny00
      // scaled by 1 + 10⁻⁹, a finishing round that ran its regions until they
      // stalled took 30 s for 80 -> 58, the next grew to every vertex.
      // (With the whole boundary free, across cube edges, interior vertices
      // kept in the cube.)
      auto finishingRounds = [&](int& leftOver) {
        freeTheBoundary();
        untangleOptions.cubeAcrossEdges = options.domain == ParamDomain::Cube;
        untangleOptions.keepInteriorInCube = true;
        int kept = 0;
        for (int round = 0; round < kFinishingRounds && leftOver > 0; ++round) {
          UntangleResult finished = runPhase(untangled.U, true);
          if (finished.stopped) throw Status::failure("stopped during the final untangling");
          const int left = finished.invertedAfter + finished.flippedBoundaryTriangles;
          if (left >= leftOver) break;
          untangled = std::move(finished);
          leftOver = left;
          ++kept;
        }
        return kept;
      };
      int leftOver = untangled.invertedAfter + untangled.flippedBoundaryTriangles;
      if (leftOver > 0 && (untangled.budgetExhausted || untangled.stalled) && !untangled.stopped &&
          options.untangle.localRepairSweeps > 0 &&
          leftOver <= std::max(100.0, options.untangle.localRepairFraction * static_cast<double>(nt)))
        r.param.finishingRounds += finishingRounds(leftOver);
      // Tets that no round repairs, pinched between their neighbours (on
      // bunny00 scaled by 1 + 10⁻⁹ and 1 + 2·10⁻⁹, with interior vertices
      // kept in the cube: 1 and 3 tets, e.g. one boundary and three interior
      // vertices with a 0.2 long edge, volume −10⁻¹⁴ of a target 10⁻⁶; the
      // morph took 850 s for them): split the longest edge of each, as
      // splitBoundaryChords splits chords, and run the rounds again. The new
      // vertex is free to leave the edge. Measured on those two: 1 -> 0 and
      // 3 -> 0 in one round (about 1 s).
      // (Like those rounds, only with the local repair.) When they do not end
      // valid, everything goes back to before the splits (measured: spool on
      // the cube, on one of three runs of the same input, 3 tets left after
      // the splits, and the morph on the split mesh found no start), and
      // every edge of each tet left is split instead: a tet pinched flat
      // with no long edge, or flat because two of its vertices nearly meet,
      // gets a free vertex on each edge. Measured on spool scaled by
      // 1 + 3·10⁻⁹ (cube): 2 tets left, each with one cube-face and three
      // interior vertices, volume −10⁻¹¹ of a target 6·10⁻⁶ (in one, two
      // vertices 2.6·10⁻⁴ apart in U, 0.03 in the input); the longest-edge
      // splits (8) did not repair them and the morph then failed after
      // 80 s (the run ended with 2 tets inverted); all their edges (12):
      // 9 -> 0 in the local repair, in 5 ms. Longest edges first, so that
      // the maps those repair stay as they were. When neither ends valid,
      // everything goes back to before the splits, for the morph.
      struct BeforeSplits {
        TetMesh mesh;
        UntangleResult untangled;
        Eigen::MatrixX3d ballU;
        Eigen::VectorXd w, physical, weighted, targetVolume;
        std::vector<char> jumps;
        std::vector<bool> fixed;
        std::vector<std::uint8_t> locks;
        int finishingRounds;
      };
      auto fewTetsLeft = [&] {
        return options.untangle.localRepairSweeps > 0 && !untangled.stopped && untangled.invertedAfter > 0 &&
               untangled.invertedAfter <= kMaxSplitTets;
      };
      std::optional<BeforeSplits> beforeSplits;
      if (fewTetsLeft())
        beforeSplits = BeforeSplits{r.mesh, untangled, r.ballU, w, physical, weighted, r.targetVolume,
                                    jumps, fixed, locks, r.param.finishingRounds};
      // Split rounds (longest edges, or every edge); when they end with tets
      // left, everything goes back to before the splits.
      int undoneSplits = 0;
      auto splitRounds = [&](bool everyEdge) {
        for (int splitRound = 0; splitRound < kSplitRounds && fewTetsLeft(); ++splitRound) {
          const EdgeSplits cut = splitEdges(r.mesh, edgesToSplit(untangled.U, mesh.T, r.boundaryVertices, everyEdge));
          if (cut.splits.empty()) break;
          nv = mesh.numVertices(), nt = mesh.numTets();
          // Every per-vertex and per-tet array follows the mesh.
          growBySplits(untangled.U, cut, nv);
          growBySplits(r.ballU, cut, nv);
          fixed.resize(static_cast<size_t>(nv), false);
          if (!locks.empty()) locks.resize(static_cast<size_t>(nv), 0);
          jumps.resize(static_cast<size_t>(nv), 0);
          for (const EdgeSplit& e : cut.splits)
            jumps[static_cast<size_t>(e.vertex)] = jumps[static_cast<size_t>(e.a)] && jumps[static_cast<size_t>(e.b)];
          const Eigen::VectorXd w0 = w;
          w.resize(nt);
          for (Eigen::Index t = 0; t < nt; ++t) w(t) = w0(cut.parent[static_cast<size_t>(t)]);
          measureTets();
          r.targetVolume = weighted * (r.domainVolume / totalWeighted);
          untangleOptions.targetVolumes = r.targetVolume;
          if (!locks.empty()) untangleOptions.cubeLocks = locks;
          r.param.splitEdges += static_cast<int>(cut.splits.size());
          leftOver = countNonPositiveTets(untangled.U, mesh.T) + untangled.flippedBoundaryTriangles;
          untangled.invertedAfter = leftOver - untangled.flippedBoundaryTriangles;
          r.param.finishingRounds += finishingRounds(leftOver);
        }
        if (untangled.invertedAfter == 0 && untangled.flippedBoundaryTriangles == 0) return;
        if (!beforeSplits || r.param.splitEdges == 0) return;
        const BeforeSplits& b = *beforeSplits;  // (copied: the second attempt starts from it too)
        r.mesh = b.mesh;
        untangled = b.untangled;
        r.ballU = b.ballU;
        w = b.w, physical = b.physical, weighted = b.weighted;
        r.targetVolume = b.targetVolume;
        jumps = b.jumps, fixed = b.fixed, locks = b.locks;
        r.param.finishingRounds = b.finishingRounds;
        nv = mesh.numVertices(), nt = mesh.numTets();
        untangleOptions.targetVolumes = r.targetVolume;
        if (!locks.empty()) untangleOptions.cubeLocks = locks;
        undoneSplits += r.param.splitEdges;
        r.param.splitEdges = 0;
      };
      splitRounds(false);
      if (beforeSplits && (untangled.invertedAfter > 0 || untangled.flippedBoundaryTriangles > 0)) splitRounds(true);
      if (undoneSplits > 0)
        r.warnings.push_back("split " + std::to_string(undoneSplits) +
                             " edges of tets the final untangling left inverted, which did not repair them; the "
                             "splits were undone");
      if (r.param.splitEdges > 0)
        r.warnings.push_back("split " + std::to_string(r.param.splitEdges) +
                             " edges of tets the final untangling left inverted (param.split_edges): the "
                             "parameterized mesh has that many more vertices than the input");
      r.timings.finalUntangle = secondsSince(t0);
      if (untangled.stopped) throw Status::failure("stopped during the final untangling");
      if ((untangled.invertedAfter > 0 || untangled.flippedBoundaryTriangles > 0) && canMorph) {
        // The composition folds more than untangling repairs: start again
        // from the bijective ball map (stretched onto the cube) and move it
        // towards the untangler's result, which is bijective almost
        // everywhere, behind a barrier that keeps every tet positive
        // (barrier_morph.h).
        t0 = Clock::now();
        report(0.95, "morph from the ball map");
        UntangleOptions startOptions;
        startOptions.progress = untangleOptions.progress;
        // (Shorter ε rounds, to reach the local max-min repair sooner, left
        // spool.off's start with 6 tets inverted: its default rounds take
        // 50 s of the fallback's 58.)
        BarrierMorphOptions morph;
        morph.targetVolumes = r.targetVolume;
        (options.domain == ParamDomain::Cube ? morph.cubeFaces : morph.sphereFaces) = r.boundaryFaces;
        morph.progress = [&](double, const std::string& m) { return !options.progress || options.progress(-1, m); };
        std::optional<BarrierMorphResult> best;  // of the morphs run, the one that ends closest to its target
        auto morphFrom = [&](const Eigen::MatrixX3d& start) {
          BarrierMorphResult morphed =
              morphTowards(mesh.V, mesh.T, start, untangled.U, std::vector<bool>(static_cast<size_t>(nv), false), morph);
          if (morphed.stopped) throw Status::failure("stopped during the morph");
          if (!best || morphed.distance < best->distance) best = std::move(morphed);
        };
        const Eigen::MatrixX3d ball = ballStart(mesh, r.ballU, r.boundaryFaces, startOptions);
        if (ball.rows() == nv && options.domain == ParamDomain::Ball) {
          morphFrom(ball);
        } else if (ball.rows() == nv) {
          const Eigen::MatrixX3d stretched = stretchOntoCube(ball, r.boundaryFaces);
          if (countNonPositiveTets(stretched, mesh.T) == 0) {
            morphFrom(stretched);
          } else {
            for (const MorphStartShapes shapes : {MorphStartShapes::BallMap, MorphStartShapes::Input}) {
              if (best && best->distance <= kMorphCloseEnough) break;
              const Eigen::MatrixX3d start = untangleStretch(mesh, ball, stretched, r.boundaryFaces, shapes, startOptions);
              if (start.rows() == nv) morphFrom(start);
            }
          }
        }
        if (best) {
          r.param.morphed = true;
          r.param.morphDistance = best->distance;
          r.param.morphMaxDistance = best->maxDistance;
          r.warnings.push_back(
              "the transport's composition could not be untangled (" + std::to_string(untangled.invertedAfter) +
              " tets left inverted" + (untangled.budgetExhausted ? " when its work budget was spent" : "") +
              "); the parameterization is the ball map moved towards it without inverting a tet "
              "(param.morph: root mean square distance " + formatDouble(best->distance) + " target edges)");
          untangled.U = std::move(best->U);
          untangled.invertedAfter = countNonPositiveTets(untangled.U, mesh.T);
        }
        r.timings.morph = secondsSince(t0);
      }
      r.U = std::move(untangled.U);
      t0 = Clock::now();
      if (options.relaxIterations > 0 && untangled.invertedAfter == 0) {
        // Measure relaxation where the density jumps (see relaxIterations):
        // the vertices within relaxRings rings of a vertex whose tets have
        // different densities move; the others and the boundary stay.
        std::vector<char> jump = jumps;  // grown by rings below
        for (int ring = 0; ring < options.relaxRings; ++ring) {
          std::vector<char> next = jump;
          for (Eigen::Index t = 0; t < nt; ++t) {
            bool touches = false;
            for (int k = 0; k < 4; ++k) touches = touches || jump[static_cast<size_t>(mesh.T(t, k))];
            if (touches)
              for (int k = 0; k < 4; ++k) next[static_cast<size_t>(mesh.T(t, k))] = 1;
          }
          jump.swap(next);
        }
        std::vector<bool> held(static_cast<size_t>(nv), true);
        int moving = 0;
        for (Eigen::Index i = 0; i < nv; ++i) held[static_cast<size_t>(i)] = !jump[static_cast<size_t>(i)];
        for (Eigen::Index k = 0; k < r.boundaryVertices.size(); ++k) held[static_cast<size_t>(r.boundaryVertices(k))] = true;
        for (Eigen::Index i = 0; i < nv; ++i) moving += !held[static_cast<size_t>(i)];
        if (moving > 0) {
          UntangleOptions relax = untangleOptions;
          relax.sphereFaces.resize(0, 3);
          relax.relax = true;
          relax.maxTetEvaluations = 0;  // (no inversions: the budget is for untangling)
          relax.method = UntangleMethod::Lbfgs;  // (its iteration budget is the L-BFGS one)
          relax.theta = options.relaxTheta;
          relax.maxLbfgsIterations = options.relaxIterations;
          UntangleResult relaxed = untangle(mesh.V, mesh.T, r.U, held, relax);
          if (relaxed.invertedAfter == 0) r.U = std::move(relaxed.U);
        }
      }
      r.timings.relax = secondsSince(t0);

      // 7. tangential smoothing of the boundary (boundary_smoothing.h)
      t0 = Clock::now();
      if (options.boundarySmoothing.sweeps > 0 || options.boundarySmoothing.interiorSweeps > 0) {
        report(0.99, "boundary smoothing");
        BoundarySmoothingOptions smoothing = options.boundarySmoothing;
        smoothing.shape = options.domain == ParamDomain::Cube ? BoundaryShape::UnitCube : BoundaryShape::UnitSphere;
        smoothing.targetVolumes = r.targetVolume;
        smoothing.held.assign(jumps.begin(), jumps.end());
        BoundarySmoothingResult smoothed = smoothBoundary(mesh.V, mesh.T, r.U, r.boundaryFaces, smoothing);
        r.U = std::move(smoothed.U);
        r.param.boundarySmoothingMoves = smoothed.moves;
        r.param.interiorSmoothingMoves = smoothed.interiorMoves;
        r.param.boundarySmoothingRefused = smoothed.refused;
        r.param.boundarySmoothingRms = smoothed.rmsMove;
      }
      r.timings.boundarySmoothing = secondsSince(t0);
    }

    // Figures.
    r.param.invertedTets = countNonPositiveTets(r.U, mesh.T);
    r.param.flippedBoundaryTriangles = countFlippedTriangles(r.U, r.boundaryFaces, apex);
    for (Eigen::Index k = 0; k < r.boundaryVertices.size(); ++k) {
      const Eigen::Vector3d u = r.U.row(r.boundaryVertices(k));
      double d = 0;
      if (options.domain == ParamDomain::Ball) {
        d = std::abs(u.norm() - 1);
      } else {
        const double outside = (u.array() - u.array().min(1.0).max(0.0)).matrix().norm();
        const double toFace = std::min(u.minCoeff(), (1 - u.array()).minCoeff());
        d = std::max(outside, std::abs(toFace));
      }
      r.param.boundaryMaxDistance = std::max(r.param.boundaryMaxDistance, d);
    }
    r.parametricVolume = signedVolumes(r.U, mesh.T);
    std::vector<double> ratios(static_cast<size_t>(nt));
    for (Eigen::Index t = 0; t < nt; ++t) ratios[static_cast<size_t>(t)] = r.parametricVolume(t) / r.targetVolume(t);
    r.param.volumeRatio = summarise(std::move(ratios));
    {
      const bool cube = options.domain == ParamDomain::Cube;
      r.param.misplacedVolume = misplacedFraction(r.U, mesh.T, r.parametricVolume, r.targetVolume,
                                                  Eigen::Vector3d::Constant(cube ? 0.0 : -1.0), Eigen::Vector3d::Constant(1.0),
                                                  kMisplacementCells);
    }
    std::map<int, RegionFigures> regions;
    std::map<int, double> regionWeighted;
    const double totalParametric = r.parametricVolume.sum();
    for (Eigen::Index t = 0; t < nt; ++t) {
      RegionFigures& g = regions[mesh.region(t)];
      g.id = mesh.region(t);
      g.isVoid = mesh.voidRegions.count(g.id) > 0;
      g.physicalVolume += physical(t);
      regionWeighted[g.id] += weighted(t);
      g.targetVolumeFraction += weighted(t) / totalWeighted;
      g.achievedVolumeFraction += r.parametricVolume(t) / totalParametric;
    }
    for (auto& [id, g] : regions) {
      g.density = regionWeighted[id] / g.physicalVolume;
      r.regions.push_back(g);
    }
    if (r.param.invertedTets > 0)
      r.status = Status::failure(std::to_string(r.param.invertedTets) + " tets of the parameterization remain inverted");
  } catch (const Status& stopped) {
    r.status = stopped;
  }
  r.timings.total = secondsSince(start);
  return r;
}

}  // namespace tet2spline

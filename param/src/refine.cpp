#include "tet2spline/param/refine.h"

#include <Eigen/Geometry>
#include <tbb/parallel_sort.h>
#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <unordered_set>
#include <utility>
#include <vector>

#include "tet2spline/param/topology.h"

namespace tet2spline {
namespace {

std::uint64_t edgeKey(int a, int b) {
  if (a > b) std::swap(a, b);
  return (static_cast<std::uint64_t>(a) << 32) | static_cast<std::uint32_t>(b);
}

constexpr std::array<std::array<int, 2>, 6> kTetEdges{{{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}}};

// Chords in a deterministic order (by first appearance in T). `onBoundary`
// is set to the boundary vertices' flags.
std::vector<std::pair<int, int>> findChords(const TetMesh& mesh, std::vector<char>& onBoundary) {
  const Eigen::MatrixX3i F = boundaryFaces(mesh);
  const size_t nv = static_cast<size_t>(mesh.numVertices());
  onBoundary.assign(nv, 0);
  // Each vertex's neighbours along the boundary edges, as CSR (a neighbour
  // once per boundary face they share): an edge between two boundary
  // vertices is a boundary edge if one lists the other. (A hash set of the
  // boundary edges, asked for every such tet edge, was most of this
  // function's 0.3 s on bunny00.)
  std::vector<int> start(nv + 1, 0);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      onBoundary[static_cast<size_t>(F(f, k))] = 1;
      start[static_cast<size_t>(F(f, k)) + 1] += 2;
    }
  for (size_t v = 0; v < nv; ++v) start[v + 1] += start[v];
  std::vector<int> neighbour(static_cast<size_t>(start[nv]));
  {
    std::vector<int> fill(start.begin(), start.end() - 1);
    for (Eigen::Index f = 0; f < F.rows(); ++f)
      for (int k = 0; k < 3; ++k) {
        int& at = fill[static_cast<size_t>(F(f, k))];
        neighbour[static_cast<size_t>(at++)] = F(f, (k + 1) % 3);
        neighbour[static_cast<size_t>(at++)] = F(f, (k + 2) % 3);
      }
  }
  auto boundaryEdge = [&](int a, int b) {
    const auto first = neighbour.begin() + start[static_cast<size_t>(a)];
    const auto last = neighbour.begin() + start[static_cast<size_t>(a) + 1];
    return std::find(first, last, b) != last;
  };
  std::vector<std::pair<int, int>> chords;
  std::unordered_set<std::uint64_t> seen;
  for (Eigen::Index t = 0; t < mesh.numTets(); ++t)
    for (const auto& e : kTetEdges) {
      const int a = mesh.T(t, e[0]), b = mesh.T(t, e[1]);
      if (!onBoundary[static_cast<size_t>(a)] || !onBoundary[static_cast<size_t>(b)] || boundaryEdge(a, b)) continue;
      if (!seen.insert(edgeKey(a, b)).second) continue;
      chords.emplace_back(std::min(a, b), std::max(a, b));
    }
  return chords;
}

}  // namespace

int countBoundaryChords(const TetMesh& mesh) {
  std::vector<char> onBoundary;
  return static_cast<int>(findChords(mesh, onBoundary).size());
}

namespace {

// Interior faces whose three vertices are on the boundary (their edges are
// boundary edges, so no chord split touches them; e.g. the inner face of a
// tet with three faces on the boundary at a sharp corner) would lie flat on
// one face of the cube, between two tets. Each gets a new vertex at its
// centroid, and its two tets become three each. Returns the faces split.
// `onBoundary`: the flags of the boundary vertices (vertices past its end
// are interior).
int splitBoundaryFaces(TetMesh& mesh, std::vector<char> onBoundary) {
  onBoundary.resize(static_cast<size_t>(mesh.numVertices()), 0);
  // Faces with three boundary vertices, seen from two tets (interior).
  std::vector<std::array<int, 3>> candidates;
  for (Eigen::Index t = 0; t < mesh.numTets(); ++t)
    for (int skip = 0; skip < 4; ++skip) {
      std::array<int, 3> f;
      int n = 0;
      for (int k = 0; k < 4; ++k)
        if (k != skip) f[static_cast<size_t>(n++)] = mesh.T(t, k);
      if (!onBoundary[static_cast<size_t>(f[0])] || !onBoundary[static_cast<size_t>(f[1])] ||
          !onBoundary[static_cast<size_t>(f[2])])
        continue;
      std::sort(f.begin(), f.end());
      candidates.push_back(f);
    }
  tbb::parallel_sort(candidates.begin(), candidates.end());  // (equal faces are equal values: the same order)
  std::vector<std::array<int, 3>> interior;
  for (size_t i = 0; i + 1 < candidates.size(); ++i)
    if (candidates[i] == candidates[i + 1]) interior.push_back(candidates[i]);
  for (const auto& f : interior) {
    std::vector<Eigen::Index> around;
    for (Eigen::Index t = 0; t < mesh.numTets(); ++t) {
      int hits = 0;
      for (int k = 0; k < 4; ++k) hits += mesh.T(t, k) == f[0] || mesh.T(t, k) == f[1] || mesh.T(t, k) == f[2];
      if (hits == 3) around.push_back(t);
    }
    const Eigen::Index m = mesh.numVertices();
    mesh.V.conservativeResize(m + 1, 3);
    mesh.V.row(m) = (mesh.V.row(f[0]) + mesh.V.row(f[1]) + mesh.V.row(f[2])) / 3.0;
    for (auto& field : mesh.pointFields) {
      field.values.conservativeResize(m + 1, field.values.cols());
      field.values.row(m) = (field.values.row(f[0]) + field.values.row(f[1]) + field.values.row(f[2])) / 3.0;
    }
    for (Eigen::Index t : around) {
      const Eigen::Index nt = mesh.numTets();
      mesh.T.conservativeResize(nt + 2, 4);
      mesh.region.conservativeResize(nt + 2);
      for (auto& field : mesh.cellFields) field.values.conservativeResize(nt + 2, field.values.cols());
      const Eigen::RowVector4i q = mesh.T.row(t);
      // m lies in the face, so replacing one face vertex by it keeps the orientation.
      int made = 0;
      for (int k = 0; k < 4; ++k) {
        if (q(k) != f[0] && q(k) != f[1] && q(k) != f[2]) continue;
        Eigen::RowVector4i r = q;
        r(k) = static_cast<int>(m);
        const Eigen::Index row = made == 0 ? t : nt + made - 1;
        mesh.T.row(row) = r;
        mesh.region(row) = mesh.region(t);
        for (auto& field : mesh.cellFields) field.values.row(row) = field.values.row(t);
        ++made;
      }
    }
  }
  return static_cast<int>(interior.size());
}

}  // namespace

// A chord's split only replaces the tets around it (an interior edge, in no
// boundary face) and adds an interior vertex, so the boundary faces and
// their vertices are the same after the chord splits: the boundary is
// found once (one pass of tetFaces over every tet fewer). With findChords'
// boundary-edge lists instead of its hash set, bunny00's chord step took
// 0.7, 0.8, 0.7 s against 1.3, 1.3, 1.3 s (alternating runs, 2026-12-07).
int splitBoundaryChords(TetMesh& mesh) {
  std::vector<char> onBoundary;
  const std::vector<std::pair<int, int>> chords = findChords(mesh, onBoundary);
  const int split = chords.empty() ? 0 : static_cast<int>(splitEdges(mesh, chords).splits.size());
  return split + splitBoundaryFaces(mesh, std::move(onBoundary));
}

EdgeSplits splitEdges(TetMesh& mesh, const std::vector<std::pair<int, int>>& edges) {
  EdgeSplits result;
  const Eigen::Index nv0 = mesh.numVertices(), nt0 = mesh.numTets();
  const Eigen::Index nc = static_cast<Eigen::Index>(edges.size());
  // Each edge adds one vertex, and one tet per tet around it (about 5).
  std::vector<std::array<int, 4>> tets(static_cast<size_t>(nt0));
  for (Eigen::Index t = 0; t < nt0; ++t) tets[t] = {mesh.T(t, 0), mesh.T(t, 1), mesh.T(t, 2), mesh.T(t, 3)};
  std::vector<int> parent(static_cast<size_t>(nt0));  // original tet of each tet (region, cell fields)
  for (Eigen::Index t = 0; t < nt0; ++t) parent[static_cast<size_t>(t)] = static_cast<int>(t);
  std::vector<std::vector<int>> vertexTets(static_cast<size_t>(nv0 + nc));
  for (Eigen::Index t = 0; t < nt0; ++t)
    for (int k = 0; k < 4; ++k) vertexTets[static_cast<size_t>(mesh.T(t, k))].push_back(static_cast<int>(t));

  Eigen::MatrixX3d V(nv0 + nc, 3);
  V.topRows(nv0) = mesh.V;
  std::vector<Field> pointFields = mesh.pointFields;
  for (auto& f : pointFields) {
    Eigen::MatrixXd values(nv0 + nc, f.values.cols());
    values.topRows(nv0) = f.values;
    f.values = std::move(values);
  }

  // Position of the new vertex on the edge: the midpoint, unless a sliver
  // around the edge would get a non-positive volume in floating point
  // (the midpoint is rounded; later stages need vol > 0 in doubles): then
  // the point of the edge, among a few, that keeps every new tet positive
  // (exactly and in doubles) by the widest margin. No such point: the edge
  // stays (rare; reported by the return value's shortfall).
  auto tetVolume = [](const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, const Eigen::Vector3d& p2,
                      const Eigen::Vector3d& p3) { return (p1 - p0).cross(p2 - p0).dot(p3 - p0); };
  Eigen::Index nvNew = nv0;
  for (Eigen::Index c = 0; c < nc; ++c) {
    const auto [a, b] = edges[static_cast<size_t>(c)];
    if (a == b || a < 0 || b < 0 || a >= nv0 || b >= nv0) continue;
    // Tets around the edge: those of a that also hold b.
    std::vector<int> around;
    for (int t : vertexTets[static_cast<size_t>(a)]) {
      const auto& q = tets[static_cast<size_t>(t)];
      if (std::find(q.begin(), q.end(), b) != q.end()) around.push_back(t);
    }
    if (around.empty()) continue;
    auto worst = [&](const Eigen::Vector3d& p) {
      double margin = std::numeric_limits<double>::infinity();
      for (int t : around) {
        for (int side = 0; side < 2; ++side) {
          std::array<Eigen::Vector3d, 4> x;
          for (int k = 0; k < 4; ++k) {
            const int v = tets[static_cast<size_t>(t)][static_cast<size_t>(k)];
            x[static_cast<size_t>(k)] = (side == 0 ? v == b : v == a) ? p : Eigen::Vector3d(V.row(v));
          }
          if (orient3d(x[0].data(), x[1].data(), x[2].data(), x[3].data()) <= 0) return -1.0;
          margin = std::min(margin, tetVolume(x[0], x[1], x[2], x[3]));
        }
      }
      return margin;
    };
    const Eigen::Vector3d pa = V.row(a), pb = V.row(b);
    double bestT = 0.5;
    Eigen::Vector3d best = 0.5 * (pa + pb);
    double bestMargin = worst(best);
    if (!(bestMargin > 0)) {
      for (double t : {0.45, 0.55, 0.4, 0.6, 0.35, 0.65, 0.3, 0.7, 0.25, 0.75}) {
        const Eigen::Vector3d p = pa + t * (pb - pa);
        const double m = worst(p);
        if (m > bestMargin) bestMargin = m, best = p, bestT = t;
      }
    }
    if (!(bestMargin > 0)) continue;
    const int m = static_cast<int>(nvNew++);
    result.splits.push_back({a, b, m, bestT});
    V.row(m) = best;
    for (auto& f : pointFields) f.values.row(m) = (1 - bestT) * f.values.row(a) + bestT * f.values.row(b);
    auto& tb = vertexTets[static_cast<size_t>(b)];
    for (int t : around) {
      // (.., a, .., b, ..) -> (.., a, .., m, ..) and (.., m, .., b, ..): m lies
      // on segment ab, so both keep the orientation of the original tet.
      std::array<int, 4> second = tets[static_cast<size_t>(t)];
      for (int& v : tets[static_cast<size_t>(t)]) if (v == b) v = m;
      for (int& v : second) if (v == a) v = m;
      const int t2 = static_cast<int>(tets.size());
      tets.push_back(second);
      parent.push_back(parent[static_cast<size_t>(t)]);
      tb.erase(std::find(tb.begin(), tb.end(), t));
      for (int v : second) vertexTets[static_cast<size_t>(v)].push_back(t2);
      vertexTets[static_cast<size_t>(m)].push_back(t);
    }
  }
  V.conservativeResize(nvNew, 3);
  for (auto& f : pointFields) f.values.conservativeResize(nvNew, f.values.cols());

  const Eigen::Index nt = static_cast<Eigen::Index>(tets.size());
  Eigen::MatrixX4i T(nt, 4);
  Eigen::VectorXi region(nt);
  for (Eigen::Index t = 0; t < nt; ++t) {
    for (int k = 0; k < 4; ++k) T(t, k) = tets[static_cast<size_t>(t)][static_cast<size_t>(k)];
    region(t) = mesh.region(parent[static_cast<size_t>(t)]);
  }
  for (auto& f : mesh.cellFields) {
    Eigen::MatrixXd values(nt, f.values.cols());
    for (Eigen::Index t = 0; t < nt; ++t) values.row(t) = f.values.row(parent[static_cast<size_t>(t)]);
    f.values = std::move(values);
  }
  mesh.V = std::move(V);
  mesh.T = std::move(T);
  mesh.region = std::move(region);
  mesh.pointFields = std::move(pointFields);
  result.parent = std::move(parent);
  return result;
}

}  // namespace tet2spline

// Topology and validity of tetrahedral solids and triangle surfaces
// (design.md, "Topology"). Everything combinatorial is done with sorted keys
// (no hashing, deterministic); signs of volumes come from exact orient3d.
#include "tet2spline/param/topology.h"

#include <Eigen/Geometry>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numeric>

#include "self_intersection.h"
#include "shell_geometry.h"
#include "tet_faces.h"

namespace tet2spline {

namespace {

using Tri = std::array<int, 3>;

class UnionFind {
 public:
  explicit UnionFind(std::size_t n) : parent_(n) { std::iota(parent_.begin(), parent_.end(), 0); }
  int find(int i) {
    while (parent_[i] != i) i = parent_[i] = parent_[parent_[i]];
    return i;
  }
  void unite(int a, int b) {
    a = find(a), b = find(b);
    if (a == b) return;
    if (a < b) std::swap(a, b);
    parent_[a] = b;  // the smaller index is the root: components are ordered by their first element
  }

 private:
  std::vector<int> parent_;
};

std::string plural(long n, const std::string& one, const std::string& many) {
  return std::to_string(n) + " " + (n == 1 ? one : many);
}

inline std::uint64_t edgeKey(int a, int b) {
  if (a > b) std::swap(a, b);
  return (std::uint64_t(std::uint32_t(a)) << 32) | std::uint32_t(b);
}

/// Combinatorics of a set of triangles (a surface, or the boundary of a tet mesh).
struct TriangleTopology {
  std::vector<ShellInfo> shells;                ///< in the order of their first faces
  std::vector<std::vector<int>> shellFaces;
  int boundaryEdges = 0;
  int boundaryLoops = 0;
  int nonManifoldEdges = 0;
  int nonManifoldVertices = 0;
  int inconsistentEdges = 0;
};

TriangleTopology analyzeTriangles(const Eigen::MatrixX3d& V, const std::vector<Tri>& F) {
  TriangleTopology out;
  const int nF = static_cast<int>(F.size());
  if (nF == 0) return out;

  // Edges: one record per triangle side, sorted by the undirected key.
  struct EdgeUse {
    std::uint64_t key;
    int face;
    bool forward;  // the triangle runs the edge from the smaller to the larger index
  };
  std::vector<EdgeUse> uses;
  uses.reserve(3 * std::size_t(nF));
  for (int f = 0; f < nF; ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = F[f][k], b = F[f][(k + 1) % 3];
      uses.push_back({edgeKey(a, b), f, a < b});
    }
  tbb::parallel_sort(uses.begin(), uses.end(), [](const EdgeUse& x, const EdgeUse& y) {
    return x.key != y.key ? x.key < y.key : x.face < y.face;
  });

  UnionFind faceSets(nF);
  struct EdgeGroup {
    std::size_t begin, end;
  };
  std::vector<EdgeGroup> groups;
  for (std::size_t i = 0; i < uses.size();) {
    std::size_t j = i;
    while (j < uses.size() && uses[j].key == uses[i].key) ++j;
    groups.push_back({i, j});
    if (j - i == 2) faceSets.unite(uses[i].face, uses[i + 1].face);
    i = j;
  }

  // Shells in the order of their first faces.
  std::vector<int> shellOf(nF, -1);
  std::vector<int> rootShell(nF, -1);
  for (int f = 0; f < nF; ++f) {
    const int r = faceSets.find(f);
    if (rootShell[r] < 0) {
      rootShell[r] = static_cast<int>(out.shells.size());
      out.shells.emplace_back();
      out.shellFaces.emplace_back();
    }
    shellOf[f] = rootShell[r];
    out.shellFaces[shellOf[f]].push_back(f);
  }
  const int nS = static_cast<int>(out.shells.size());
  std::vector<char> open(nS, 0);

  // Edge counts per shell, boundary / non-manifold / inconsistent edges.
  std::vector<std::pair<int, int>> boundaryEdgeList;
  for (const auto& g : groups) {
    const std::size_t n = g.end - g.begin;
    if (n == 2) {
      const int s = shellOf[uses[g.begin].face];
      ++out.shells[s].edges;
      if (uses[g.begin].forward == uses[g.begin + 1].forward) {
        ++out.shells[s].inconsistentEdges;
        ++out.inconsistentEdges;
      }
      continue;
    }
    if (n == 1) {
      ++out.boundaryEdges;
      const auto key = uses[g.begin].key;
      boundaryEdgeList.emplace_back(int(key >> 32), int(key & 0xffffffffu));
    } else {
      ++out.nonManifoldEdges;
    }
    // The edge belongs to every shell that has one of its triangles.
    std::vector<int> s;
    for (std::size_t i = g.begin; i < g.end; ++i) s.push_back(shellOf[uses[i].face]);
    std::sort(s.begin(), s.end());
    s.erase(std::unique(s.begin(), s.end()), s.end());
    for (int k : s) ++out.shells[k].edges, open[k] = 1;
  }

  // Holes: connected groups of boundary edges.
  if (!boundaryEdgeList.empty()) {
    UnionFind loops(V.rows());
    std::vector<int> verts;
    for (auto [a, b] : boundaryEdgeList) loops.unite(a, b), verts.push_back(a);
    std::vector<int> roots;
    for (int v : verts) roots.push_back(loops.find(v));
    std::sort(roots.begin(), roots.end());
    out.boundaryLoops = static_cast<int>(std::unique(roots.begin(), roots.end()) - roots.begin());
  }

  // Vertices per shell, and the fan (link) of every vertex.
  struct Corner {
    int v, a, b, shell;
  };
  std::vector<Corner> corners;
  corners.reserve(3 * std::size_t(nF));
  for (int f = 0; f < nF; ++f)
    for (int k = 0; k < 3; ++k) corners.push_back({F[f][k], F[f][(k + 1) % 3], F[f][(k + 2) % 3], shellOf[f]});
  tbb::parallel_sort(corners.begin(), corners.end(), [](const Corner& x, const Corner& y) {
    return x.v != y.v ? x.v < y.v : x.shell < y.shell;
  });
  std::vector<int> link;
  for (std::size_t i = 0; i < corners.size();) {
    std::size_t j = i;
    while (j < corners.size() && corners[j].v == corners[i].v) ++j;
    for (std::size_t k = i; k < j; ++k)
      if (k == i || corners[k].shell != corners[k - 1].shell) ++out.shells[corners[k].shell].vertices;
    // A manifold vertex has a link that is one cycle (closed) or one path (open):
    // connected, every link vertex of degree <= 2.
    link.clear();
    for (std::size_t k = i; k < j; ++k) link.push_back(corners[k].a), link.push_back(corners[k].b);
    std::sort(link.begin(), link.end());
    bool manifold = true;
    for (std::size_t k = 0; k < link.size();) {
      std::size_t m = k;
      while (m < link.size() && link[m] == link[k]) ++m;
      if (m - k > 2) manifold = false;
      k = m;
    }
    link.erase(std::unique(link.begin(), link.end()), link.end());
    if (manifold && j - i > 1) {
      UnionFind local(link.size());
      auto index = [&](int x) { return int(std::lower_bound(link.begin(), link.end(), x) - link.begin()); };
      for (std::size_t k = i; k < j; ++k) local.unite(index(corners[k].a), index(corners[k].b));
      for (std::size_t k = 1; k < link.size(); ++k)
        if (local.find(int(k)) != local.find(0)) manifold = false;
    }
    if (!manifold) ++out.nonManifoldVertices;
    i = j;
  }

  // Faces, χ, genus and enclosed volume per shell. The volume is taken about a
  // point of the shell so that far-from-origin data keeps its precision.
  for (int s = 0; s < nS; ++s) {
    auto& sh = out.shells[s];
    sh.faces = static_cast<int>(out.shellFaces[s].size());
    sh.eulerCharacteristic = sh.vertices - sh.edges + sh.faces;
    sh.closed = !open[s];
    sh.genus = sh.closed ? (2 - sh.eulerCharacteristic) / 2 : -1;
    const Eigen::RowVector3d o = V.row(F[out.shellFaces[s][0]][0]);
    double volume = 0;
    for (int f : out.shellFaces[s]) {
      const Eigen::Vector3d a = V.row(F[f][0]) - o, b = V.row(F[f][1]) - o, c = V.row(F[f][2]) - o;
      volume += a.dot(b.cross(c));
    }
    sh.enclosedVolume = volume / 6;
  }
  return out;
}

/// Used vertices lying exactly on another used vertex.
int countDuplicatePositions(const Eigen::MatrixX3d& V, const std::vector<char>& used) {
  std::vector<int> idx;
  for (int i = 0; i < V.rows(); ++i)
    if (used[i]) idx.push_back(i);
  auto less = [&](int a, int b) {
    for (int k = 0; k < 3; ++k)
      if (V(a, k) != V(b, k)) return V(a, k) < V(b, k);
    return false;
  };
  tbb::parallel_sort(idx.begin(), idx.end(), less);
  int duplicates = 0;
  for (std::size_t i = 1; i < idx.size(); ++i)
    if (!less(idx[i - 1], idx[i])) ++duplicates;
  return duplicates;
}

}  // namespace

namespace detail {

TetFaces tetFaces(const Eigen::MatrixX4i& T, bool wantComponents) {
  // Outward faces of a positive tet (0,1,2,3).
  static constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  struct FaceUse {
    Tri key;   // sorted vertices
    int tet;
    int local;
  };
  const int nT = static_cast<int>(T.rows());
  auto keyOf = [&](int t, int k) {
    Tri key = {T(t, kFace[k][0]), T(t, kFace[k][1]), T(t, kFace[k][2])};
    std::sort(key.begin(), key.end());
    return key;
  };
  // The uses in the order of (key, tet, local): bucketed by the key's first
  // (smallest) vertex, then each bucket sorted by itself; the same order as
  // one sort of them all (it is total). The tets are cut into kChunks
  // ranges, which count and then fill their buckets on both cores, each
  // range in its own slots of every bucket (their counts' running sums).
  // Measured on bunny00's mesh (767k tets; a program timing both): 0.28 ->
  // 0.15 s a call, four calls between loading the mesh and its spherical
  // map (analyzeSolid, the chord splits' two, the ball map's shell).
  // (Compared element by element: std::array's < is a memcmp call.)
  const int nV = nT > 0 ? T.maxCoeff() + 1 : 0;
  constexpr int kChunks = 8;
  const int per = (nT + kChunks - 1) / kChunks;
  auto chunkTets = [&](int c) { return std::pair(c * per, std::min(nT, (c + 1) * per)); };
  // Per range and vertex: its count, then the first slot it fills.
  std::vector<int> slot(static_cast<std::size_t>(kChunks) * static_cast<std::size_t>(nV), 0);
  auto slotsOf = [&](int c) { return slot.data() + static_cast<std::size_t>(c) * static_cast<std::size_t>(nV); };
  tbb::parallel_for(0, kChunks, [&](int c) {
    int* count = slotsOf(c);
    for (auto [t, end] = chunkTets(c); t < end; ++t)
      for (int k = 0; k < 4; ++k) ++count[keyOf(t, k)[0]];
  });
  std::vector<int> start(static_cast<std::size_t>(nV) + 1, 0);
  int next = 0;
  for (int v = 0; v < nV; ++v) {
    start[static_cast<std::size_t>(v)] = next;
    for (int c = 0; c < kChunks; ++c) {
      const int n = slotsOf(c)[v];
      slotsOf(c)[v] = next;
      next += n;
    }
  }
  start[static_cast<std::size_t>(nV)] = next;
  std::vector<FaceUse> uses(4 * std::size_t(nT));
  tbb::parallel_for(0, kChunks, [&](int c) {
    int* fill = slotsOf(c);
    for (auto [t, end] = chunkTets(c); t < end; ++t)
      for (int k = 0; k < 4; ++k) {
        const Tri key = keyOf(t, k);
        uses[static_cast<std::size_t>(fill[key[0]]++)] = {key, t, k};
      }
  });
  tbb::parallel_for(tbb::blocked_range<int>(0, nV, 4096), [&](const tbb::blocked_range<int>& r) {
    for (int v = r.begin(); v != r.end(); ++v) {
      const auto first = uses.begin() + start[static_cast<std::size_t>(v)];
      const auto last = uses.begin() + start[static_cast<std::size_t>(v) + 1];
      if (last - first > 1)
        std::sort(first, last, [](const FaceUse& x, const FaceUse& y) {
          if (x.key[1] != y.key[1]) return x.key[1] < y.key[1];
          if (x.key[2] != y.key[2]) return x.key[2] < y.key[2];
          if (x.tet != y.tet) return x.tet < y.tet;
          return x.local < y.local;
        });
    }
  });
  TetFaces out;
  UnionFind tets(wantComponents ? nT : 0);
  for (std::size_t i = 0; i < uses.size();) {
    std::size_t j = i + 1;
    for (; j < uses.size() && uses[j].key[0] == uses[i].key[0] && uses[j].key[1] == uses[i].key[1] &&
           uses[j].key[2] == uses[i].key[2];
         ++j)
      if (wantComponents) tets.unite(uses[j - 1].tet, uses[j].tet);
    if (j - i == 1) {
      const auto& u = uses[i];
      out.boundary.push_back(
          {T(u.tet, kFace[u.local][0]), T(u.tet, kFace[u.local][1]), T(u.tet, kFace[u.local][2])});
    } else if (j - i > 2) {
      if (out.nonManifoldFaces++ == 0) out.firstNonManifoldUses = static_cast<int>(j - i);
    }
    i = j;
  }
  if (wantComponents)
    for (int t = 0; t < nT; ++t)
      if (tets.find(t) == t) ++out.components;
  return out;
}

Eigen::MatrixX3i boundaryMatrix(const TetFaces& faces) {
  Eigen::MatrixX3i B(static_cast<Eigen::Index>(faces.boundary.size()), 3);
  for (std::size_t f = 0; f < faces.boundary.size(); ++f)
    B.row(static_cast<Eigen::Index>(f)) << faces.boundary[f][0], faces.boundary[f][1], faces.boundary[f][2];
  return B;
}

}  // namespace detail

namespace {

void checkTetIndices(const TetMesh& mesh, const char* function) {
  const auto nV = mesh.V.rows();
  for (Eigen::Index t = 0; t < mesh.T.rows(); ++t)
    for (int k = 0; k < 4; ++k)
      if (mesh.T(t, k) < 0 || mesh.T(t, k) >= nV)
        throw Error(ErrorKind::Input, std::string(function) + ": tet " + std::to_string(t) +
                                          " references vertex " + std::to_string(mesh.T(t, k)) +
                                          " of " + std::to_string(nV));
}

/// Exact orientation of tet t (V is column-major: gather each row first).
int tetOrientation(const TetMesh& mesh, Eigen::Index t) {
  const Eigen::RowVector3d a = mesh.V.row(mesh.T(t, 0)), b = mesh.V.row(mesh.T(t, 1)),
                           c = mesh.V.row(mesh.T(t, 2)), d = mesh.V.row(mesh.T(t, 3));
  return orient3d(a.data(), b.data(), c.data(), d.data());
}

struct ProblemList {
  std::vector<std::string>& text;
  std::vector<ErrorKind>& kinds;
  void add(ErrorKind kind, std::string sentence) {
    text.push_back(std::move(sentence));
    kinds.push_back(kind);
  }
};

}  // namespace

// --------------------------------------------------------------------------
// Tetrahedral solids

Eigen::MatrixX3i boundaryFaces(const TetMesh& mesh) {
  checkTetIndices(mesh, "boundaryFaces");
  return detail::boundaryMatrix(detail::tetFaces(mesh.T, false));
}

SolidReport analyzeSolid(const TetMesh& mesh) {
  checkTetIndices(mesh, "analyzeSolid");
  const int nT = static_cast<int>(mesh.T.rows());
  if (mesh.region.size() != 0 && mesh.region.size() != nT)
    throw Error(ErrorKind::Input, "analyzeSolid: " + std::to_string(mesh.region.size()) +
                                      " region tags for " + std::to_string(nT) + " tets");
  SolidReport r;
  ProblemList problems{r.problems, r.problemKinds};
  r.vertices = static_cast<int>(mesh.V.rows());
  r.tets = nT;
  if (nT == 0) {
    problems.add(ErrorKind::Input, "the mesh has no tets");
    return r;
  }

  std::vector<char> used(mesh.V.rows(), 0);
  for (int t = 0; t < nT; ++t)
    for (int k = 0; k < 4; ++k) used[mesh.T(t, k)] = 1;
  r.unusedVertices = static_cast<int>(std::count(used.begin(), used.end(), 0));
  r.duplicateVertices = countDuplicatePositions(mesh.V, used);

  // Inverted and degenerate counts packed in one reduction (low/high 32 bits).
  const std::uint64_t counts = tbb::parallel_reduce(
      tbb::blocked_range<int>(0, nT, 4096), std::uint64_t(0),
      [&](const tbb::blocked_range<int>& range, std::uint64_t c) {
        for (int t = range.begin(); t != range.end(); ++t) {
          const int o = tetOrientation(mesh, t);
          if (o < 0) c += 1;
          if (o == 0) c += std::uint64_t(1) << 32;
        }
        return c;
      },
      [](std::uint64_t a, std::uint64_t b) { return a + b; });
  r.invertedTets = static_cast<int>(counts & 0xffffffffu);
  r.degenerateTets = static_cast<int>(counts >> 32);

  const detail::TetFaces faces = detail::tetFaces(mesh.T, true);
  r.components = faces.components;
  r.nonManifoldFaces = faces.nonManifoldFaces;
  TriangleTopology topo = analyzeTriangles(mesh.V, faces.boundary);
  r.nonManifoldBoundaryEdges = topo.nonManifoldEdges;
  r.nonManifoldBoundaryVertices = topo.nonManifoldVertices;

  // Outer shell first: the largest enclosed |volume|; the rest keep their order.
  std::vector<int> order(topo.shells.size());
  std::iota(order.begin(), order.end(), 0);
  if (!order.empty()) {
    auto outer = std::max_element(order.begin(), order.end(), [&](int a, int b) {
      return std::abs(topo.shells[a].enclosedVolume) < std::abs(topo.shells[b].enclosedVolume);
    });
    std::rotate(order.begin(), outer, outer + 1);
  }
  for (int s : order) r.shells.push_back(topo.shells[s]);
  r.genus = r.shells.empty() ? 0 : r.shells[0].genus;

  if (mesh.region.size() == 0) {
    r.regions = {1};
  } else {
    r.regions.assign(mesh.region.data(), mesh.region.data() + nT);
    std::sort(r.regions.begin(), r.regions.end());
    r.regions.erase(std::unique(r.regions.begin(), r.regions.end()), r.regions.end());
  }
  r.voids = std::max(0, static_cast<int>(r.shells.size()) - 1) + static_cast<int>(mesh.voidRegions.size());

  // Problems: topology first (what the user must change in the model), then geometry.
  if (r.components > 1)
    problems.add(ErrorKind::Topology, "the tets form " + std::to_string(r.components) +
                                          " connected components; expected one solid");
  if (r.nonManifoldFaces > 0)
    problems.add(ErrorKind::Topology,
                 plural(r.nonManifoldFaces, "triangle is", "triangles are") + " shared by more than two tets");
  if (r.nonManifoldBoundaryEdges > 0)
    problems.add(ErrorKind::Topology, plural(r.nonManifoldBoundaryEdges, "boundary edge is", "boundary edges are") +
                                          " non-manifold (more than two boundary faces)");
  if (r.nonManifoldBoundaryVertices > 0)
    problems.add(ErrorKind::Topology,
                 plural(r.nonManifoldBoundaryVertices, "boundary vertex is", "boundary vertices are") +
                     " non-manifold (their boundary faces do not form one fan)");
  for (std::size_t s = 0; s < r.shells.size(); ++s) {
    const auto& sh = r.shells[s];
    if (!sh.closed || sh.genus == 0) continue;
    if (s == 0)
      problems.add(ErrorKind::Topology, "outer boundary has genus " + std::to_string(sh.genus) +
                                            "; only genus-0 solids can be mapped to a ball");
    else
      problems.add(ErrorKind::Topology, "inner boundary shell " + std::to_string(s) + " (a void) has genus " +
                                            std::to_string(sh.genus) + "; voids must be genus 0");
  }
  if (r.invertedTets > 0)
    problems.add(ErrorKind::Input, std::to_string(r.invertedTets) + " of " + std::to_string(nT) +
                                       " tets are inverted");
  if (r.degenerateTets > 0)
    problems.add(ErrorKind::Input, std::to_string(r.degenerateTets) + " of " + std::to_string(nT) +
                                       " tets are degenerate (zero volume)");
  if (r.duplicateVertices > 0)
    problems.add(ErrorKind::Input, plural(r.duplicateVertices, "vertex lies", "vertices lie") +
                                       " exactly on another vertex (unmerged vertices)");
  return r;
}

bool reorientIfAllInverted(TetMesh& mesh) {
  checkTetIndices(mesh, "reorientIfAllInverted");
  if (mesh.T.rows() == 0) return false;
  for (Eigen::Index t = 0; t < mesh.T.rows(); ++t) {
    if (tetOrientation(mesh, t) >= 0) return false;
  }
  mesh.T.col(2).swap(mesh.T.col(3));
  return true;
}

int removeUnusedVertices(TetMesh& mesh) {
  checkTetIndices(mesh, "removeUnusedVertices");
  const auto nV = mesh.V.rows();
  std::vector<int> newIndex(nV, -1);
  for (Eigen::Index t = 0; t < mesh.T.rows(); ++t)
    for (int k = 0; k < 4; ++k) newIndex[mesh.T(t, k)] = 0;
  int n = 0;
  for (auto& i : newIndex)
    if (i == 0) i = n++;
  if (n == nV) return 0;
  auto compact = [&](Eigen::MatrixXd& M) {
    if (M.rows() != nV) return;
    Eigen::MatrixXd out(n, M.cols());
    for (Eigen::Index i = 0; i < nV; ++i)
      if (newIndex[i] >= 0) out.row(newIndex[i]) = M.row(i);
    M = std::move(out);
  };
  Eigen::MatrixXd V = mesh.V;
  compact(V);
  mesh.V = V;
  for (auto& f : mesh.pointFields) compact(f.values);
  for (Eigen::Index t = 0; t < mesh.T.rows(); ++t)
    for (int k = 0; k < 4; ++k) mesh.T(t, k) = newIndex[mesh.T(t, k)];
  return static_cast<int>(nV - n);
}

void requireValidSolid(const SolidReport& report, const std::string& file) {
  if (report.valid()) return;
  const ErrorKind kind = report.problemKinds.empty() ? ErrorKind::Topology : report.problemKinds.front();
  throw Error(kind, file + ": " + report.problems.front());
}

// --------------------------------------------------------------------------
// Triangle surfaces

SurfaceReport analyzeSurface(const SurfaceMesh& surface, bool checkSelfIntersections) {
  SurfaceReport r;
  ProblemList problems{r.problems, r.problemKinds};
  const auto nV = surface.V.rows();
  r.vertices = static_cast<int>(nV);
  r.faces = static_cast<int>(surface.F.rows());
  if (r.faces == 0) {
    problems.add(ErrorKind::Input, "the surface has no triangles");
    return r;
  }
  std::vector<Tri> F(r.faces);
  std::vector<char> used(nV, 0);
  for (int f = 0; f < r.faces; ++f)
    for (int k = 0; k < 3; ++k) {
      const int v = surface.F(f, k);
      if (v < 0 || v >= nV)
        throw Error(ErrorKind::Input, "analyzeSurface: triangle " + std::to_string(f) + " references vertex " +
                                          std::to_string(v) + " of " + std::to_string(nV));
      F[f][k] = v;
      used[v] = 1;
    }
  r.unusedVertices = static_cast<int>(std::count(used.begin(), used.end(), 0));
  r.duplicateVertices = countDuplicatePositions(surface.V, used);
  for (const Tri& t : F) {
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) {
      ++r.degenerateFaces;
      continue;
    }
    const Eigen::RowVector3d a = surface.V.row(t[0]), b = surface.V.row(t[1]), c = surface.V.row(t[2]);
    if (collinear(a.data(), b.data(), c.data())) ++r.degenerateFaces;
  }

  TriangleTopology topo = analyzeTriangles(surface.V, F);
  r.boundaryEdges = topo.boundaryEdges;
  r.boundaryLoops = topo.boundaryLoops;
  r.nonManifoldEdges = topo.nonManifoldEdges;
  r.nonManifoldVertices = topo.nonManifoldVertices;
  r.inconsistentEdges = topo.inconsistentEdges;
  r.shells = std::move(topo.shells);
  r.shellFaces = std::move(topo.shellFaces);

  // CGAL needs a manifold, consistently oriented triangle mesh; anything else
  // is refused below before self-intersections would matter.
  const bool meshable = r.nonManifoldEdges == 0 && r.nonManifoldVertices == 0 && r.inconsistentEdges == 0 &&
                        r.degenerateFaces == 0;
  if (checkSelfIntersections && meshable) {
    r.selfIntersections = countSelfIntersections(surface, kMaxSelfIntersections);
    r.selfIntersectionsChecked = r.selfIntersections >= 0;
    if (r.selfIntersections < 0) r.selfIntersections = 0;
  }

  // Problems in the order a user should fix them: holes and non-manifold
  // parts (topology), then geometry (degenerate, orientation,
  // self-intersection, coincident vertices), then the genus, which only means
  // something for a clean closed surface.
  const std::string unmerged =
      r.duplicateVertices > 0
          ? " (" + plural(r.duplicateVertices, "vertex lies", "vertices lie") + " exactly on another: unmerged?)"
          : std::string();
  if (r.boundaryEdges > 0)
    problems.add(ErrorKind::Topology, "the surface is open: " + plural(r.boundaryLoops, "hole", "holes") +
                                          " bounded by " + plural(r.boundaryEdges, "edge", "edges") +
                                          " with one triangle; a solid needs a closed surface" + unmerged);
  if (r.nonManifoldEdges > 0)
    problems.add(ErrorKind::Topology, plural(r.nonManifoldEdges, "edge is", "edges are") +
                                          " non-manifold (more than two triangles)");
  if (r.nonManifoldVertices > 0)
    problems.add(ErrorKind::Topology, plural(r.nonManifoldVertices, "vertex is", "vertices are") +
                                          " non-manifold (its triangles do not form one fan)");
  if (r.degenerateFaces > 0)
    problems.add(ErrorKind::Input, std::to_string(r.degenerateFaces) + " of " + std::to_string(r.faces) +
                                       " triangles are degenerate (repeated vertex or zero area)");
  if (r.inconsistentEdges > 0)
    problems.add(ErrorKind::Input, "the triangles are not consistently oriented (" +
                                       plural(r.inconsistentEdges, "edge is", "edges are") +
                                       " used twice in the same direction)");
  if (r.selfIntersections > 0)
    problems.add(ErrorKind::Input, "the surface intersects itself (" +
                                       std::string(r.selfIntersections >= kMaxSelfIntersections ? "at least " : "") +
                                       plural(r.selfIntersections, "pair", "pairs") + " of triangles intersect)");
  if (r.duplicateVertices > 0 && r.boundaryEdges == 0)
    problems.add(ErrorKind::Input, plural(r.duplicateVertices, "vertex lies", "vertices lie") +
                                       " exactly on another vertex (the surface touches itself there)");
  // Nesting needs closed shells that do not cross each other.
  if (r.problems.empty() && (r.selfIntersectionsChecked || !checkSelfIntersections)) {
    const ShellGeometry geometry(surface, r);
    int a = -1, b = -1;
    if (!geometry.nesting(r.shellParent, r.shellDepth, a, b)) {
      r.shellParent.clear(), r.shellDepth.clear();
      problems.add(ErrorKind::Input, "boundary shells " + std::to_string(a + 1) + " and " + std::to_string(b + 1) +
                                         " nearly touch (inside or outside cannot be told)");
    } else {
      const long roots = std::count(r.shellDepth.begin(), r.shellDepth.end(), 0);
      if (roots > 1)
        problems.add(ErrorKind::Topology, "the surface bounds " + std::to_string(roots) +
                                              " separate solids side by side; expected one solid");
    }
  }
  // The outer shell is the one enclosing the largest |volume|.
  int outer = 0;
  for (std::size_t s = 1; s < r.shells.size(); ++s)
    if (std::abs(r.shells[s].enclosedVolume) > std::abs(r.shells[outer].enclosedVolume)) outer = int(s);
  for (std::size_t s = 0; s < r.shells.size(); ++s) {
    const auto& sh = r.shells[s];
    if (!sh.closed || sh.genus == 0) continue;
    if (int(s) == outer)
      problems.add(ErrorKind::Topology, "outer boundary has genus " + std::to_string(sh.genus) +
                                            "; only genus-0 solids can be mapped to a ball");
    else
      problems.add(ErrorKind::Topology, "boundary shell " + std::to_string(s + 1) + " of " +
                                            std::to_string(r.shells.size()) + " has genus " +
                                            std::to_string(sh.genus) + "; every shell must be genus 0");
  }
  return r;
}

namespace {

struct SharedEdge {
  double degrees;  // between the normals of its two triangles
  int f0, f1;      // those triangles
};

struct SurfaceEdges {
  std::vector<Eigen::Vector3d> areaNormal;  // per triangle: (b − a) × (c − a), twice its area along its normal
  std::vector<SharedEdge> shared;           // every edge that exactly two triangles share
};

SurfaceEdges sharedEdges(const Eigen::MatrixX3d& X, const Eigen::MatrixX3i& F, const char* function) {
  if (F.size() > 0 && (F.minCoeff() < 0 || F.maxCoeff() >= X.rows()))
    throw Error(ErrorKind::Input, std::string(function) + ": a triangle index outside the " + std::to_string(X.rows()) + " points");
  SurfaceEdges out;
  out.areaNormal.resize(static_cast<size_t>(F.rows()));
  struct EdgeUse {
    std::uint64_t key;
    int face;
  };
  std::vector<EdgeUse> uses;
  uses.reserve(static_cast<size_t>(F.rows()) * 3);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = X.row(F(f, 0)), b = X.row(F(f, 1)), c = X.row(F(f, 2));
    out.areaNormal[static_cast<size_t>(f)] = (b - a).cross(c - a);
    for (int k = 0; k < 3; ++k) uses.push_back({edgeKey(F(f, k), F(f, (k + 1) % 3)), static_cast<int>(f)});
  }
  tbb::parallel_sort(uses.begin(), uses.end(), [](const EdgeUse& x, const EdgeUse& y) {
    return x.key != y.key ? x.key < y.key : x.face < y.face;
  });
  for (size_t i = 0; i < uses.size();) {
    size_t j = i;
    while (j < uses.size() && uses[j].key == uses[i].key) ++j;
    if (j - i == 2) {
      const int f0 = uses[i].face, f1 = uses[i + 1].face;
      const double c = out.areaNormal[static_cast<size_t>(f0)].normalized().dot(out.areaNormal[static_cast<size_t>(f1)].normalized());
      // (a degenerate triangle's NaN normal counts as a crease)
      out.shared.push_back({std::isfinite(c) ? std::acos(std::clamp(c, -1.0, 1.0)) * 180.0 / M_PI : 180.0, f0, f1});
    }
    i = j;
  }
  return out;
}

}  // namespace

double normalAngleQuantile(const Eigen::MatrixX3d& X, const Eigen::MatrixX3i& F, double p, double ignoreBelow) {
  if (!(p >= 0 && p <= 1)) throw Error(ErrorKind::Usage, "normalAngleQuantile: quantile " + std::to_string(p) + " outside [0, 1]");
  if (!(ignoreBelow >= 0)) throw Error(ErrorKind::Usage, "normalAngleQuantile: angle " + std::to_string(ignoreBelow) + " below 0");
  std::vector<double> angles;
  for (const SharedEdge& e : sharedEdges(X, F, "normalAngleQuantile").shared)
    if (e.degrees >= ignoreBelow) angles.push_back(e.degrees);
  if (angles.empty()) return 0;
  const size_t k = static_cast<size_t>(std::llround(p * static_cast<double>(angles.size() - 1)));
  std::nth_element(angles.begin(), angles.begin() + static_cast<std::ptrdiff_t>(k), angles.end());
  return angles[k];
}

double planarShare(const Eigen::MatrixX3d& X, const Eigen::MatrixX3i& F, double degrees, double minPatch) {
  if (!(degrees >= 0)) throw Error(ErrorKind::Usage, "planarShare: angle " + std::to_string(degrees) + " below 0");
  if (!(minPatch >= 0 && minPatch <= 1))
    throw Error(ErrorKind::Usage, "planarShare: patch share " + std::to_string(minPatch) + " outside [0, 1]");
  const SurfaceEdges edges = sharedEdges(X, F, "planarShare");
  const Eigen::Index nf = F.rows();
  std::vector<std::vector<int>> next(static_cast<size_t>(nf));
  for (const SharedEdge& e : edges.shared) {
    next[static_cast<size_t>(e.f0)].push_back(e.f1);
    next[static_cast<size_t>(e.f1)].push_back(e.f0);
  }
  std::vector<Eigen::Vector3d> normal(static_cast<size_t>(nf));
  std::vector<double> area(static_cast<size_t>(nf));
  double total = 0;
  for (size_t f = 0; f < static_cast<size_t>(nf); ++f) {
    area[f] = 0.5 * edges.areaNormal[f].norm();
    normal[f] = edges.areaNormal[f].normalized();
    total += area[f];
  }
  if (!(total > 0)) return 0;
  // Patches grown from each unvisited triangle over shared edges to the
  // triangles whose normal is within `degrees` of the seed's (not of the
  // neighbour's: a finely meshed curved surface does not chain into one).
  const double cosine = std::cos(degrees * M_PI / 180.0);
  std::vector<char> seen(static_cast<size_t>(nf), 0);
  std::vector<int> stack;
  double planar = 0;
  for (Eigen::Index seed = 0; seed < nf; ++seed) {
    if (seen[static_cast<size_t>(seed)]) continue;
    const Eigen::Vector3d n0 = normal[static_cast<size_t>(seed)];
    double patch = 0;
    seen[static_cast<size_t>(seed)] = 1;
    stack.assign(1, static_cast<int>(seed));
    while (!stack.empty()) {
      const int f = stack.back();
      stack.pop_back();
      patch += area[static_cast<size_t>(f)];
      for (int g : next[static_cast<size_t>(f)])
        if (!seen[static_cast<size_t>(g)] && normal[static_cast<size_t>(g)].dot(n0) >= cosine) {
          seen[static_cast<size_t>(g)] = 1;
          stack.push_back(g);
        }
    }
    if (patch >= minPatch * total) planar += patch;
  }
  return planar / total;
}

void requireValidSurface(const SurfaceReport& report, const std::string& file) {
  if (report.valid()) return;
  const ErrorKind kind = report.problemKinds.empty() ? ErrorKind::Topology : report.problemKinds.front();
  throw Error(kind, file + ": " + report.problems.front());
}

}  // namespace tet2spline

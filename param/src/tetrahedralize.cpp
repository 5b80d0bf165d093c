// Tetrahedral meshing of closed surfaces with TetGen 1.5 used as a library.
// This is the only file that includes tetgen.h (TetGen is AGPL: the licence
// boundary stays visible). TetGen is built with TETLIBRARY, so it throws an
// int instead of exiting; we turn that into tet2spline::Error.
#include "tet2spline/param/tetrahedralize.h"

#include <Eigen/Geometry>
#include <tetgen.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <new>
#include <numeric>
#include <string>
#include <vector>

#include "tet2spline/param/error.h"
#include "shell_geometry.h"
#include "tet2spline/param/topology.h"

namespace tet2spline {

namespace {

/// A point strictly inside shell s and outside each of `children`: a small
/// step inward from the centroid of one of s's larger triangles, verified by
/// winding numbers (a step that leaves the region is retried shorter or from
/// another triangle).
bool findSeed(const ShellGeometry& shells, int s, const std::vector<int>& children, Eigen::Vector3d& seed) {
  std::vector<std::pair<double, int>> byArea;
  for (int f : shells.faces(s)) {
    const Eigen::Vector3i t = shells.face(f);
    const Eigen::Vector3d n = (shells.vertex(t[1]) - shells.vertex(t[0])).cross(shells.vertex(t[2]) - shells.vertex(t[0]));
    byArea.emplace_back(-n.norm(), f);
  }
  const std::size_t tries = std::min<std::size_t>(byArea.size(), 32);
  std::partial_sort(byArea.begin(), byArea.begin() + tries, byArea.end());
  for (std::size_t i = 0; i < tries; ++i) {
    const Eigen::Vector3i t = shells.face(byArea[i].second);
    const Eigen::Vector3d a = shells.vertex(t[0]), b = shells.vertex(t[1]), c = shells.vertex(t[2]);
    const Eigen::Vector3d n = (b - a).cross(c - a);
    const double area2 = n.norm();
    if (!(area2 > 0)) continue;
    const Eigen::Vector3d inward = -shells.sign(s) * n / area2;
    const Eigen::Vector3d centroid = (a + b + c) / 3;
    // Inradius-like scale: 2·area / perimeter.
    const double scale = area2 / ((b - a).norm() + (c - b).norm() + (a - c).norm());
    for (double factor : {0.5, 0.1, 0.02}) {
      const Eigen::Vector3d p = centroid + factor * scale * inward;
      if (shells.inside(s, p) != 1) continue;
      bool ok = true;
      for (int child : children)
        if (shells.inside(child, p) != 0) ok = false;
      if (ok) {
        seed = p;
        return true;
      }
    }
  }
  return false;
}

std::string tetgenFailure(int code) {
  switch (code) {
    case 1: return "TetGen ran out of memory";
    case 2: return "TetGen failed with an internal error";
    case 3: return "the surface intersects itself (found by TetGen)";
    case 4: return "the surface has a feature too small for TetGen's tolerance";
    case 5: return "the surface has two facets too close to each other for TetGen";
    case 10: return "TetGen refused the input";
    default: return "TetGen failed with code " + std::to_string(code);
  }
}

}  // namespace

int flipCaps(SurfaceMesh& surface, double capAngleDegrees) {
  if (!(capAngleDegrees > 0 && capAngleDegrees < 180)) return 0;
  const double cosLimit = std::cos(capAngleDegrees * M_PI / 180);  // angle > limit <=> cos < cosLimit
  const Eigen::MatrixX3d& V = surface.V;
  Eigen::MatrixX3i& F = surface.F;
  std::map<std::pair<int, int>, int> edgeFace;  // directed edge -> its triangle
  auto setEdges = [&](Eigen::Index f, bool insert) {
    for (int k = 0; k < 3; ++k) {
      const std::pair<int, int> e{F(f, k), F(f, (k + 1) % 3)};
      if (insert) edgeFace[e] = static_cast<int>(f);
      else edgeFace.erase(e);
    }
  };
  for (Eigen::Index f = 0; f < F.rows(); ++f) setEdges(f, true);
  int flips = 0;
  // Each flip removes a cap; the bound only guards against flipping back and forth.
  for (Eigen::Index f = 0; f < F.rows() && flips <= F.rows(); ++f) {
    for (int k = 0; k < 3 && flips <= F.rows(); ++k) {
      const int a = F(f, k), b = F(f, (k + 1) % 3), c = F(f, (k + 2) % 3);
      const Eigen::Vector3d u = V.row(b) - V.row(a), w = V.row(c) - V.row(a);
      const double lu = u.norm(), lw = w.norm();
      if (!(lu > 0 && lw > 0) || !(u.dot(w) < cosLimit * lu * lw)) continue;
      const auto across = edgeFace.find({c, b});
      if (across == edgeFace.end()) continue;
      const Eigen::Index g = across->second;
      int d = -1;
      for (int j = 0; j < 3; ++j)
        if (F(g, j) != b && F(g, j) != c) d = F(g, j);
      if (d < 0 || d == a || edgeFace.count({a, d}) || edgeFace.count({d, a})) continue;
      const Eigen::Vector3d pa = V.row(a), pb = V.row(b), pc = V.row(c), pd = V.row(d);
      const Eigen::Vector3d old = (pb - pc).cross(pd - pc);  // the neighbour (c, b, d)
      if (!((pb - pa).cross(pd - pa).dot(old) > 0 && (pd - pa).cross(pc - pa).dot(old) > 0)) continue;
      setEdges(f, false), setEdges(g, false);
      F.row(f) << a, b, d;
      F.row(g) << a, d, c;
      setEdges(f, true), setEdges(g, true);
      ++flips;
      k = -1;  // look at the new triangle f again
    }
  }
  return flips;
}

TetMesh tetrahedralize(const SurfaceMesh& input, const TetrahedralizeOptions& options,
                       const std::string& sourceName, TetrahedralizeStats* stats) {
  // TetGen's refinement need not terminate for radius-edge bounds below 1.
  if (options.radiusEdgeRatio != 0 && !(options.radiusEdgeRatio >= 1))
    throw Error(ErrorKind::Usage, "tetrahedralize: radius-edge ratio " + std::to_string(options.radiusEdgeRatio) +
                                      " must be 0 (no refinement) or at least 1");
  if (!(options.minDihedral >= 0 && options.minDihedral <= 18))
    throw Error(ErrorKind::Usage, "tetrahedralize: minimum dihedral angle " + std::to_string(options.minDihedral) +
                                      " must be in [0, 18] degrees (TetGen's refinement need not end above)");
  if (options.minDihedral > 0 && options.radiusEdgeRatio == 0)
    throw Error(ErrorKind::Usage, "tetrahedralize: a minimum dihedral angle needs the quality refinement "
                                  "(radius-edge ratio > 0)");
  if (!(options.maxVolume >= 0) || !(options.relativeSize >= 0))
    throw Error(ErrorKind::Usage, "tetrahedralize: negative or NaN size");
  SurfaceReport report = analyzeSurface(input, true);
  requireValidSurface(report, sourceName);
  if (stats) *stats = TetrahedralizeStats{};
  SurfaceMesh repaired;
  const SurfaceMesh* chosen = &input;
  if (options.capAngle > 0 && !options.exactBoundary) {
    repaired = input;
    const int flips = flipCaps(repaired, options.capAngle);
    if (flips > 0) {
      SurfaceReport check = analyzeSurface(repaired, true);
      if (check.valid()) {  // otherwise mesh the input as it is
        report = std::move(check);
        chosen = &repaired;
        if (stats) stats->capsFlipped = flips;
      }
    }
  }
  const SurfaceMesh& surface = *chosen;
  const ShellGeometry shells(surface, report);
  const int nS = shells.size();
  const std::vector<int>& parent = report.shellParent;
  const std::vector<int>& depth = report.shellDepth;
  if (static_cast<int>(parent.size()) != nS || static_cast<int>(depth.size()) != nS)
    throw Error(ErrorKind::Numerical, sourceName + ": the nesting of the boundary shells is unknown");
  for (int i = 0; i < nS; ++i)
    if (options.voids && depth[i] >= 2)
      throw Error(ErrorKind::Topology, sourceName + ": boundary shell " + std::to_string(i + 1) +
                                           " lies inside the void of shell " + std::to_string(parent[i] + 1) +
                                           ", so the solid would have two components");

  // One region per shell: inside it and outside its children. The outer one is
  // tag 1; the others 2, 3, ... in shell order.
  std::vector<int> tag(nS);
  {
    int next = 2;
    for (int s = 0; s < nS; ++s) tag[s] = depth[s] == 0 ? 1 : next++;
  }
  std::vector<std::vector<int>> children(nS);
  for (int s = 0; s < nS; ++s)
    if (parent[s] >= 0) children[parent[s]].push_back(s);

  // TetGen input: the used vertices (in their order) and one facet per triangle.
  std::vector<int> newIndex(surface.V.rows(), -1);
  for (Eigen::Index f = 0; f < surface.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) newIndex[surface.F(f, k)] = 0;
  std::vector<int> oldIndex;
  for (Eigen::Index v = 0; v < surface.V.rows(); ++v)
    if (newIndex[v] == 0) {
      newIndex[v] = static_cast<int>(oldIndex.size());
      oldIndex.push_back(static_cast<int>(v));
    }
  tetgenio in, out;
  in.firstnumber = 0;
  in.numberofpoints = static_cast<int>(oldIndex.size());
  in.pointlist = new REAL[3 * oldIndex.size()];
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (std::size_t i = 0; i < oldIndex.size(); ++i) {
    const Eigen::Vector3d p = surface.V.row(oldIndex[i]).transpose();
    for (int k = 0; k < 3; ++k) in.pointlist[3 * i + k] = p[k];
    lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  }
  in.numberoffacets = static_cast<int>(surface.F.rows());
  in.facetlist = new tetgenio::facet[in.numberoffacets];
  for (int f = 0; f < in.numberoffacets; ++f) {
    tetgenio::facet& facet = in.facetlist[f];
    tetgenio::init(&facet);
    facet.numberofpolygons = 1;
    facet.polygonlist = new tetgenio::polygon[1];
    tetgenio::init(&facet.polygonlist[0]);
    facet.polygonlist[0].numberofvertices = 3;
    facet.polygonlist[0].vertexlist = new int[3];
    for (int k = 0; k < 3; ++k) facet.polygonlist[0].vertexlist[k] = newIndex[surface.F(f, k)];
  }
  in.numberofregions = nS;
  in.regionlist = new REAL[5 * nS];
  for (int s = 0; s < nS; ++s) {
    Eigen::Vector3d seed;
    if (!findSeed(shells, s, children[s], seed))
      throw Error(ErrorKind::Numerical, sourceName + ": found no point strictly inside boundary shell " +
                                            std::to_string(s + 1) + " to seed its region");
    for (int k = 0; k < 3; ++k) in.regionlist[5 * s + k] = seed[k];
    in.regionlist[5 * s + 3] = tag[s];
    in.regionlist[5 * s + 4] = 0;
  }

  // Switches: p (surface), A (region attributes), Q (quiet: the library must
  // print nothing), q and a set exactly after parsing.
  double maxVolume = options.maxVolume;
  if (options.relativeSize > 0) {
    const double edge = options.relativeSize * (hi - lo).norm();
    maxVolume = edge * edge * edge / (6 * std::sqrt(2.0));  // regular tet of that edge
  }
  std::string switches = "pAQ";
  if (options.radiusEdgeRatio > 0) switches += "q2";
  if (maxVolume > 0) switches += "a1";
  tetgenbehavior behavior;
  if (!behavior.parse_commandline(&switches[0]))
    throw Error(ErrorKind::Numerical, "tetrahedralize: TetGen rejected switches " + switches);
  if (options.radiusEdgeRatio > 0) behavior.minratio = options.radiusEdgeRatio;
  if (maxVolume > 0) behavior.maxvolume = maxVolume;
  if (options.minDihedral > 0) behavior.mindihedral = options.minDihedral;
  // TetGen merges adjacent facets within 0.1° of coplanar (-p/179.9) and then
  // places boundary Steiner points on the merged facet, up to ~1e-5 × size
  // off the input surface; 180° keeps every input triangle its own facet.
  if (options.exactBoundary) behavior.facet_ang_tol = 180;
  try {
    ::tetrahedralize(&behavior, &in, &out);
  } catch (int code) {
    throw Error(code == 1 || code == 2 ? ErrorKind::Numerical : ErrorKind::Input,
                sourceName + ": " + tetgenFailure(code));
  } catch (const std::bad_alloc&) {
    throw Error(ErrorKind::Numerical, sourceName + ": " + tetgenFailure(1));
  }
  if (out.numberoftetrahedra <= 0 || out.numberofcorners != 4 || out.numberoftetrahedronattributes < 1)
    throw Error(ErrorKind::Numerical, sourceName + ": TetGen produced no tetrahedra");

  TetMesh mesh;
  mesh.V.resize(out.numberofpoints, 3);
  for (int i = 0; i < out.numberofpoints; ++i)
    for (int k = 0; k < 3; ++k) mesh.V(i, k) = out.pointlist[3 * i + k];
  mesh.T.resize(out.numberoftetrahedra, 4);
  mesh.region.resize(out.numberoftetrahedra);
  const int nA = out.numberoftetrahedronattributes;
  int degenerate = 0, unseeded = 0;
  for (int t = 0; t < out.numberoftetrahedra; ++t) {
    for (int k = 0; k < 4; ++k) mesh.T(t, k) = out.tetrahedronlist[4 * t + k];
    const int r = static_cast<int>(std::lround(out.tetrahedronattributelist[nA * t]));
    if (std::find(tag.begin(), tag.end(), r) == tag.end()) ++unseeded;
    mesh.region[t] = r;
    // Positive orientation (tet_mesh.h), decided exactly tet by tet.
    Eigen::RowVector3d p[4];
    for (int k = 0; k < 4; ++k) p[k] = mesh.V.row(mesh.T(t, k));
    const int o = orient3d(p[0].data(), p[1].data(), p[2].data(), p[3].data());
    if (o < 0) std::swap(mesh.T(t, 2), mesh.T(t, 3));
    if (o == 0) ++degenerate;
  }
  if (degenerate > 0)
    throw Error(ErrorKind::Numerical, sourceName + ": TetGen produced " + std::to_string(degenerate) +
                                          " degenerate tets");
  if (unseeded > 0)
    throw Error(ErrorKind::Numerical, sourceName + ": " + std::to_string(unseeded) +
                                          " tets got no region from TetGen's region seeds");
  if (options.voids)
    for (int s = 0; s < nS; ++s)
      if (depth[s] == 1) mesh.voidRegions.insert(tag[s]);
  removeUnusedVertices(mesh);
  return mesh;
}

}  // namespace tet2spline

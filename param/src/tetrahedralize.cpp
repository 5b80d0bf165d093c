// Tetrahedral meshing of closed surfaces with TetGen 1.5 used as a library.
// This is the only file that includes tetgen.h (TetGen is AGPL: the licence
// boundary stays visible). TetGen is built with TETLIBRARY, so it throws an
// int instead of exiting; we turn that into tet2spline::Error.
#include "tet2spline/param/tetrahedralize.h"

#include <Eigen/Geometry>
#include <tetgen.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <ctime>
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

// ---------------------------------------------------------------------------
// TetGen's steps for our switches, with one change that keeps its mesh.
//
// TetGen 1.5.0's Delaunay refinement first queues every boundary segment
// (bunny00: 113k) and every subface in two memory pools and repairs them.
// The pools keep their high-water mark: every later repair pass (one after
// each tet circumcentre that encroaches on the boundary) walks all those
// dead slots to find the few live ones. perf on bunny00 (`tetgen -pAq1.5`,
// 2026-12-06): 31% of TetGen's 14 s in memorypool::traverse, nearly all of
// it under repairencsegs/repairencfacs called from splittetrahedron. With
// the compaction below, `tet2spline mesh bunny00.off` took 11.8 s instead
// of 18.2 (2026-12-07, another host), writing the same file.
//
// A pass visits the live entries in slot order, and a new entry takes the
// slot on top of the pool's stack of dead slots. So once a pool is empty,
// only two things decide every later pass: the order of its dead stack and
// the slot order of the slots on it. compactDeadStack keeps both for the
// top `keep` entries of the stack and drops the rest: the new pool's slots
// are 0 .. keep-1, ranked as the old slots were, stacked in the old order.
// As long as no more than `keep` entries are ever live at once, every pass
// then visits the same entries in the same order, and TetGen makes the same
// mesh bit for bit (tested against tetrahedralize() itself; a pool that
// dropped slots and then grew past the ones it kept is counted in the
// stats, see Compaction).
// ---------------------------------------------------------------------------

// What compactDeadStack did to a pool: the slots it kept, and whether it
// dropped any (only then can a pool that grows past `kept` differ from
// TetGen's: with the whole stack kept, it grows as TetGen's own does, at
// the end of the slot order).
struct Compaction {
  long kept = 0;
  bool truncated = false;
};

// Rebuilds an empty pool of `face` entries (TetGen's badsubsegs and
// badsubfacs) as described above; adds the number of slots dropped to
// `dropped`. A pool that is not empty stays as it is.
Compaction compactDeadStack(tetgenmesh::memorypool& pool, long keep, long& dropped) {
  if (pool.items != 0 || pool.deaditemstack == nullptr) return {};
  // The pool's blocks, numbered in traversal order, sorted by their first
  // item's address (for slotOf's lookup).
  const auto firstItem = [&](void** block) {
    const auto align = static_cast<std::uintptr_t>(pool.alignbytes);
    const auto p = reinterpret_cast<std::uintptr_t>(block + 1);
    return p + align - p % align;
  };
  std::vector<std::pair<std::uintptr_t, long>> blocks;  // (first item's address, block index)
  long index = 0;
  for (void** block = pool.firstblock; block != nullptr; block = static_cast<void**>(*block)) {
    blocks.emplace_back(firstItem(block), index++);
    if (block == pool.nowblock) break;
  }
  std::sort(blocks.begin(), blocks.end());
  const auto bytes = static_cast<std::uintptr_t>(pool.itembytes);
  const auto slotOf = [&](void* item) -> long {
    const auto p = reinterpret_cast<std::uintptr_t>(item);
    auto it = std::upper_bound(blocks.begin(), blocks.end(), std::make_pair(p, std::numeric_limits<long>::max()));
    if (it == blocks.begin()) return -1;
    --it;
    const std::uintptr_t offset = p - it->first;
    if (offset % bytes != 0 || offset / bytes >= static_cast<std::uintptr_t>(pool.itemsperblock)) return -1;
    return it->second * pool.itemsperblock + static_cast<long>(offset / bytes);
  };
  // The stack's top `keep` entries (top first), by their slots.
  std::vector<long> stack;
  long depth = 0;
  for (void* item = pool.deaditemstack; item != nullptr; item = *static_cast<void**>(item), ++depth) {
    if (depth >= keep) continue;
    const long slot = slotOf(item);
    if (slot < 0) return {};  // not a layout we know: leave the pool as it is
    stack.push_back(slot);
  }
  dropped += depth - static_cast<long>(stack.size());
  std::vector<long> sorted = stack;
  std::sort(sorted.begin(), sorted.end());
  pool.restart();
  std::vector<void*> fresh(stack.size());
  for (auto& item : fresh) item = pool.alloc();  // slots 0, 1, ... in traversal order
  // Push them back bottom first, so the old top's counterpart is on top again;
  // shver < 0 marks a dead entry for the repair passes.
  for (std::size_t k = stack.size(); k-- > 0;) {
    const auto rank = std::lower_bound(sorted.begin(), sorted.end(), stack[k]) - sorted.begin();
    auto* entry = static_cast<tetgenmesh::face*>(fresh[static_cast<std::size_t>(rank)]);
    entry->shver = -1;
    pool.dealloc(entry);
  }
  return {static_cast<long>(stack.size()), depth > static_cast<long>(stack.size())};
}

// Entries a compacted pool took beyond its kept slots (see Compaction).
long outgrown(const tetgenmesh::memorypool* pool, const Compaction& c) {
  return pool && c.truncated && pool->maxitems > c.kept ? pool->maxitems - c.kept : 0;
}

// Owns TetGen's refinement queues (its own delaunayrefinement leaks them
// when it throws).
struct RefinementQueues {
  tetgenmesh& m;
  ~RefinementQueues() {
    delete m.encseglist;
    delete m.encshlist;
    delete m.badsubsegs;
    delete m.badsubfacs;
    delete m.badtetrahedrons;
    m.encseglist = m.encshlist = nullptr;
    m.badsubsegs = m.badsubfacs = m.badtetrahedrons = nullptr;
  }
};

// Dead-stack entries kept by compactDeadStack: far more than are ever live
// at once in the refinement of our meshes, far fewer than the 113k-340k
// slots the pools grow to.
constexpr long kQueueSlots = 8192;

// TetGen 1.5.0's delaunayrefinement() for a PLC without -Y, -m or -S, its
// queues compacted once they are empty (see above). Returns the entries
// that grew past the compacted pools (0: TetGen's own mesh) and adds the
// slots dropped to `dropped`.
long refine(tetgenmesh& m, long& dropped) {
  tetgenbehavior& b = *m.b;
  m.steinerleft = b.steinerleft;
  if (m.useinsertradius) m.makefacetverticesmap();
  RefinementQueues owned{m};
  m.encseglist = new tetgenmesh::arraypool(sizeof(tetgenmesh::face), 8);
  m.encshlist = new tetgenmesh::arraypool(sizeof(tetgenmesh::badface), 8);
  // Encroached segments, then subfaces (chkencflag 1, 2).
  m.badsubsegs = new tetgenmesh::memorypool(sizeof(tetgenmesh::face), b.shellfaceperblock, sizeof(void*), 0);
  tetgenmesh::face entry;
  m.subsegs->traversalinit();
  for (entry.sh = m.shellfacetraverse(m.subsegs); entry.sh != nullptr; entry.sh = m.shellfacetraverse(m.subsegs))
    m.enqueuesubface(m.badsubsegs, &entry);
  m.repairencsegs(1);
  Compaction segments, subfaces;
  if (b.reflevel > 1) {
    segments = compactDeadStack(*m.badsubsegs, kQueueSlots, dropped);
    m.badsubfacs = new tetgenmesh::memorypool(sizeof(tetgenmesh::face), b.shellfaceperblock, sizeof(void*), 0);
    m.subfaces->traversalinit();
    for (entry.sh = m.shellfacetraverse(m.subfaces); entry.sh != nullptr;
         entry.sh = m.shellfacetraverse(m.subfaces))
      m.enqueuesubface(m.badsubfacs, &entry);
    m.repairencfacs(2);
  }
  long grown = outgrown(m.badsubsegs, segments);
  if (b.reflevel > 2) {
    // Bad tets (chkencflag 4), with both boundary queues compacted (again,
    // for the segments': that keeps what the subface phase left on it).
    segments = compactDeadStack(*m.badsubsegs, kQueueSlots, dropped);
    if (m.badsubfacs) subfaces = compactDeadStack(*m.badsubfacs, kQueueSlots, dropped);
    m.cosmindihed = std::cos(b.mindihedral / 180.0 * 3.14159265358979323846264338327950288419716939937510582);
    m.badtetrahedrons =
        new tetgenmesh::memorypool(sizeof(tetgenmesh::triface), b.tetrahedraperblock, sizeof(void*), 0);
    tetgenmesh::triface tet;
    m.tetrahedrons->traversalinit();
    for (tet.tet = m.tetrahedrontraverse(); tet.tet != nullptr; tet.tet = m.tetrahedrontraverse())
      m.enqueuetetrahedron(&tet);
    m.repairbadtets(4);
    grown += outgrown(m.badsubsegs, segments) + outgrown(m.badsubfacs, subfaces);
  }
  return grown;
}

// TetGen 1.5.0's tetrahedralize(b, in, out) for the switches tetrahedralize()
// below sets (-pAQ, -q, -a, a dihedral bound, the facet angle tolerance), its
// refinement by refine() above; only the points and tets are written out.
// Sets the stats' queue counts (see TetrahedralizeStats).
void runTetGen(tetgenbehavior& b, tetgenio& in, tetgenio& out, TetrahedralizeStats& stats) {
  if (!b.plc || b.refine || b.nobisect || b.coarsen || b.metric || b.insertaddpoints || b.diagnose ||
      b.convex || b.order != 1 || b.steinerleft != -1 || b.docheck || !b.quiet) {
    ::tetrahedralize(&b, &in, &out);
    return;
  }
  tetgenmesh m;
  m.b = &b;
  m.in = &in;
  m.addin = nullptr;
  m.initializepools();
  m.transfernodes();
  exactinit(b.verbose, b.noexact, b.nostaticfilter, m.xmax - m.xmin, m.ymax - m.ymin, m.zmax - m.zmin);
  clock_t ticks;
  m.incrementaldelaunay(ticks);
  m.meshsurface();
  m.constraineddelaunay(ticks);
  m.carveholes();
  if (b.quality) stats.queueSlotsGrown = refine(m, stats.queueSlotsDropped);
  if (b.optlevel > 0) m.optimizemesh();
  if (!b.nojettison && (m.dupverts > 0 || m.unuverts > 0)) m.jettisonnodes();
  out.firstnumber = in.firstnumber;
  out.mesh_dim = in.mesh_dim;
  m.outnodes(&out);
  if (m.tetrahedrons->items > 0) m.outelements(&out);
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
    if (options.tetgenDriver) {
      TetrahedralizeStats queues;
      runTetGen(behavior, in, out, queues);
      if (stats) stats->queueSlotsGrown = queues.queueSlotsGrown, stats->queueSlotsDropped = queues.queueSlotsDropped;
    } else {
      ::tetrahedralize(&behavior, &in, &out);
    }
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

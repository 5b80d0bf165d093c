#pragma once
// Regular triangulations of weighted points as flat arrays, and their repair
// by flips after the weights change (internal to param/; no CGAL types here).
//
// A triangulation is a list of tets (site indices, positively oriented) and,
// per tet and slot q, the tet across the face opposite vertex q (−1 on the
// convex hull). This is what power_diagram.cpp copies out of CGAL's
// Regular_triangulation_3.
#include <Eigen/Core>
#include <array>
#include <vector>

namespace tet2spline {

struct TetArrays {
  std::vector<std::array<int, 4>> vertex;     ///< #T, positively oriented
  std::vector<std::array<int, 4>> neighbour;  ///< #T, across the face opposite each slot; −1 on the hull
};

/// Makes `tets` the regular triangulation of the sites `points` (#N × 3)
/// with weights `weights` (#N) by 2-3 and 3-2 flips (Lawson's algorithm
/// with the exactly filtered power test of CGAL's kernel), starting from
/// the regular triangulation of the same sites under other weights.
/// Precondition: `tets` triangulates the sites' convex hull and every site
/// is one of its vertices. Flips cannot remove a vertex: a site that the new
/// weights hide, or a non-regular facet that no flip can remove (Lawson's
/// algorithm can stall in 3D), or more than `maxFlips` flips make it return
/// false. On true every interior facet is locally regular, which makes the
/// triangulation regular. On false after a stall or at the flip limit,
/// `tets` is still a triangulation of the sites (positively oriented, every
/// site a vertex, not regular) and `suspects` (if given) lists the sites of
/// its facets that are not locally regular, sorted, without repeats; on the
/// other failures (the seed's tets not positive in these sites, sites on the
/// hull that are not its corners) `tets` is unchanged and `suspects` empty.
bool repairRegularTriangulation(const Eigen::MatrixX3d& points, const Eigen::VectorXd& weights, TetArrays& tets,
                                long maxFlips, long* flips = nullptr, std::vector<int>* suspects = nullptr);

/// Rewrites `tets` in a canonical form that depends only on the set of tets:
/// each tet's slots turned by an even permutation so that its vertex tuple
/// is lexicographically smallest, the tets sorted by that tuple, neighbours
/// renumbered. Two builds of the same triangulation (CGAL's insertion, a
/// repair by flips) then give bit-identical measurements downstream.
void canonicalizeTets(TetArrays& tets, int sites);

}  // namespace tet2spline

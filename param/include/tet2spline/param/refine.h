#pragma once
/// Mesh refinement that the maps need before they start.
///
/// A *chord* is an edge between two boundary vertices that is not itself a
/// boundary edge: it runs through the inside of the solid. On the cube, the
/// two ends of a chord can land on the same face, and then the tets around
/// it (which must turn a full 360° around it) cannot all be positive: no
/// untangling can repair them. A tet with four boundary vertices has such
/// chords, and on the ball its shape is decided by the spherical map alone.
/// Splitting every chord at its midpoint (a new interior vertex) removes
/// both problems; TetGen meshes have chords at sharp features and in thin
/// parts.

#include <utility>
#include <vector>

#include "tet2spline/param/tet_mesh.h"

namespace tet2spline {

/// Splits every chord of the outer boundary (see above) at its midpoint.
/// Each tet around a chord becomes two tets with the same region and cell
/// fields; point fields of the new vertex are the mean of the chord's ends.
/// Tets stay positively oriented, exactly and in floating point: the new
/// vertex is the midpoint unless rounding would flatten a sliver around the
/// chord, then another point of the chord; a chord with no such point stays.
/// Returns the number of chords split (the number of new vertices, appended
/// after the existing ones).
int splitBoundaryChords(TetMesh& mesh);

/// One edge split by splitEdges: the new vertex `vertex` lies at
/// (1 − t)·a + t·b (t = ½ unless rounding forced another point, see above).
struct EdgeSplit {
  int a = 0, b = 0, vertex = 0;
  double t = 0.5;
};

struct EdgeSplits {
  std::vector<EdgeSplit> splits;  ///< in the order of the edges given; new vertices appended in that order
  std::vector<int> parent;        ///< per tet of the refined mesh: the tet it was cut from (itself if untouched)
};

/// Splits each edge (a, b) of `edges` as splitBoundaryChords splits a chord:
/// every tet around it becomes two (the first keeps its index, the second is
/// appended), regions, cell and point fields follow. The new vertex is the
/// edge's midpoint unless rounding would flatten a tet around it; an edge
/// with no such point, or that is not an edge of the mesh (any more), stays.
/// Tets stay positively oriented when they were.
EdgeSplits splitEdges(TetMesh& mesh, const std::vector<std::pair<int, int>>& edges);

/// Number of chords of the outer boundary, for tests and reports.
int countBoundaryChords(const TetMesh& mesh);

}  // namespace tet2spline

#pragma once
/// Tetrahedral meshing of closed surfaces with TetGen (used as a library).
///
/// The surface may hold nested closed shells. Without voids each nesting level
/// is a region: the space between the outer shell and the shells directly
/// inside it is region 1, the inside of an inner shell region 2, 3, ... (one
/// tag per inner shell, in the order of the shells' first faces). With
/// `voids`, inner shells bound voids: their inside is meshed too and tagged as
/// a void region (listed in TetMesh::voidRegions), so the filled solid is a
/// topological ball (design.md, "Voids").
///
/// The surface is validated first (topology.h: closed, manifold, genus 0 per
/// shell, no self-intersection) so that TetGen never sees bad input. Nesting
/// is decided by winding numbers; shells may be oriented either way. Refused
/// with Error(Topology): shells side by side (several solids) and, with
/// `voids`, a shell inside a void (the solid would fall apart).
///
/// Output: positively oriented tets (checked with exact orient3d), no unused
/// vertices; the surface's used vertices come first, in their order and with
/// their exact coordinates, then TetGen's Steiner points.
/// TetGen prints nothing (-Q).

#include <string>

#include "tet2spline/param/tet_mesh.h"

namespace tet2spline {

struct TetrahedralizeOptions {
  double radiusEdgeRatio = 1.5;  ///< TetGen quality bound (-q), >= 1; 0 = no quality refinement
  double maxVolume = 0;          ///< largest tet volume (-a); 0 = no limit
  double relativeSize = 0;       ///< if > 0, max edge ≈ relativeSize × bbox diagonal (overrides maxVolume:
                                 ///< the volume of a regular tet of that edge, (size·diag)³/(6√2))
  /// Degrees, in [0, 18]: TetGen's quality refinement also splits tets with
  /// a smaller dihedral angle (-q ratio/angle; needs radiusEdgeRatio > 0).
  /// 0 leaves TetGen's default (no angle bound; its optimisation only
  /// removes slivers with a dihedral angle above 165°). The maps untangle
  /// a mesh with fewer slivers far more easily: on spool.off, 15° takes
  /// the cube parameterization's ball map from 1 inverted tet after 6400
  /// L-BFGS iterations (over 30 s) to none after 2 s, for 34% more vertices
  /// (5398 against 4017). Not the default: it adds vertices everywhere
  /// (blobby 8.6k -> 16.3k, fandisk 18.2k -> 28.9k) and the transport costs
  /// grow with them.
  double minDihedral = 0;
  bool voids = false;            ///< inner shells are voids (filled, tagged) instead of material regions
  /// Boundary Steiner points lie exactly on the input triangles, so the tets'
  /// volume equals the enclosed volume to rounding. false lets TetGen merge
  /// facets within 0.1° of coplanar (fewer tets on CAD-like surfaces, boundary
  /// points up to ~1e-5 × size off the input surface).
  bool exactBoundary = true;
  /// Caps (triangles with an angle above this many degrees, nearly a
  /// segment) are removed by edge flips before meshing (flipCaps); 0 = never.
  /// TetGen has to conform to a cap: on triceratops.off one cap (angles 0°,
  /// 180°, 0°) made a cluster of tets with edges 5e-8 of the model size and
  /// vertex volumes 3e-21 of the total, which the transport cannot resolve.
  /// Only with merged facets (exactBoundary false): the flip leaves two
  /// nearly coplanar triangles, which TetGen then merges and remeshes; kept
  /// as two facets (exactBoundary), they bound a near-flat sliver instead
  /// (triceratops: its ball map then kept one inverted tet after 388 s of
  /// untangling), and exactBoundary promises the input triangles anyway.
  double capAngle = 179;
  /// Runs TetGen's steps from here, with its refinement queues compacted
  /// once they are empty (tetrahedralize.cpp says how): the same mesh,
  /// bit for bit, as TetGen's own tetrahedralize(), whose refinement
  /// spends a third of its time walking dead queue slots (`tet2spline
  /// mesh bunny00.off`: 18.2 -> 11.8 s, the same file). false calls
  /// tetrahedralize() itself.
  bool tetgenDriver = true;
};

/// What tetrahedralize() changed in the surface before meshing.
struct TetrahedralizeStats {
  int capsFlipped = 0;  ///< edge flips made by flipCaps
  /// Queue entries that TetGen's refinement took beyond the slots a
  /// compacted queue kept, in a queue that dropped some
  /// (TetrahedralizeOptions::tetgenDriver); 0 means the mesh is the one
  /// TetGen's own tetrahedralize() makes.
  long queueSlotsGrown = 0;
  /// Dead queue slots the driver dropped (what TetGen's repair passes
  /// would have walked each time).
  long queueSlotsDropped = 0;
};

/// Removes caps in place by edge flips: for a triangle (a, b, c) with an angle
/// above `capAngleDegrees` at a, the edge bc is flipped to ad (d the apex of
/// the triangle across bc) when ad is not yet an edge and both new triangles
/// keep the orientation of the old pair. The vertices do not move; the
/// surface moves by at most the cap's height, |bc|·sin(180° − angle)/2.
/// Returns the number of flips. A surface whose flips would create an edge
/// twice or a folded pair keeps those caps.
int flipCaps(SurfaceMesh& surface, double capAngleDegrees = 179);

/// Throws Error(Input/Topology) for an invalid surface (see topology.h) and
/// Error(Numerical) if TetGen fails; the message names `sourceName`.
TetMesh tetrahedralize(const SurfaceMesh& surface, const TetrahedralizeOptions& options = {},
                       const std::string& sourceName = "surface", TetrahedralizeStats* stats = nullptr);

}  // namespace tet2spline

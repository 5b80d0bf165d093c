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
  bool voids = false;            ///< inner shells are voids (filled, tagged) instead of material regions
  /// Boundary Steiner points lie exactly on the input triangles, so the tets'
  /// volume equals the enclosed volume to rounding. false lets TetGen merge
  /// facets within 0.1° of coplanar (fewer tets on CAD-like surfaces, boundary
  /// points up to ~1e-5 × size off the input surface).
  bool exactBoundary = true;
};

/// Throws Error(Input/Topology) for an invalid surface (see topology.h) and
/// Error(Numerical) if TetGen fails; the message names `sourceName`.
TetMesh tetrahedralize(const SurfaceMesh& surface, const TetrahedralizeOptions& options = {},
                       const std::string& sourceName = "surface");

}  // namespace tet2spline

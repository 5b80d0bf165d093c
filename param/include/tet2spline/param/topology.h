#pragma once
/// Topology and validity of tetrahedral solids and triangle surfaces
/// (design.md, "Topology"). Genus of a closed shell: g = (2 − χ)/2, χ = V − E + F.
/// Inverted and degenerate tets are decided with exact orientation predicates.

#include <string>
#include <vector>

#include "tet2spline/param/error.h"
#include "tet2spline/param/tet_mesh.h"

namespace tet2spline {

/// One closed boundary shell (or connected surface component). Shells are the
/// connected components of the triangles through manifold edges (two triangles).
struct ShellInfo {
  int vertices = 0;
  int edges = 0;
  int faces = 0;
  int eulerCharacteristic = 0;
  int genus = 0;           ///< (2 − χ)/2 for closed shells; −1 when the shell is open
  bool closed = true;
  double enclosedVolume = 0; ///< signed volume enclosed (outward normals give > 0)
  int inconsistentEdges = 0;  ///< manifold edges whose two triangles use it in the same direction
};

/// Everything `tet2spline check` reports about a solid.
struct SolidReport {
  int vertices = 0;
  int tets = 0;
  int components = 0;              ///< connected components of tets (sharing a face)
  int unusedVertices = 0;
  int duplicateVertices = 0;       ///< used vertices at exactly the position of another used one
  int invertedTets = 0;            ///< exact orient3d < 0
  int degenerateTets = 0;          ///< exact orient3d == 0
  int nonManifoldFaces = 0;         ///< triangles shared by more than two tets
  int nonManifoldBoundaryEdges = 0;  ///< edges of more than two boundary faces
  int nonManifoldBoundaryVertices = 0; ///< boundary faces at the vertex are not one fan
  std::vector<ShellInfo> shells;   ///< boundary shells, outer shell first
  int genus = 0;                   ///< genus of the outer shell
  int voids = 0;                   ///< inner boundary shells, plus filled void regions
  std::vector<int> regions;        ///< distinct region tags, ascending
  std::vector<std::string> problems; ///< one sentence per reason the solid is refused
  std::vector<ErrorKind> problemKinds; ///< Topology or Input, one per problem
  bool valid() const { return problems.empty(); }
};

/// Throws Error(Input) when T indexes outside V or region has neither 0 nor
/// #T entries; everything else goes into the report. Unused vertices are counted but are not a problem
/// (see removeUnusedVertices); duplicate positions among used vertices are.
SolidReport analyzeSolid(const TetMesh& mesh);

/// If every tet is inverted, flips them all (a mesh written with the other
/// orientation convention) and returns true. Otherwise leaves the mesh alone.
bool reorientIfAllInverted(TetMesh& mesh);

/// Drops vertices that no tet uses (and their rows of pointFields), renumbers
/// T, and returns how many were removed.
int removeUnusedVertices(TetMesh& mesh);

/// Throws Error(Topology) (several components, non-manifold, genus > 0) or
/// Error(Input) (inverted or degenerate tets, coincident vertices) with the
/// first problem of `report`, prefixed by "file: "; the kind is
/// problemKinds[0]. Topology problems are listed first. Does nothing for a
/// valid report.
void requireValidSolid(const SolidReport& report, const std::string& file);

/// Topology of a triangle surface that should bound a solid.
struct SurfaceReport {
  int vertices = 0;
  int faces = 0;
  int unusedVertices = 0;           ///< vertices of no triangle (not a problem)
  int duplicateVertices = 0;        ///< used vertices at exactly the position of another used one
  int boundaryEdges = 0;            ///< edges with one incident triangle (open surface)
  int boundaryLoops = 0;            ///< connected groups of boundary edges (holes)
  int nonManifoldEdges = 0;         ///< edges with more than two incident triangles
  int nonManifoldVertices = 0;      ///< vertices whose triangle fan is not one disk/cycle
  int degenerateFaces = 0;          ///< zero-area or repeated-index triangles
  int inconsistentEdges = 0;        ///< edges used twice in the same direction
  int selfIntersections = 0;        ///< intersecting pairs of triangles (capped at kMaxSelfIntersections)
  bool selfIntersectionsChecked = false; ///< false when not asked, or the surface is not a
                                         ///< manifold triangle mesh (then it is refused anyway)
  std::vector<ShellInfo> shells;    ///< connected components, in the order of their first faces
  std::vector<std::vector<int>> shellFaces; ///< face indices of each shell
  /// Nesting, known when the shells are closed, manifold and do not
  /// intersect (else empty): the innermost shell containing each shell (−1
  /// for none) and the number of shells containing it (winding numbers).
  std::vector<int> shellParent;
  std::vector<int> shellDepth;
  std::vector<std::string> problems;
  std::vector<ErrorKind> problemKinds; ///< Topology or Input, one per problem
  bool valid() const { return problems.empty(); }
};

/// Self-intersection counting stops at this many pairs of triangles.
constexpr int kMaxSelfIntersections = 1000;

/// Components, manifoldness, genus per shell, (CGAL) self-intersections, and
/// the nesting of closed shells: more than one outermost shell (solids side
/// by side) is a topology problem.
SurfaceReport analyzeSurface(const SurfaceMesh& surface, bool checkSelfIntersections = true);

/// Throws with the first problem of `report`, prefixed by "file: ":
/// Error(Topology) for open, non-manifold, several solids or genus > 0;
/// Error(Input) for degenerate, inconsistently oriented, self-intersecting or
/// self-touching surfaces. Problems are listed in the order a user should fix
/// them: open/non-manifold, then geometry, then nesting, then genus.
void requireValidSurface(const SurfaceReport& report, const std::string& file);

/// The boundary triangles of a tet mesh, oriented outward, indexing mesh.V.
Eigen::MatrixX3i boundaryFaces(const TetMesh& mesh);

/// Exact sign of det[b − a, c − a, d − a]: +1, 0 or −1.
int orient3d(const double* a, const double* b, const double* c, const double* d);

/// Exactly whether a, b, c lie on one line (a zero-area triangle).
bool collinear(const double* a, const double* b, const double* c);

/// Number of tets of (X, T) with exact orientation <= 0.
int countNonPositiveTets(const Eigen::MatrixX3d& X, const Eigen::MatrixX4i& T);

/// Number of triangles F (indexing U) that are flipped as seen from `apex`:
/// exact orient3d(apex, U_a, U_b, U_c) <= 0 (the boundary of a domain
/// star-shaped from apex, e.g. the cube from its centre).
int countFlippedTriangles(const Eigen::MatrixX3d& U, const Eigen::MatrixX3i& F, const Eigen::Vector3d& apex);

/// Quantile p (in [0, 1]) of the angle, in degrees, between the normals of
/// the two triangles of F (#F × 3, indexing X) on each edge that exactly two
/// of them share, over the edges whose angle is at least ignoreBelow; 0
/// when there is none. A finely meshed smooth surface has small angles
/// everywhere; creases and sharp tips show in the upper tail. ignoreBelow
/// (e.g. 0.1°) leaves out the edges inside planar faces, which splitting
/// a surface's triangles adds (TetGen's quality meshing does on the
/// boundary) and which would otherwise push the tail down. The
/// libcgal-demo meshes as the command line meshes them, at p = 0.99 and
/// 0.1°: see ParamOptions::smoothBoundaryDegrees. Throws Error(Usage) for
/// p outside [0, 1] or ignoreBelow < 0, Error(Input) for an index out of
/// range.
double normalAngleQuantile(const Eigen::MatrixX3d& X, const Eigen::MatrixX3i& F, double p, double ignoreBelow = 0);

/// Share of the area of the triangles F (#F × 3, indexing X) that lies in
/// planar patches of at least minPatch of the whole area: patches of
/// triangles joined across shared edges whose normals are within `degrees`
/// of the patch's first triangle's. A CAD solid's tessellation is mostly
/// large planar faces; a scanned or sculpted shape has none, and splitting
/// its triangles (as TetGen's quality meshing does on the boundary) makes
/// patches no larger than an input triangle. Throws Error(Usage) for
/// degrees < 0 or minPatch outside [0, 1], Error(Input) for an index out of
/// range.
double planarShare(const Eigen::MatrixX3d& X, const Eigen::MatrixX3i& F, double degrees, double minPatch);

}  // namespace tet2spline

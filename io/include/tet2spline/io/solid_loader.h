#pragma once
/// Turns any supported input file into a tetrahedral solid (design.md, "Data flow"):
/// volume meshes are read (and reoriented when every tet is inverted), surfaces
/// are meshed with TetGen, STEP/IGES solids are tessellated and then meshed.

#include <string>

#include "tet2spline/io/cad_io.h"
#include "tet2spline/param/tet_mesh.h"
#include "tet2spline/param/tetrahedralize.h"
#include "tet2spline/param/topology.h"

namespace tet2spline {

struct LoadOptions {
  TetrahedralizeOptions meshing;  ///< for surface and CAD input
  CadReadOptions cad;             ///< for STEP/IGES input
  bool validate = true;           ///< throw on an invalid solid (requireValidSolid)
};

struct LoadedSolid {
  TetMesh mesh;
  SolidReport report;             ///< analyzeSolid(mesh)
  std::string inputKind;          ///< "volume", "surface" or "cad"
  bool reoriented = false;        ///< every tet of the input was inverted and was flipped
  int removedUnusedVertices = 0;  ///< vertices of a volume file that no tet uses (dropped)
  int capsFlipped = 0;            ///< surface/CAD input: caps removed by edge flips before meshing
  /// surface/CAD input: TetrahedralizeStats::queueSlotsGrown (0: the mesh is
  /// the one TetGen's own tetrahedralize() makes)
  long tetgenQueueSlotsGrown = 0;
  double seconds = 0;             ///< reading + tessellation + meshing + analysis
};

/// Reads `path` by extension. Throws Error(Input) for unknown extensions and
/// malformed files, and (when options.validate) Error(Topology/Input) for a
/// solid that later stages cannot take, with the report's first problem.
LoadedSolid loadSolid(const std::string& path, const LoadOptions& options = {});

}  // namespace tet2spline

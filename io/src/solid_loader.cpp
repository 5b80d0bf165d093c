#include "tet2spline/io/solid_loader.h"

#include <chrono>

#include "tet2spline/io/mesh_io.h"
#include "tet2spline/param/error.h"

namespace tet2spline {

LoadedSolid loadSolid(const std::string& path, const LoadOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  LoadedSolid out;
  const FileFormat format = formatFromPath(path);
  if (isVolumeFormat(format)) {
    out.inputKind = "volume";
    out.mesh = readTetMesh(path);
    // Readers keep every vertex of the file (gmsh writes its geometry points
    // too); a vertex of no tet has no place in a solid's parameterization.
    out.removedUnusedVertices = removeUnusedVertices(out.mesh);
    out.reoriented = reorientIfAllInverted(out.mesh);
  } else if (isSurfaceFormat(format) || isCadFormat(format)) {
    const bool cad = isCadFormat(format);
    out.inputKind = cad ? "cad" : "surface";
    TetrahedralizeStats stats;
    out.mesh = tetrahedralize(cad ? readCadSurface(path, options.cad) : readSurface(path), options.meshing, path, &stats);
    out.capsFlipped = stats.capsFlipped;
    out.tetgenQueueSlotsGrown = stats.queueSlotsGrown;
  } else {
    throwInputError(path, 0,
                    "unknown file extension (expected .mesh, .msh, .node, .ele, .vtu, .vtk, .off, .obj, .stl, "
                    ".ply, .step, .stp, .iges or .igs)");
  }
  out.report = analyzeSolid(out.mesh);
  if (options.validate) requireValidSolid(out.report, path);
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace tet2spline

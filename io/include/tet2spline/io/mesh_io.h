#pragma once
/// Reading and writing meshes by file extension.
///
/// Volume meshes: MEDIT .mesh (ASCII), Gmsh .msh 2.2 and 4.1 (ASCII and binary),
/// TetGen .node/.ele (either name), VTK .vtu (ASCII, binary, appended; raw or
/// zlib-compressed) and legacy .vtk. Region tags are read from MEDIT references,
/// Gmsh physical tags, TetGen region attributes and VTU/VTK cell arrays
/// ("region", "gmsh:physical", "CellEntityIds", "MaterialIds", "medit:ref").
/// Surfaces: OFF, OBJ, STL (ASCII and binary), PLY (ASCII and binary).
///
/// Every reader throws tet2spline::Error(ErrorKind::Input) with one line
/// "file[:line]: cause" on malformed data (empty, truncated, wrong header,
/// counts that disagree, indices out of range, NaN/Inf coordinates, non-tet
/// cells in a volume file). Readers do not check topology (see topology.h) and
/// do not reorient tets. They keep every vertex of the file, referenced or not,
/// in file order (Gmsh node tags are remapped to 0..#V-1), and drop 0D/1D/2D
/// cells together with their data. In .vtu/.vtk the region array is not also
/// copied into cellFields; every other numeric array becomes a point or cell
/// field. Regions: MEDIT tet references; Gmsh physical tag, else the entity
/// (elementary) tag, else 1; TetGen first tet attribute, else 1; VTK the
/// first array present in the order listed above, else 1.
///
/// Writers write to a temporary name and rename, so a failure leaves no file.
/// Round trips through .mesh, .msh and .vtu give back V, T (same order) and
/// region bit for bit; .vtu also every field (as Float64) and voidRegions
/// (FieldData "void_regions"). Other formats do not store voidRegions.

#include <string>

#include "tet2spline/param/tet_mesh.h"

namespace tet2spline {

enum class FileFormat { Medit, Gmsh, TetGen, Vtu, LegacyVtk, Off, Obj, Stl, Ply, Step, Iges, Unknown };

/// The format named by the path's extension (case-insensitive); Unknown otherwise.
FileFormat formatFromPath(const std::string& path);
bool isVolumeFormat(FileFormat f);
bool isSurfaceFormat(FileFormat f);
bool isCadFormat(FileFormat f);

/// Reads a tetrahedral mesh; throws Error(Input) for an unknown extension.
TetMesh readTetMesh(const std::string& path);

/// Reads a triangulated surface; throws Error(Input) for an unknown extension.
SurfaceMesh readSurface(const std::string& path);

struct MeshWriteOptions {
  bool binary = true;  ///< binary/appended where the format has it (.msh, .vtu)
};

/// Writes .mesh, .msh (4.1) or .vtu, with the region tags and, for .vtu, every
/// point and cell field. .msh has one volume entity per region whose physical
/// tag is the region; .vtu is appended raw binary (UInt64 headers) or ASCII.
/// Throws Error(Input) when the path cannot be written, and before creating
/// any file when the mesh is inconsistent (region/field sizes, T outside V).
void writeTetMesh(const TetMesh& mesh, const std::string& path, const MeshWriteOptions& options = {});

/// Writes a surface as .off, .obj, .stl (binary, float32 coordinates) or .ply
/// (binary little endian, double coordinates).
void writeSurface(const SurfaceMesh& surface, const std::string& path);

}  // namespace tet2spline

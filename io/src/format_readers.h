#pragma once
// Per-format readers and writers behind mesh_io.h (internal to the io module).
#include <string>

#include "tet2spline/io/mesh_io.h"
#include "tet2spline/param/tet_mesh.h"

namespace tet2spline::detail {

// Surfaces.
SurfaceMesh readOff(const std::string& path);
SurfaceMesh readObj(const std::string& path);
SurfaceMesh readStl(const std::string& path);
SurfaceMesh readPly(const std::string& path);
void writeOff(const SurfaceMesh& s, const std::string& path);
void writeObj(const SurfaceMesh& s, const std::string& path);
void writeStl(const SurfaceMesh& s, const std::string& path);  // binary
void writePly(const SurfaceMesh& s, const std::string& path);  // binary little endian

// Volume meshes.
TetMesh readMedit(const std::string& path);
TetMesh readGmsh(const std::string& path);
TetMesh readTetGen(const std::string& path);  // .node or .ele; finds the sibling
TetMesh readVtu(const std::string& path);
TetMesh readLegacyVtk(const std::string& path);
void writeMedit(const TetMesh& m, const std::string& path);
void writeGmsh(const TetMesh& m, const std::string& path, bool binary);
void writeVtu(const TetMesh& m, const std::string& path, bool binary);

/// Throws unless V, T, region and fields have consistent shapes and T indexes V.
void checkMeshForWriting(const TetMesh& m, const std::string& path);
void checkSurfaceForWriting(const SurfaceMesh& s, const std::string& path);

/// Region of tet t (1 when the mesh has no region tags).
inline int regionOf(const TetMesh& m, Eigen::Index t) { return m.region.size() == 0 ? 1 : m.region(t); }

}  // namespace tet2spline::detail

// Dispatch of mesh reading and writing by file extension.
#include "tet2spline/io/mesh_io.h"

#include <algorithm>
#include <cctype>

#include "format_readers.h"
#include "tet2spline/param/error.h"

namespace tet2spline {

namespace {
std::string lowerExtension(const std::string& path) {
  auto slash = path.find_last_of('/');
  auto dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return {};
  std::string ext = path.substr(dot + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext;
}
}  // namespace

FileFormat formatFromPath(const std::string& path) {
  const std::string ext = lowerExtension(path);
  if (ext == "mesh") return FileFormat::Medit;
  if (ext == "msh") return FileFormat::Gmsh;
  if (ext == "node" || ext == "ele") return FileFormat::TetGen;
  if (ext == "vtu") return FileFormat::Vtu;
  if (ext == "vtk") return FileFormat::LegacyVtk;
  if (ext == "off") return FileFormat::Off;
  if (ext == "obj") return FileFormat::Obj;
  if (ext == "stl") return FileFormat::Stl;
  if (ext == "ply") return FileFormat::Ply;
  if (ext == "step" || ext == "stp") return FileFormat::Step;
  if (ext == "iges" || ext == "igs") return FileFormat::Iges;
  return FileFormat::Unknown;
}

bool isVolumeFormat(FileFormat f) {
  return f == FileFormat::Medit || f == FileFormat::Gmsh || f == FileFormat::TetGen || f == FileFormat::Vtu ||
         f == FileFormat::LegacyVtk;
}
bool isSurfaceFormat(FileFormat f) {
  return f == FileFormat::Off || f == FileFormat::Obj || f == FileFormat::Stl || f == FileFormat::Ply;
}
bool isCadFormat(FileFormat f) { return f == FileFormat::Step || f == FileFormat::Iges; }

SurfaceMesh readSurface(const std::string& path) {
  switch (formatFromPath(path)) {
    case FileFormat::Off: return detail::readOff(path);
    case FileFormat::Obj: return detail::readObj(path);
    case FileFormat::Stl: return detail::readStl(path);
    case FileFormat::Ply: return detail::readPly(path);
    default: break;
  }
  throwInputError(path, 0, "unknown or unsupported surface file extension (expected .off, .obj, .stl or .ply)");
}

TetMesh readTetMesh(const std::string& path) {
  switch (formatFromPath(path)) {
    case FileFormat::Medit: return detail::readMedit(path);
    case FileFormat::Gmsh: return detail::readGmsh(path);
    case FileFormat::TetGen: return detail::readTetGen(path);
    case FileFormat::Vtu: return detail::readVtu(path);
    case FileFormat::LegacyVtk: return detail::readLegacyVtk(path);
    default: break;
  }
  throwInputError(path, 0, "unknown or unsupported volume mesh extension (expected .mesh, .msh, .node/.ele, .vtu or .vtk)");
}

void writeTetMesh(const TetMesh& mesh, const std::string& path, const MeshWriteOptions& options) {
  const FileFormat f = formatFromPath(path);
  if (f != FileFormat::Medit && f != FileFormat::Gmsh && f != FileFormat::Vtu)
    throwInputError(path, 0, "unsupported output extension for a tetrahedral mesh (expected .mesh, .msh or .vtu)");
  detail::checkMeshForWriting(mesh, path);
  switch (f) {
    case FileFormat::Medit: detail::writeMedit(mesh, path); break;
    case FileFormat::Gmsh: detail::writeGmsh(mesh, path, options.binary); break;
    default: detail::writeVtu(mesh, path, options.binary); break;
  }
}

void writeSurface(const SurfaceMesh& surface, const std::string& path) {
  const FileFormat f = formatFromPath(path);
  if (!isSurfaceFormat(f))
    throwInputError(path, 0, "unsupported output extension for a surface (expected .off, .obj, .stl or .ply)");
  detail::checkSurfaceForWriting(surface, path);
  switch (f) {
    case FileFormat::Off: detail::writeOff(surface, path); break;
    case FileFormat::Obj: detail::writeObj(surface, path); break;
    case FileFormat::Stl: detail::writeStl(surface, path); break;
    default: detail::writePly(surface, path); break;
  }
}

namespace detail {

void checkMeshForWriting(const TetMesh& m, const std::string& path) {
  const Eigen::Index nv = m.V.rows(), nt = m.T.rows();
  auto bad = [&](const std::string& why) { throw Error(ErrorKind::Input, path + ": writeTetMesh: inconsistent mesh: " + why); };
  if (m.region.size() != 0 && m.region.size() != nt)
    bad("region has " + std::to_string(m.region.size()) + " entries for " + std::to_string(nt) + " tets");
  if (nt > 0 && (m.T.minCoeff() < 0 || m.T.maxCoeff() >= nv))
    bad("a tet references a vertex outside [0, " + std::to_string(nv) + ")");
  for (const auto& f : m.pointFields)
    if (f.values.rows() != nv) bad("point field '" + f.name + "' has " + std::to_string(f.values.rows()) + " rows for " + std::to_string(nv) + " vertices");
  for (const auto& f : m.cellFields)
    if (f.values.rows() != nt) bad("cell field '" + f.name + "' has " + std::to_string(f.values.rows()) + " rows for " + std::to_string(nt) + " tets");
}

void checkSurfaceForWriting(const SurfaceMesh& s, const std::string& path) {
  if (s.F.rows() > 0 && (s.F.minCoeff() < 0 || s.F.maxCoeff() >= s.V.rows()))
    throw Error(ErrorKind::Input, path + ": writeSurface: inconsistent surface: a triangle references a vertex outside [0, " +
                                      std::to_string(s.V.rows()) + ")");
}

}  // namespace detail
}  // namespace tet2spline

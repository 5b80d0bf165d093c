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
    default: break;
  }
  throwInputError(path, 0, "unknown or unsupported surface file extension (expected .off, .obj, .stl or .ply)");
}

TetMesh readTetMesh(const std::string& path) {
  throwInputError(path, 0, "unknown or unsupported volume mesh extension (expected .mesh, .msh, .node/.ele, .vtu or .vtk)");
}

}  // namespace tet2spline

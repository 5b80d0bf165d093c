#pragma once
/// Plain mesh types that the modules exchange (design.md, "Data flow").
/// Letters follow the paper: V vertex positions, T tets, F triangles.

#include <Eigen/Core>
#include <set>
#include <string>
#include <vector>

namespace tet2spline {

/// A named array attached to the vertices or the tets of a mesh.
struct Field {
  std::string name;
  Eigen::MatrixXd values;  ///< #entities × components
};

/// A tetrahedral solid. Tets are positively oriented: for T(t,:) = (a,b,c,d),
/// det[V_b − V_a, V_c − V_a, V_d − V_a] > 0.
struct TetMesh {
  Eigen::MatrixX3d V;             ///< vertex positions, #V × 3
  Eigen::MatrixX4i T;             ///< vertex indices per tet, #T × 4
  Eigen::VectorXi region;         ///< region (material) tag per tet, #T; 1 where the input has none
  std::set<int> voidRegions;      ///< region tags whose tets fill a void of the solid
  std::vector<Field> pointFields; ///< per-vertex arrays carried from input to output
  std::vector<Field> cellFields;  ///< per-tet arrays carried from input to output

  Eigen::Index numVertices() const { return V.rows(); }
  Eigen::Index numTets() const { return T.rows(); }
  /// The field of that name among pointFields/cellFields, or nullptr.
  const Field* pointField(const std::string& name) const {
    for (const auto& f : pointFields) if (f.name == name) return &f;
    return nullptr;
  }
  const Field* cellField(const std::string& name) const {
    for (const auto& f : cellFields) if (f.name == name) return &f;
    return nullptr;
  }
};

/// A triangulated surface, possibly made of several closed shells.
struct SurfaceMesh {
  Eigen::MatrixX3d V;  ///< vertex positions, #V × 3
  Eigen::MatrixX3i F;  ///< vertex indices per triangle, #F × 3
};

}  // namespace tet2spline

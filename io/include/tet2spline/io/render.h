#pragma once
/// A small deterministic software renderer for the report's pictures.
///
/// Orthographic projection, z-buffer, Lambert + ambient shading from a headlight
/// (the light sits at the eye), two-sided (back faces are lit like front faces,
/// so inside-out input still reads), optional edge lines drawn where a pixel lies
/// within half a line width of a visible triangle's edge. Per-vertex scalars are
/// interpolated across triangles before the colour map is applied (smooth
/// colours, no Gouraud blending of colours). Anti-aliasing by supersampling.
/// The same input gives byte-identical pixels (no threads, no randomness).
///
/// View: `upAxis` u ∈ {0,1,2} is the world axis that appears vertical; with
/// (e1, e2) = (axis (u+1)%3, axis (u+2)%3), the eye looks at the model from the
/// direction d = cos(el)·cos(az)·e1 + cos(el)·sin(az)·e2 + sin(el)·e_u; screen
/// right is r = e_u × d / |e_u × d| and screen up is d × r. So with the default
/// upAxis = 2 and az = el = 0 the eye is on +x, right is +y and up is +z.
/// Fit: the 2D bounding box of all rows of V (referenced by F or not) projected
/// onto (r, up) is scaled uniformly to fill the image less `margin`·min(width,
/// height) on every side, and centred.
///
/// Letters: V vertex positions, F triangles, T tets (tet_mesh.h).

#include <Eigen/Core>

#include <string>
#include <vector>

#include "tet2spline/io/image.h"

namespace tet2spline {

enum class ColorMap {
  Viridis,      ///< perceptually uniform dark blue → green → yellow (matplotlib's viridis, piecewise linear)
  Diverging,    ///< blue → white → red, white at the middle of the range (ratios around 1, signed errors)
  Categorical,  ///< scalar rounded to an integer label, coloured by categoricalColor()
};

struct RenderOptions {
  int width = 800;
  int height = 600;
  double azimuthDeg = 35;
  double elevationDeg = 25;
  int upAxis = 2;                 ///< world axis drawn vertical: 0 x, 1 y, 2 z
  double margin = 0.04;           ///< empty border, as a fraction of min(width, height)
  ColorMap colorMap = ColorMap::Viridis;
  double scalarMin = 0;           ///< colour range; when scalarMin >= scalarMax the data's finite min/max
  double scalarMax = 0;
  Rgb background{255, 255, 255};
  Rgb baseColor{176, 190, 208};   ///< surface colour when no scalar or label is given
  Rgb nanColor{200, 200, 200};    ///< colour of non-finite scalars
  bool edges = false;             ///< overlay the triangles' edges
  Rgb edgeColor{40, 40, 40};
  double edgeWidth = 1.0;         ///< line width in output pixels
  double edgeOpacity = 0.55;
  double ambient = 0.3;           ///< shade = ambient + (1 − ambient)·|n·d|
  double creaseAngleDeg = 35;     ///< normals are averaged across edges flatter than this; 0 gives flat shading
  int supersample = 2;            ///< samples per pixel along each axis (1 = no anti-aliasing)
};

/// What colours a surface: at most one of the three may be non-empty.
struct SurfaceColors {
  Eigen::VectorXd vertexScalar;  ///< #V, interpolated across triangles, mapped by options.colorMap
  Eigen::VectorXd faceScalar;    ///< #F, constant per triangle, mapped by options.colorMap
  Eigen::VectorXi faceLabel;     ///< #F, categorical (region tags): categoricalColor(label)
};

/// Renders the triangles F (#F × 3, indices into V, #V × 3) as described above.
/// Throws std::invalid_argument naming renderSurface for a bad shape, an index out
/// of range, non-finite coordinates, more than one colouring, or a bad option.
Image renderSurface(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, const SurfaceColors& colors = {},
                    const RenderOptions& options = {});

/// Keeps the tets whose centroid c satisfies (c − point)·normal <= 0 and returns
/// the boundary faces of that set (faces not shared by two kept tets), each with
/// the tet it bounds, oriented outward from that tet for positively oriented tets.
/// Faces come in the order of their tets, then the tet's faces 0..3 (opposite
/// vertex 0..3), so the result is deterministic.
struct ClipPlane {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitX();  ///< points into the removed half; need not be unit
};
struct TetCutFaces {
  Eigen::MatrixX3i F;  ///< #faces × 3, indices into V
  Eigen::VectorXi tet; ///< #faces, the kept tet each face bounds
};
TetCutFaces clippedTetBoundary(const Eigen::MatrixX3d& V, const Eigen::MatrixX4i& T, const ClipPlane& plane);

/// What colours a cut tet mesh: at most one non-empty.
struct TetColors {
  Eigen::VectorXd vertexScalar;  ///< #V, interpolated
  Eigen::VectorXd tetScalar;     ///< #T, constant per tet
  Eigen::VectorXi tetLabel;      ///< #T, categorical (region tags)
};

/// renderSurface of clippedTetBoundary(V, T, plane), colouring each face by its
/// tet. The view is fitted to all of V, so a cut and an uncut picture taken with
/// the same options line up. Look from the removed side (the normal's side) to
/// see the cut. Throws std::invalid_argument naming renderTetCut on bad input.
Image renderTetCut(const Eigen::MatrixX3d& V, const Eigen::MatrixX4i& T, const ClipPlane& plane,
                   const TetColors& colors = {}, const RenderOptions& options = {});

/// The colour of t ∈ [0,1] (clamped; NaN gives mid-grey) under a continuous map.
/// For ColorMap::Categorical, t is taken as a label: categoricalColor(lround(t)).
Rgb colorMapColor(ColorMap map, double t);

/// A 10-colour qualitative palette (Tableau 10), indexed by (label − 1) modulo 10
/// (region tags start at 1, which gets the palette's blue), so a region keeps its
/// colour in every picture and table.
Rgb categoricalColor(int label);

/// A horizontal colour bar as an <svg> element for inline use in HTML (no xmlns, no
/// external references):
/// the gradient of `map` from `min` to `max`, 5 ticks with labels, and `label`
/// (escaped) as its title. Width and height in CSS pixels.
std::string colorBarSvg(ColorMap map, double min, double max, const std::string& label, int width = 320,
                        int height = 56);

}  // namespace tet2spline

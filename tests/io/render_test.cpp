// The report's software renderer: coverage, occlusion, colours, edges, cuts, determinism.
#include "tet2spline/io/render.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <stdexcept>

using namespace tet2spline;

namespace {

constexpr double kPi = 3.14159265358979323846;

/// The unit cube [0,1]^3 as 12 outward triangles.
void unitCube(Eigen::MatrixX3d& V, Eigen::MatrixX3i& F) {
  V.resize(8, 3);
  for (int i = 0; i < 8; ++i) V.row(i) << (i & 1), (i >> 1) & 1, (i >> 2) & 1;
  F.resize(12, 3);
  F << 0, 2, 1, 1, 2, 3,  // z = 0
      4, 5, 6, 5, 7, 6,   // z = 1
      0, 1, 4, 1, 5, 4,   // y = 0
      2, 6, 3, 3, 6, 7,   // y = 1
      0, 4, 2, 2, 4, 6,   // x = 0
      1, 3, 5, 3, 7, 5;   // x = 1
}

/// A square of half-size h in the plane x = x0, centred on the x axis, as 2 triangles.
void square(double x0, double h, Eigen::MatrixX3d& V, Eigen::MatrixX3i& F) {
  V.resize(4, 3);
  V << x0, -h, -h, x0, h, -h, x0, h, h, x0, -h, h;
  F.resize(2, 3);
  F << 0, 1, 2, 0, 2, 3;
}

size_t countNot(const Image& im, Rgb bg) {
  size_t n = 0;
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) {
      const uint8_t* p = im.at(x, y);
      if (p[0] != bg.r || p[1] != bg.g || p[2] != bg.b) ++n;
    }
  return n;
}

Rgb pixel(const Image& im, int x, int y) {
  const uint8_t* p = im.at(x, y);
  return {p[0], p[1], p[2]};
}

double cross2(const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return (a - o).x() * (b - o).y() - (a - o).y() * (b - o).x();
}

/// Area of the convex hull of 2D points (Andrew's monotone chain + shoelace).
double hullArea(std::vector<Eigen::Vector2d> p) {
  std::sort(p.begin(), p.end(), [](const auto& a, const auto& b) { return a.x() != b.x() ? a.x() < b.x() : a.y() < b.y(); });
  std::vector<Eigen::Vector2d> h(2 * p.size());
  size_t k = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && cross2(h[k - 2], h[k - 1], p[i]) <= 0) --k;
    h[k++] = p[i];
  }
  for (size_t i = p.size() - 1, t = k + 1; i-- > 0;) {
    while (k >= t && cross2(h[k - 2], h[k - 1], p[i]) <= 0) --k;
    h[k++] = p[i];
  }
  h.resize(k - 1);
  double a = 0;
  for (size_t i = 0; i < h.size(); ++i) a += h[i].x() * h[(i + 1) % h.size()].y() - h[(i + 1) % h.size()].x() * h[i].y();
  return 0.5 * std::abs(a);
}

/// A structured grid of n^3 unit cubes, each split into 6 positively oriented tets (Kuhn).
void tetGrid(int n, Eigen::MatrixX3d& V, Eigen::MatrixX4i& T) {
  const int m = n + 1;
  V.resize(m * m * m, 3);
  auto id = [m](int i, int j, int k) { return i + m * (j + m * k); };
  for (int k = 0; k < m; ++k)
    for (int j = 0; j < m; ++j)
      for (int i = 0; i < m; ++i) V.row(id(i, j, k)) << i, j, k;
  std::vector<Eigen::Vector4i> tets;
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        for (const auto& p : perms) {
          int c[3] = {i, j, k};
          Eigen::Vector4i t;
          t[0] = id(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            ++c[p[s]];
            t[s + 1] = id(c[0], c[1], c[2]);
          }
          const Eigen::Vector3d a = V.row(t[0]), b = V.row(t[1]), cc = V.row(t[2]), d = V.row(t[3]);
          if ((b - a).cross(cc - a).dot(d - a) < 0) std::swap(t[2], t[3]);
          tets.push_back(t);
        }
  T.resize(Eigen::Index(tets.size()), 4);
  for (size_t i = 0; i < tets.size(); ++i) T.row(Eigen::Index(i)) = tets[i].transpose();
}

/// Every edge of a closed, consistently oriented triangle set appears once in each direction.
void expectClosedOriented(const Eigen::MatrixX3i& F) {
  std::map<std::pair<int, int>, int> directed;
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) ++directed[{F(f, k), F(f, (k + 1) % 3)}];
  for (const auto& [e, n] : directed) {
    EXPECT_EQ(n, 1) << "edge " << e.first << "-" << e.second << " used twice in one direction";
    const auto it = directed.find({e.second, e.first});
    EXPECT_TRUE(it != directed.end() && it->second == 1) << "edge " << e.first << "-" << e.second << " has no twin";
  }
}

}  // namespace

// The cube's silhouette is the convex hull of its 8 projected corners; the view
// is fitted to their bounding box (render.h). Count covered pixels against that.
TEST(Render, CubeFillsItsAnalyticSilhouette) {
  Eigen::MatrixX3d V;
  Eigen::MatrixX3i F;
  unitCube(V, F);
  const double views[][2] = {{0, 0}, {35, 25}, {120, -40}, {-70, 60}, {10, 90}};
  for (const auto& view : views) {
    RenderOptions o;
    o.width = 400;
    o.height = 300;
    o.margin = 0.05;
    o.supersample = 1;
    o.azimuthDeg = view[0];
    o.elevationDeg = view[1];
    const Image im = renderSurface(V, F, {}, o);
    ASSERT_EQ(im.width, 400);
    ASSERT_EQ(im.height, 300);

    // The projection as documented in render.h, for upAxis = 2.
    const double az = view[0] * kPi / 180, el = view[1] * kPi / 180;
    const Eigen::Vector3d d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
    Eigen::Vector3d r = Eigen::Vector3d::UnitZ().cross(d);
    if (r.norm() < 1e-9) r = Eigen::Vector3d(-std::sin(az), std::cos(az), 0);
    r.normalize();
    const Eigen::Vector3d up = d.cross(r);
    std::vector<Eigen::Vector2d> corners;
    Eigen::Vector2d lo(1e9, 1e9), hi(-1e9, -1e9);
    for (int i = 0; i < 8; ++i) {
      const Eigen::Vector3d p = V.row(i);
      corners.emplace_back(p.dot(r), p.dot(up));
      lo = lo.cwiseMin(corners.back());
      hi = hi.cwiseMax(corners.back());
    }
    const double m = 0.05 * 300;
    const double s = std::min((400 - 2 * m) / (hi - lo).x(), (300 - 2 * m) / (hi - lo).y());
    const double expected = hullArea(corners) * s * s;
    const double got = double(countNot(im, o.background));
    EXPECT_NEAR(got / expected, 1.0, 0.02) << "az " << view[0] << " el " << view[1] << ": " << got << " pixels, expected "
                                           << expected;
    // Centred: the covered pixels' bounding box is symmetric about the image centre.
    int x0 = im.width, x1 = -1, y0 = im.height, y1 = -1;
    for (int y = 0; y < im.height; ++y)
      for (int x = 0; x < im.width; ++x)
        if (pixel(im, x, y) != o.background) x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
    EXPECT_NEAR(x0 + x1 + 1, im.width, 2);
    EXPECT_NEAR(y0 + y1 + 1, im.height, 2);
  }
}

TEST(Render, SupersamplingKeepsTheArea) {
  Eigen::MatrixX3d V;
  Eigen::MatrixX3i F;
  unitCube(V, F);
  RenderOptions o;
  o.width = 300;
  o.height = 300;
  o.supersample = 1;
  const double area1 = double(countNot(renderSurface(V, F, {}, o), o.background));
  o.supersample = 3;
  const double area3 = double(countNot(renderSurface(V, F, {}, o), o.background));
  // Anti-aliased rims count as covered: a few pixels per unit of perimeter at most.
  EXPECT_GT(area3, area1 * 0.99);
  EXPECT_LT(area3, area1 * 1.03);
}

// A nearer square hides a farther one, whatever the triangle order.
TEST(Render, NearerSurfaceHidesFartherOne) {
  Eigen::MatrixX3d Vn, Vf;
  Eigen::MatrixX3i Fn, Ff;
  square(1.0, 0.5, Vn, Fn);  // near: the eye is on +x
  square(0.0, 1.0, Vf, Ff);  // far, larger
  const int red = 2, blue = 0;
  for (const bool nearFirst : {true, false}) {
    Eigen::MatrixX3d V(8, 3);
    Eigen::MatrixX3i F(4, 3);
    Eigen::VectorXi label(4);
    const Eigen::MatrixX3d& A = nearFirst ? Vn : Vf;
    const Eigen::MatrixX3d& B = nearFirst ? Vf : Vn;
    V << A, B;
    F << Fn, (Ff.array() + 4).matrix();
    label << Eigen::Vector2i::Constant(nearFirst ? red : blue), Eigen::Vector2i::Constant(nearFirst ? blue : red);
    RenderOptions o;
    o.azimuthDeg = 0;
    o.elevationDeg = 0;
    o.width = o.height = 200;
    o.margin = 0;
    o.supersample = 1;
    SurfaceColors c;
    c.faceLabel = label;
    const Image im = renderSurface(V, F, c, o);
    // Facing the headlight, the colour is the label's colour exactly.
    EXPECT_EQ(pixel(im, 100, 100), categoricalColor(red)) << "nearFirst " << nearFirst;
    EXPECT_EQ(pixel(im, 70, 130), categoricalColor(red));
    EXPECT_EQ(pixel(im, 20, 100), categoricalColor(blue));
    EXPECT_EQ(pixel(im, 100, 180), categoricalColor(blue));
    // Red covers the middle half of each axis: a quarter of the image.
    size_t reds = 0;
    for (int y = 0; y < 200; ++y)
      for (int x = 0; x < 200; ++x) reds += pixel(im, x, y) == categoricalColor(red);
    EXPECT_NEAR(double(reds) / (200.0 * 200.0), 0.25, 0.01);
  }
}

// Lambert + ambient from a headlight: a face seen at angle θ is lit by ambient + (1 − ambient)·cos θ.
TEST(Render, HeadlightLambertShading) {
  Eigen::MatrixX3d V;
  Eigen::MatrixX3i F;
  square(0.0, 1.0, V, F);
  RenderOptions o;
  o.width = o.height = 64;
  o.supersample = 1;
  o.baseColor = {200, 200, 200};
  o.ambient = 0.25;
  o.elevationDeg = 0;
  for (const double az : {0.0, 30.0, 60.0}) {
    o.azimuthDeg = az;
    const Image im = renderSurface(V, F, {}, o);
    const double expected = 200 * (0.25 + 0.75 * std::cos(az * kPi / 180));
    EXPECT_NEAR(pixel(im, 32, 32).g, expected, 1.0) << "azimuth " << az;
  }
}

// Per-vertex scalars are interpolated before the colour map: the middle of a linear ramp has the map's middle colour.
TEST(Render, VertexScalarsInterpolateSmoothly) {
  Eigen::MatrixX3d V;
  Eigen::MatrixX3i F;
  square(0.0, 1.0, V, F);
  Eigen::VectorXd s = V.col(1);  // y: screen right when looking from +x
  RenderOptions o;
  o.azimuthDeg = o.elevationDeg = 0;
  o.width = o.height = 101;
  o.margin = 0;
  o.supersample = 1;
  SurfaceColors c;
  c.vertexScalar = s;
  const Image im = renderSurface(V, F, c, o);
  const Rgb mid = colorMapColor(ColorMap::Viridis, 0.5);
  const Rgb got = pixel(im, 50, 50);
  EXPECT_NEAR(got.r, mid.r, 3);
  EXPECT_NEAR(got.g, mid.g, 3);
  EXPECT_NEAR(got.b, mid.b, 3);
  // Left end near the map's start, right end near its end; green rises monotonically along the row (viridis).
  const Rgb first = colorMapColor(ColorMap::Viridis, 0), last = colorMapColor(ColorMap::Viridis, 1);
  EXPECT_NEAR(pixel(im, 0, 50).g, first.g, 4);
  EXPECT_NEAR(pixel(im, 100, 50).g, last.g, 4);
  for (int x = 1; x < 101; ++x) EXPECT_GE(pixel(im, x, 50).g, pixel(im, x - 1, 50).g) << x;
  // An explicit range maps values outside it to the ends.
  o.scalarMin = 10;
  o.scalarMax = 20;
  const Image clamped = renderSurface(V, F, c, o);
  EXPECT_EQ(pixel(clamped, 50, 50), first);
}

TEST(Render, EdgesAreDrawnOnlyWhenAsked) {
  Eigen::MatrixX3d V;
  Eigen::MatrixX3i F;
  square(0.0, 1.0, V, F);
  RenderOptions o;
  o.azimuthDeg = o.elevationDeg = 0;
  o.width = o.height = 100;
  o.margin = 0.1;
  o.supersample = 1;
  const Image plain = renderSurface(V, F, {}, o);
  o.edges = true;
  const Image edged = renderSurface(V, F, {}, o);
  // The shared diagonal runs through the centre; the interior away from it is untouched.
  // Pixel (49, 50) has its centre on the diagonal (screen offset (−0.5, +0.5) from the centre).
  EXPECT_EQ(pixel(plain, 49, 50), o.baseColor);
  EXPECT_LT(pixel(edged, 49, 50).r, o.baseColor.r - 40);
  EXPECT_EQ(pixel(edged, 70, 40), pixel(plain, 70, 40));
  EXPECT_EQ(countNot(edged, o.background), countNot(plain, o.background));
}

TEST(Render, SameInputSameBytes) {
  Eigen::MatrixX3d V;
  Eigen::MatrixX3i F;
  unitCube(V, F);
  V = (V.array() - 0.5).matrix();
  SurfaceColors c;
  c.vertexScalar = V.rowwise().norm();
  RenderOptions o;
  o.edges = true;
  o.supersample = 2;
  const Image a = renderSurface(V, F, c, o);
  const Image b = renderSurface(V, F, c, o);
  EXPECT_EQ(a.pixels, b.pixels);
  o.azimuthDeg += 1;
  EXPECT_NE(renderSurface(V, F, c, o).pixels, a.pixels);
}

TEST(Render, EmptyMeshGivesBackground) {
  RenderOptions o;
  o.width = 32;
  o.height = 16;
  const Image im = renderSurface(Eigen::MatrixX3d(0, 3), Eigen::MatrixX3i(0, 3), {}, o);
  EXPECT_EQ(countNot(im, o.background), 0u);
}

TEST(Render, BadInputNamesTheFunction) {
  Eigen::MatrixX3d V;
  Eigen::MatrixX3i F;
  unitCube(V, F);
  auto expectThrow = [](const std::function<void()>& f, const std::string& what) {
    try {
      f();
      ADD_FAILURE() << "no exception; expected " << what;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("renderSurface"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  Eigen::MatrixX3i badF = F;
  badF(3, 1) = 8;
  expectThrow([&] { renderSurface(V, badF); }, "indices");
  SurfaceColors c;
  c.vertexScalar = Eigen::VectorXd::Zero(7);
  expectThrow([&] { renderSurface(V, F, c); }, "vertexScalar");
  c.vertexScalar = Eigen::VectorXd::Zero(8);
  c.faceLabel = Eigen::VectorXi::Zero(12);
  expectThrow([&] { renderSurface(V, F, c); }, "at most one");
  RenderOptions o;
  o.width = 0;
  expectThrow([&] { renderSurface(V, F, {}, o); }, "image size");
  Eigen::MatrixX3d nanV = V;
  nanV(2, 2) = NAN;
  expectThrow([&] { renderSurface(nanV, F); }, "non-finite");
}

TEST(TetCut, BoundaryOfKeptTetsIsClosedAndOutward) {
  Eigen::MatrixX3d V;
  Eigen::MatrixX4i T;
  tetGrid(2, V, T);  // [0,2]^3, 48 tets
  // No cut: the cube's surface, 2 triangles per unit square, 4 squares per side.
  ClipPlane far;
  far.point = Eigen::Vector3d(10, 0, 0);
  far.normal = Eigen::Vector3d(1, 0, 0);
  const TetCutFaces all = clippedTetBoundary(V, T, far);
  EXPECT_EQ(all.F.rows(), 6 * 4 * 2);
  expectClosedOriented(all.F);
  // Outward: each face's normal points away from its tet's centroid.
  for (Eigen::Index i = 0; i < all.F.rows(); ++i) {
    const Eigen::Vector3d a = V.row(all.F(i, 0)), b = V.row(all.F(i, 1)), c = V.row(all.F(i, 2));
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (int k = 0; k < 4; ++k) centroid += V.row(T(all.tet[i], k)).transpose() / 4;
    EXPECT_GT((b - a).cross(c - a).dot(a - centroid), 0) << "face " << i;
  }
  // Cut at x = 1: the half-cube [0,1]×[0,2]^2, its cut face made of tet faces in x = 1.
  ClipPlane half;
  half.point = Eigen::Vector3d(1, 0, 0);
  half.normal = Eigen::Vector3d(2, 0, 0);
  const TetCutFaces cut = clippedTetBoundary(V, T, half);
  expectClosedOriented(cut.F);
  int onCut = 0;
  for (Eigen::Index i = 0; i < cut.F.rows(); ++i) {
    EXPECT_LT(V.row(cut.F(i, 0)).x() + V.row(cut.F(i, 1)).x() + V.row(cut.F(i, 2)).x(), 3.0 + 1e-12);
    for (int k = 0; k < 4; ++k) EXPECT_LE(V(T(cut.tet[i], k), 0), 1.0);
    onCut += V(cut.F(i, 0), 0) == 1 && V(cut.F(i, 1), 0) == 1 && V(cut.F(i, 2), 0) == 1;
  }
  EXPECT_EQ(onCut, 4 * 2);
  EXPECT_EQ(cut.F.rows(), 8 + 8 + 4 * 4);  // x = 0 and x = 1 sides: 4 squares; y and z sides: 2 squares each
}

TEST(TetCut, RenderShowsRegionsOnTheCut) {
  Eigen::MatrixX3d V;
  Eigen::MatrixX4i T;
  tetGrid(2, V, T);
  TetColors colors;
  colors.tetLabel.resize(T.rows());
  for (Eigen::Index t = 0; t < T.rows(); ++t) {
    const double z = (V(T(t, 0), 2) + V(T(t, 1), 2) + V(T(t, 2), 2) + V(T(t, 3), 2)) / 4;
    colors.tetLabel[t] = z < 1 ? 1 : 2;
  }
  ClipPlane plane;
  plane.point = Eigen::Vector3d(1, 1, 1);
  plane.normal = Eigen::Vector3d(1, 0, 0);
  RenderOptions o;
  o.azimuthDeg = 0;  // looking from +x, at the cut face x = 1
  o.elevationDeg = 0;
  o.width = o.height = 120;
  o.supersample = 1;
  const Image im = renderTetCut(V, T, plane, colors, o);
  // Upper half region 2, lower half region 1, both facing the light.
  EXPECT_EQ(pixel(im, 60, 30), categoricalColor(2));
  EXPECT_EQ(pixel(im, 60, 90), categoricalColor(1));
  // The uncut mesh with the same options is framed identically (view fitted to all of V).
  ClipPlane none;
  none.point = Eigen::Vector3d(9, 0, 0);
  const Image whole = renderSurface(V, clippedTetBoundary(V, T, none).F, {}, o);
  EXPECT_EQ(countNot(im, o.background), countNot(whole, o.background));
  TetColors bad;
  bad.tetScalar = Eigen::VectorXd::Zero(3);
  EXPECT_THROW(renderTetCut(V, T, plane, bad, o), std::invalid_argument);
}

TEST(ColorMaps, EndsAndPalette) {
  EXPECT_EQ(colorMapColor(ColorMap::Viridis, 0), (Rgb{68, 1, 84}));
  EXPECT_EQ(colorMapColor(ColorMap::Viridis, 1), (Rgb{253, 231, 37}));
  EXPECT_EQ(colorMapColor(ColorMap::Viridis, -3), colorMapColor(ColorMap::Viridis, 0));
  EXPECT_EQ(colorMapColor(ColorMap::Viridis, 7), colorMapColor(ColorMap::Viridis, 1));
  const Rgb w = colorMapColor(ColorMap::Diverging, 0.5);
  EXPECT_GT(std::min({w.r, w.g, w.b}), 240);
  // Luminance of viridis increases with t.
  double prev = -1;
  for (int i = 0; i <= 50; ++i) {
    const Rgb c = colorMapColor(ColorMap::Viridis, i / 50.0);
    const double lum = 0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b;
    EXPECT_GT(lum, prev);
    prev = lum;
  }
  EXPECT_EQ(categoricalColor(3), categoricalColor(13));
  EXPECT_EQ(categoricalColor(-1), categoricalColor(9));
  EXPECT_NE(categoricalColor(1), categoricalColor(2));
}

TEST(ColorBar, SvgHasTicksAndEscapedLabel) {
  const std::string svg = colorBarSvg(ColorMap::Viridis, 0.5, 2.0, "ratio <a&b>");
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_NE(svg.find("ratio &lt;a&amp;b&gt;"), std::string::npos);
  EXPECT_EQ(svg.find("<a&b>"), std::string::npos);
  EXPECT_NE(svg.find("linearGradient"), std::string::npos);
  EXPECT_NE(svg.find(">1<"), std::string::npos);
  EXPECT_NE(svg.find(">1.5<"), std::string::npos);
  EXPECT_EQ(svg.find("http"), std::string::npos);
}

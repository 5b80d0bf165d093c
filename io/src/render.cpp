// Software renderer for the report (see render.h).
#include "tet2spline/io/render.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <functional>
#include <sstream>
#include <stdexcept>

#include "svg_util.h"

namespace tet2spline {

namespace {

constexpr double kPi = 3.14159265358979323846;

// matplotlib's viridis at t = 0, 0.1, ..., 1 (interpolated linearly in between).
constexpr std::array<Rgb, 11> kViridis = {{{68, 1, 84},
                                           {72, 36, 117},
                                           {65, 68, 135},
                                           {53, 95, 141},
                                           {42, 120, 142},
                                           {33, 145, 140},
                                           {34, 168, 132},
                                           {68, 191, 112},
                                           {122, 209, 81},
                                           {189, 223, 38},
                                           {253, 231, 37}}};
// Blue → near-white → red (ColorBrewer RdBu, reversed), 9 stops.
constexpr std::array<Rgb, 9> kDiverging = {{{33, 102, 172},
                                            {67, 147, 195},
                                            {146, 197, 222},
                                            {209, 229, 240},
                                            {247, 247, 247},
                                            {253, 219, 199},
                                            {244, 165, 130},
                                            {214, 96, 77},
                                            {178, 24, 43}}};
// Tableau 10.
constexpr std::array<Rgb, 10> kCategorical = {{{78, 121, 167},
                                               {242, 142, 43},
                                               {225, 87, 89},
                                               {118, 183, 178},
                                               {89, 161, 79},
                                               {237, 201, 72},
                                               {176, 122, 161},
                                               {255, 157, 167},
                                               {156, 117, 95},
                                               {186, 176, 172}}};

template <size_t N>
Rgb piecewise(const std::array<Rgb, N>& stops, double t) {
  t = std::clamp(t, 0.0, 1.0) * double(N - 1);
  const size_t i = std::min(size_t(t), N - 2);
  const double f = t - double(i);
  auto mix = [f](uint8_t a, uint8_t b) { return uint8_t(std::lround(a + (double(b) - a) * f)); };
  return {mix(stops[i].r, stops[i + 1].r), mix(stops[i].g, stops[i + 1].g), mix(stops[i].b, stops[i + 1].b)};
}

void requireFinite(const Eigen::MatrixX3d& V, const char* fn) {
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    if (!V.row(i).allFinite())
      throw std::invalid_argument(std::string(fn) + ": vertex " + std::to_string(i) + " has a non-finite coordinate");
}

struct View {
  Eigen::Vector3d d, right, up;
  double scale = 1, cx = 0, cy = 0, midR = 0, midU = 0;
  Eigen::Vector3d project(const Eigen::Vector3d& p) const {  // sample-space x, y (down), depth (towards eye)
    return {cx + scale * (p.dot(right) - midR), cy - scale * (p.dot(up) - midU), p.dot(d)};
  }
};

View fitView(const Eigen::MatrixX3d& V, const RenderOptions& o, int W, int H, int ss) {
  const int u = o.upAxis;
  Eigen::Vector3d e1 = Eigen::Vector3d::Unit((u + 1) % 3), e2 = Eigen::Vector3d::Unit((u + 2) % 3),
                  eu = Eigen::Vector3d::Unit(u);
  const double az = o.azimuthDeg * kPi / 180, el = o.elevationDeg * kPi / 180;
  View v;
  v.d = std::cos(el) * std::cos(az) * e1 + std::cos(el) * std::sin(az) * e2 + std::sin(el) * eu;
  Eigen::Vector3d r = eu.cross(v.d);
  // Looking straight down the up axis: keep the azimuth's notion of "right".
  if (r.norm() < 1e-9) r = -std::sin(az) * e1 + std::cos(az) * e2;
  v.right = r.normalized();
  v.up = v.d.cross(v.right).normalized();
  double rMin = std::numeric_limits<double>::infinity(), rMax = -rMin, uMin = rMin, uMax = -rMin;
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    const Eigen::Vector3d p = V.row(i).transpose();
    rMin = std::min(rMin, p.dot(v.right));
    rMax = std::max(rMax, p.dot(v.right));
    uMin = std::min(uMin, p.dot(v.up));
    uMax = std::max(uMax, p.dot(v.up));
  }
  if (V.rows() == 0) rMin = rMax = uMin = uMax = 0;
  const double marginPx = o.margin * std::min(o.width, o.height) * ss;
  const double availW = W - 2 * marginPx, availH = H - 2 * marginPx;
  const double extR = rMax - rMin, extU = uMax - uMin;
  double s = std::numeric_limits<double>::infinity();
  if (extR > 0) s = std::min(s, availW / extR);
  if (extU > 0) s = std::min(s, availH / extU);
  if (!std::isfinite(s)) s = 1;
  v.scale = s;
  v.cx = 0.5 * W;
  v.cy = 0.5 * H;
  v.midR = 0.5 * (rMin + rMax);
  v.midU = 0.5 * (uMin + uMax);
  return v;
}

void validateOptions(const RenderOptions& o, const char* fn) {
  auto bad = [fn](const std::string& why) { throw std::invalid_argument(std::string(fn) + ": " + why); };
  if (o.width <= 0 || o.height <= 0 || o.width > 16384 || o.height > 16384)
    bad("image size " + std::to_string(o.width) + "x" + std::to_string(o.height) + " not in 1..16384");
  if (o.supersample < 1 || o.supersample > 8) bad("supersample " + std::to_string(o.supersample) + " not in 1..8");
  if (o.upAxis < 0 || o.upAxis > 2) bad("upAxis " + std::to_string(o.upAxis) + " not in 0..2");
  if (!(o.margin >= 0 && o.margin < 0.5)) bad("margin must be in [0, 0.5)");
  if (!std::isfinite(o.azimuthDeg) || !std::isfinite(o.elevationDeg)) bad("non-finite view angle");
}

}  // namespace

Rgb colorMapColor(ColorMap map, double t) {
  if (map == ColorMap::Categorical) return std::isfinite(t) ? categoricalColor(int(std::lround(t))) : Rgb{128, 128, 128};
  if (std::isnan(t)) return {128, 128, 128};
  return map == ColorMap::Diverging ? piecewise(kDiverging, t) : piecewise(kViridis, t);
}

Rgb categoricalColor(int label) { return kCategorical[size_t((((label - 1) % 10) + 10) % 10)]; }

Image renderSurface(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, const SurfaceColors& colors,
                    const RenderOptions& o) {
  const char* fn = "renderSurface";
  validateOptions(o, fn);
  requireFinite(V, fn);
  const Eigen::Index nV = V.rows(), nF = F.rows();
  if (nF > 0 && (F.minCoeff() < 0 || F.maxCoeff() >= nV))
    throw std::invalid_argument(std::string(fn) + ": F holds indices outside 0.." + std::to_string(nV - 1));
  const int given = int(colors.vertexScalar.size() > 0) + int(colors.faceScalar.size() > 0) +
                    int(colors.faceLabel.size() > 0);
  if (given > 1) throw std::invalid_argument(std::string(fn) + ": give at most one of vertexScalar, faceScalar, faceLabel");
  if (colors.vertexScalar.size() > 0 && colors.vertexScalar.size() != nV)
    throw std::invalid_argument(std::string(fn) + ": vertexScalar has " + std::to_string(colors.vertexScalar.size()) +
                                " values for " + std::to_string(nV) + " vertices");
  if (colors.faceScalar.size() > 0 && colors.faceScalar.size() != nF)
    throw std::invalid_argument(std::string(fn) + ": faceScalar has " + std::to_string(colors.faceScalar.size()) +
                                " values for " + std::to_string(nF) + " triangles");
  if (colors.faceLabel.size() > 0 && colors.faceLabel.size() != nF)
    throw std::invalid_argument(std::string(fn) + ": faceLabel has " + std::to_string(colors.faceLabel.size()) +
                                " values for " + std::to_string(nF) + " triangles");

  const int ss = o.supersample;
  const int W = o.width * ss, H = o.height * ss;
  const View view = fitView(V, o, W, H, ss);

  // Scalar range.
  const Eigen::VectorXd* scalar = colors.vertexScalar.size() ? &colors.vertexScalar
                                  : colors.faceScalar.size() ? &colors.faceScalar
                                                             : nullptr;
  double sMin = o.scalarMin, sMax = o.scalarMax;
  if (scalar && !(sMin < sMax)) {
    sMin = std::numeric_limits<double>::infinity();
    sMax = -sMin;
    for (Eigen::Index i = 0; i < scalar->size(); ++i)
      if (std::isfinite((*scalar)[i])) {
        sMin = std::min(sMin, (*scalar)[i]);
        sMax = std::max(sMax, (*scalar)[i]);
      }
    if (!(sMin <= sMax)) sMin = 0, sMax = 1;
    if (sMin == sMax) sMin -= 0.5, sMax += 0.5;
  }
  auto scalarColor = [&](double s) -> Rgb {
    if (!std::isfinite(s)) return o.nanColor;
    if (o.colorMap == ColorMap::Categorical) return colorMapColor(o.colorMap, s);
    return colorMapColor(o.colorMap, (s - sMin) / (sMax - sMin));
  };

  // Projected vertices and face normals (unnormalised: twice the area).
  std::vector<Eigen::Vector3d> P(static_cast<size_t>(nV));
  for (Eigen::Index i = 0; i < nV; ++i) P[size_t(i)] = view.project(V.row(i).transpose());
  std::vector<Eigen::Vector3d> faceN(static_cast<size_t>(nF));
  for (Eigen::Index f = 0; f < nF; ++f) {
    const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    faceN[size_t(f)] = (b - a).cross(c - a);
  }

  // Corner normals: area-weighted average over the faces around the corner's vertex
  // whose normal is within the crease angle of this face's normal.
  std::vector<Eigen::Vector3d> cornerN(static_cast<size_t>(nF) * 3);
  {
    std::vector<int> start(size_t(nV) + 1, 0), incident(size_t(nF) * 3);
    for (Eigen::Index f = 0; f < nF; ++f)
      for (int k = 0; k < 3; ++k) ++start[size_t(F(f, k)) + 1];
    for (size_t i = 0; i < size_t(nV); ++i) start[i + 1] += start[i];
    std::vector<int> fill(start.begin(), start.end() - 1);
    for (Eigen::Index f = 0; f < nF; ++f)
      for (int k = 0; k < 3; ++k) incident[size_t(fill[size_t(F(f, k))]++)] = int(f);
    const double cosCrease = std::cos(std::clamp(o.creaseAngleDeg, 0.0, 180.0) * kPi / 180);
    for (Eigen::Index f = 0; f < nF; ++f) {
      const double nf = faceN[size_t(f)].norm();
      const Eigen::Vector3d unitF = nf > 0 ? Eigen::Vector3d(faceN[size_t(f)] / nf) : Eigen::Vector3d::Zero();
      for (int k = 0; k < 3; ++k) {
        Eigen::Vector3d sum = faceN[size_t(f)];
        if (o.creaseAngleDeg > 0 && nf > 0) {
          const int v = F(f, k);
          for (int j = start[size_t(v)]; j < start[size_t(v) + 1]; ++j) {
            const int g = incident[size_t(j)];
            if (g == f) continue;
            const double ng = faceN[size_t(g)].norm();
            if (ng > 0 && unitF.dot(faceN[size_t(g)]) >= cosCrease * ng) sum += faceN[size_t(g)];
          }
        }
        const double n = sum.norm();
        cornerN[size_t(f) * 3 + size_t(k)] = n > 0 ? Eigen::Vector3d(sum / n) : unitF;
      }
    }
  }

  // Visibility pass: nearest face and its barycentrics per sample.
  const size_t nSamples = size_t(W) * size_t(H);
  std::vector<double> depth(nSamples, -std::numeric_limits<double>::infinity());
  std::vector<int> faceAt(nSamples, -1);
  std::vector<std::array<float, 2>> bary(nSamples);
  for (Eigen::Index f = 0; f < nF; ++f) {
    const Eigen::Vector3d& a = P[size_t(F(f, 0))];
    const Eigen::Vector3d& b = P[size_t(F(f, 1))];
    const Eigen::Vector3d& c = P[size_t(F(f, 2))];
    const double area2 = (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
    if (std::abs(area2) < 1e-12) continue;
    const int x0 = std::max(0, int(std::floor(std::min({a.x(), b.x(), c.x()}) - 0.5)));
    const int x1 = std::min(W - 1, int(std::ceil(std::max({a.x(), b.x(), c.x()}) - 0.5)));
    const int y0 = std::max(0, int(std::floor(std::min({a.y(), b.y(), c.y()}) - 0.5)));
    const int y1 = std::min(H - 1, int(std::ceil(std::max({a.y(), b.y(), c.y()}) - 0.5)));
    const double inv = 1.0 / area2;
    for (int y = y0; y <= y1; ++y) {
      const double py = y + 0.5;
      for (int x = x0; x <= x1; ++x) {
        const double px = x + 0.5;
        const double w0 = ((b.x() - px) * (c.y() - py) - (b.y() - py) * (c.x() - px)) * inv;
        const double w1 = ((c.x() - px) * (a.y() - py) - (c.y() - py) * (a.x() - px)) * inv;
        const double w2 = 1 - w0 - w1;
        if (w0 < 0 || w1 < 0 || w2 < 0) continue;
        const double z = w0 * a.z() + w1 * b.z() + w2 * c.z();
        const size_t s = size_t(y) * size_t(W) + size_t(x);
        if (z > depth[s]) {
          depth[s] = z;
          faceAt[s] = int(f);
          bary[s] = {float(w0), float(w1)};
        }
      }
    }
  }

  // Shading pass, then box-filter the samples down to pixels.
  const double halfLine = 0.5 * o.edgeWidth * ss;
  auto shade = [&](size_t s) -> std::array<double, 3> {
    const int f = faceAt[s];
    if (f < 0) return {double(o.background.r), double(o.background.g), double(o.background.b)};
    const double w0 = bary[s][0], w1 = bary[s][1], w2 = 1 - w0 - w1;
    const std::array<double, 3> w = {w0, w1, w2};
    Rgb base = o.baseColor;
    if (colors.faceLabel.size()) base = categoricalColor(colors.faceLabel[f]);
    else if (colors.faceScalar.size()) base = scalarColor(colors.faceScalar[f]);
    else if (colors.vertexScalar.size()) {
      double v = 0;
      for (int k = 0; k < 3; ++k) v += w[size_t(k)] * colors.vertexScalar[F(f, k)];
      base = scalarColor(v);
    }
    Eigen::Vector3d n = Eigen::Vector3d::Zero();
    for (int k = 0; k < 3; ++k) n += w[size_t(k)] * cornerN[size_t(f) * 3 + size_t(k)];
    const double nn = n.norm();
    const double lambert = nn > 0 ? std::abs(n.dot(view.d)) / nn : 1.0;
    const double light = o.ambient + (1 - o.ambient) * lambert;
    std::array<double, 3> rgb = {base.r * light, base.g * light, base.b * light};
    if (o.edges) {
      // Distance (in samples) from the sample to each edge: w_k · |area2| / |edge opposite k|.
      const Eigen::Vector3d* p[3] = {&P[size_t(F(f, 0))], &P[size_t(F(f, 1))], &P[size_t(F(f, 2))]};
      const double area2 = std::abs(((*p[1]).x() - (*p[0]).x()) * ((*p[2]).y() - (*p[0]).y()) -
                                    ((*p[1]).y() - (*p[0]).y()) * ((*p[2]).x() - (*p[0]).x()));
      double dist = std::numeric_limits<double>::infinity();
      for (int k = 0; k < 3; ++k) {
        const Eigen::Vector3d& e0 = *p[(k + 1) % 3];
        const Eigen::Vector3d& e1 = *p[(k + 2) % 3];
        const double len = std::hypot(e1.x() - e0.x(), e1.y() - e0.y());
        if (len > 0) dist = std::min(dist, w[size_t(k)] * area2 / len);
      }
      if (dist < halfLine) {
        const double a = o.edgeOpacity;
        rgb = {rgb[0] * (1 - a) + o.edgeColor.r * a, rgb[1] * (1 - a) + o.edgeColor.g * a,
               rgb[2] * (1 - a) + o.edgeColor.b * a};
      }
    }
    return rgb;
  };

  Image image(o.width, o.height, 3);
  const double norm = 1.0 / double(ss * ss);
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x) {
      std::array<double, 3> sum = {0, 0, 0};
      for (int sy = 0; sy < ss; ++sy)
        for (int sx = 0; sx < ss; ++sx) {
          const auto c = shade(size_t(y * ss + sy) * size_t(W) + size_t(x * ss + sx));
          for (int k = 0; k < 3; ++k) sum[size_t(k)] += c[size_t(k)];
        }
      uint8_t* px = image.at(x, y);
      for (int k = 0; k < 3; ++k) px[k] = uint8_t(std::clamp(std::lround(sum[size_t(k)] * norm), 0L, 255L));
    }
  return image;
}

TetCutFaces clippedTetBoundary(const Eigen::MatrixX3d& V, const Eigen::MatrixX4i& T, const ClipPlane& plane) {
  if (T.rows() > 0 && (T.minCoeff() < 0 || T.maxCoeff() >= V.rows()))
    throw std::invalid_argument("clippedTetBoundary: T holds indices outside 0.." + std::to_string(V.rows() - 1));
  if (!plane.point.allFinite() || !plane.normal.allFinite() || plane.normal.norm() == 0)
    throw std::invalid_argument("clippedTetBoundary: the plane needs a finite point and a non-zero normal");
  // Face k is opposite vertex k, oriented outward for a positively oriented tet.
  static const int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  struct Entry {
    std::array<int, 3> key;
    int index;  // 4 * tet + local face
  };
  std::vector<Entry> entries;
  for (Eigen::Index t = 0; t < T.rows(); ++t) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (int k = 0; k < 4; ++k) c += V.row(T(t, k)).transpose();
    c /= 4;
    if ((c - plane.point).dot(plane.normal) > 0) continue;
    for (int k = 0; k < 4; ++k) {
      std::array<int, 3> key = {T(t, kFace[k][0]), T(t, kFace[k][1]), T(t, kFace[k][2])};
      std::sort(key.begin(), key.end());
      entries.push_back({key, int(4 * t + k)});
    }
  }
  // (keys compared entry by entry: std::array's operators went through
  // memcmp calls, a quarter of the report's rendering time on bunny00)
  auto sameKey = [](const Entry& a, const Entry& b) {
    return a.key[0] == b.key[0] && a.key[1] == b.key[1] && a.key[2] == b.key[2];
  };
  std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
    if (a.key[0] != b.key[0]) return a.key[0] < b.key[0];
    if (a.key[1] != b.key[1]) return a.key[1] < b.key[1];
    if (a.key[2] != b.key[2]) return a.key[2] < b.key[2];
    return a.index < b.index;
  });
  std::vector<int> boundary;
  for (size_t i = 0; i < entries.size();) {
    size_t j = i + 1;
    while (j < entries.size() && sameKey(entries[j], entries[i])) ++j;
    if (j == i + 1) boundary.push_back(entries[i].index);
    i = j;
  }
  std::sort(boundary.begin(), boundary.end());
  TetCutFaces out;
  out.F.resize(Eigen::Index(boundary.size()), 3);
  out.tet.resize(Eigen::Index(boundary.size()));
  for (size_t i = 0; i < boundary.size(); ++i) {
    const int t = boundary[i] / 4, k = boundary[i] % 4;
    for (int j = 0; j < 3; ++j) out.F(Eigen::Index(i), j) = T(t, kFace[k][j]);
    out.tet[Eigen::Index(i)] = t;
  }
  return out;
}

Image renderTetCut(const Eigen::MatrixX3d& V, const Eigen::MatrixX4i& T, const ClipPlane& plane,
                   const TetColors& colors, const RenderOptions& options) {
  const char* fn = "renderTetCut";
  const int given = int(colors.vertexScalar.size() > 0) + int(colors.tetScalar.size() > 0) +
                    int(colors.tetLabel.size() > 0);
  if (given > 1) throw std::invalid_argument(std::string(fn) + ": give at most one of vertexScalar, tetScalar, tetLabel");
  if (colors.tetScalar.size() > 0 && colors.tetScalar.size() != T.rows())
    throw std::invalid_argument(std::string(fn) + ": tetScalar has " + std::to_string(colors.tetScalar.size()) +
                                " values for " + std::to_string(T.rows()) + " tets");
  if (colors.tetLabel.size() > 0 && colors.tetLabel.size() != T.rows())
    throw std::invalid_argument(std::string(fn) + ": tetLabel has " + std::to_string(colors.tetLabel.size()) +
                                " values for " + std::to_string(T.rows()) + " tets");
  const TetCutFaces cut = clippedTetBoundary(V, T, plane);
  SurfaceColors sc;
  sc.vertexScalar = colors.vertexScalar;
  if (colors.tetScalar.size()) {
    sc.faceScalar.resize(cut.tet.size());
    for (Eigen::Index i = 0; i < cut.tet.size(); ++i) sc.faceScalar[i] = colors.tetScalar[cut.tet[i]];
  }
  if (colors.tetLabel.size()) {
    sc.faceLabel.resize(cut.tet.size());
    for (Eigen::Index i = 0; i < cut.tet.size(); ++i) sc.faceLabel[i] = colors.tetLabel[cut.tet[i]];
  }
  return renderSurface(V, cut.F, sc, options);
}

std::string colorBarSvg(ColorMap map, double min, double max, const std::string& label, int width, int height) {
  width = std::max(width, 80);
  height = std::max(height, 40);
  const double padX = 12, barY = 18, barH = std::max(8.0, height - 36.0), barW = width - 2 * padX;
  std::ostringstream s;
  // The gradient id is derived from the content so several bars on a page do not clash.
  const std::string id = "cb" + std::to_string(std::hash<std::string>{}(label + svg::number(min) + svg::number(max) +
                                                                        std::to_string(int(map))) % 1000000007u);
  s << "<svg class=\"colorbar\" width=\"" << width << "\" height=\"" << height
    << "\" viewBox=\"0 0 " << width << ' ' << height << "\" role=\"img\">";
  s << "<text x=\"" << padX << "\" y=\"12\" font-size=\"12\" fill=\"#334\">" << svg::escape(label) << "</text>";
  if (map == ColorMap::Categorical) {
    s << "</svg>";
    return s.str();
  }
  s << "<defs><linearGradient id=\"" << id << "\" x1=\"0\" x2=\"1\" y1=\"0\" y2=\"0\">";
  for (int i = 0; i <= 20; ++i) {
    const Rgb c = colorMapColor(map, i / 20.0);
    char hex[8];
    std::snprintf(hex, sizeof hex, "#%02x%02x%02x", c.r, c.g, c.b);
    s << "<stop offset=\"" << svg::coord(i / 20.0) << "\" stop-color=\"" << hex << "\"/>";
  }
  s << "</linearGradient></defs>";
  s << "<rect x=\"" << padX << "\" y=\"" << barY << "\" width=\"" << svg::coord(barW) << "\" height=\"" << barH
    << "\" fill=\"url(#" << id << ")\" stroke=\"#667\" stroke-width=\"0.5\"/>";
  if (min < max) {
    for (const double t : svg::niceTicks(min, max, 5)) {
      const double x = padX + barW * (t - min) / (max - min);
      s << "<line x1=\"" << svg::coord(x) << "\" x2=\"" << svg::coord(x) << "\" y1=\"" << barY + barH << "\" y2=\""
        << barY + barH + 4 << "\" stroke=\"#445\"/>";
      s << "<text x=\"" << svg::coord(x) << "\" y=\"" << barY + barH + 15
        << "\" font-size=\"11\" text-anchor=\"middle\" fill=\"#445\">" << svg::number(t, 6) << "</text>";
    }
  }
  s << "</svg>";
  return s.str();
}

}  // namespace tet2spline

#include "html_stage.h"

#include <cmath>
#include <cstdio>
#include <future>
#include <map>

#include "tet2spline/io/html_report.h"
#include "tet2spline/io/render.h"
#include "tet2spline/spline/bspline_volume.h"

namespace tet2spline::cli {
namespace {

std::string fmt(const json& v) {
  if (v.is_number_integer()) return std::to_string(v.get<long long>());
  if (v.is_number()) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.4g", v.get<double>());
    return buf;
  }
  if (v.is_boolean()) return v.get<bool>() ? "yes" : "no";
  if (v.is_string()) return v.get<std::string>();
  return v.dump();
}

// The value at a dotted path, or null.
json at(const json& j, const std::string& path) {
  const json* node = &j;
  size_t start = 0;
  while (true) {
    const size_t dot = path.find('.', start);
    const std::string key = path.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    if (!node->is_object() || !node->contains(key)) return nullptr;
    node = &(*node)[key];
    if (dot == std::string::npos) return *node;
    start = dot + 1;
  }
}

ReportSection section(const json& j, const std::string& title,
                      const std::vector<std::pair<std::string, std::string>>& keys) {
  ReportSection s{title, {}};
  for (const auto& [label, key] : keys) {
    const json v = at(j, key);
    if (!v.is_null()) s.figures.emplace_back(label, fmt(v), key);
  }
  return s;
}

// Boundary of the spline: each of the six faces sampled n × n, triangulated.
void splineSurface(const spline::BSplineVolume& volume, int n, Eigen::MatrixX3d& V, Eigen::MatrixX3i& F,
                   Eigen::VectorXd& detJ) {
  V.resize(6 * n * n, 3);
  F.resize(6 * 2 * (n - 1) * (n - 1), 3);
  detJ.resize(6 * n * n);
  const Eigen::Vector3d lo = volume.parameterMin(), hi = volume.parameterMax();
  int f = 0;
  for (int face = 0; face < 6; ++face) {
    const int axis = face / 2, a = (axis + 1) % 3, b = (axis + 2) % 3;
    const int base = face * n * n;
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        Eigen::Vector3d u;
        u(axis) = face % 2 ? hi(axis) : lo(axis);
        // Stay a hair inside so that det J at the cube's edges (0 there) does not dominate the colours.
        const double s = 0.002 + 0.996 * i / (n - 1.0), t = 0.002 + 0.996 * j / (n - 1.0);
        u(a) = lo(a) + s * (hi(a) - lo(a));
        u(b) = lo(b) + t * (hi(b) - lo(b));
        V.row(base + j * n + i) = volume.evaluate(u).transpose();
        detJ(base + j * n + i) = volume.scaledJacobian(u);
      }
    const bool flip = face % 2 == 0;
    for (int j = 0; j + 1 < n; ++j)
      for (int i = 0; i + 1 < n; ++i) {
        const int p = base + j * n + i, q = p + 1, r = p + n, s = p + n + 1;
        if (flip) {
          F.row(f++) << p, r, q;
          F.row(f++) << q, r, s;
        } else {
          F.row(f++) << p, q, r;
          F.row(f++) << q, s, r;
        }
      }
  }
}

}  // namespace

void writeRunHtml(const json& report, const ParamResult* param, const spline::BSplineVolume* volume,
                  const std::string& inputPath, const std::string& path) {
  HtmlReport h;
  h.inputPath = inputPath;
  h.generator = "tet2spline 0.1.0";
  const long negative = at(report, "jacobian.negative_gauss_points").is_null()
                            ? -1
                            : at(report, "jacobian.negative_gauss_points").get<long>();
  const int inverted = at(report, "param.inverted_tets").is_null() ? 0 : at(report, "param.inverted_tets").get<int>();
  if (volume) {
    h.verdict = negative == 0 ? "valid spline: no negative Jacobian at any Gauss point"
                              : std::to_string(negative) + " Gauss points with det J <= 0";
    h.verdictLevel = negative == 0 ? ReportVerdict::Ok : ReportVerdict::Failure;
  } else {
    h.verdict = inverted == 0 ? "bijective parameterization: no inverted tet" : std::to_string(inverted) + " inverted tets";
    h.verdictLevel = inverted == 0 ? ReportVerdict::Ok : ReportVerdict::Failure;
  }
  if (report.contains("warnings"))
    for (const auto& w : report["warnings"]) h.warnings.push_back(w.get<std::string>());

  h.sections.push_back(section(report, "Input", {{"vertices", "vertices"}, {"tets", "tets"}, {"genus", "genus"},
                                                  {"voids", "voids"}, {"input", "input_kind"}}));
  h.sections.push_back(section(report, "Ball map", {{"flipped sphere triangles", "sphere.flipped_triangles"},
                                                     {"angle distortion (mean)", "sphere.angle_distortion_mean"},
                                                     {"angle distortion (max)", "sphere.angle_distortion_max"},
                                                     {"inverted before untangling", "ball.inverted_tets_before_untangling"},
                                                     {"inverted tets", "ball.inverted_tets"},
                                                     {"harmonic residual", "ball.harmonic_residual"},
                                                     {"volume ratio p1 (transport's start)", "ball.volume_ratio.p1"},
                                                     {"volume ratio p99 (transport's start)", "ball.volume_ratio.p99"}}));
  h.sections.push_back(section(report, "Optimal transport", {{"Newton iterations", "ot.iterations"},
                                                              {"max relative mass error", "ot.max_relative_mass_error"},
                                                              {"linear solver", "ot.linear_solver"}}));
  h.sections.push_back(section(report, "Parameterization", {{"domain", "param.domain_representation"},
                                                              {"vertices", "param.vertices"},
                                                              {"inverted tets", "param.inverted_tets"},
                                                              {"boundary distance to ∂Ω", "param.boundary_max_distance"},
                                                              {"volume ratio p1", "param.volume_ratio.p1"},
                                                              {"volume ratio p50", "param.volume_ratio.p50"},
                                                              {"volume ratio p99", "param.volume_ratio.p99"},
                                                              {"misplaced volume (8³ cells)", "param.misplaced_volume"}}));
  h.sections.push_back(section(report, "Spline", {{"degree", "spline.degree"},
                                                   {"control points", "spline.control_points"},
                                                   {"RMS error / diagonal", "fit.rms_error_relative"},
                                                   {"max error / diagonal", "fit.max_error_relative"},
                                                   {"boundary Hausdorff / diagonal", "fit.boundary_hausdorff_relative"},
                                                   {"negative Gauss points", "jacobian.negative_gauss_points"},
                                                   {"min scaled Jacobian", "jacobian.min_scaled"}}));
  for (auto it = h.sections.begin(); it != h.sections.end();)
    it = it->figures.empty() ? h.sections.erase(it) : it + 1;

  if (report.contains("regions"))
    for (const auto& r : report["regions"]) {
      ReportRegion g;
      g.id = r.value("id", 0);
      g.targetVolumeFraction = r.value("target_volume_fraction", 0.0);
      g.achievedVolumeFraction = r.value("achieved_volume_fraction", 0.0);
      g.elementsPerVolume = r.value("elements_per_volume", 0.0);
      g.isVoid = r.value("void", false);
      h.regions.push_back(g);
    }
  if (report.contains("timings"))
    for (const auto& [stage, seconds] : report["timings"].items())
      if (seconds.is_number()) h.timings.push_back({stage, seconds.get<double>()});

  RenderOptions ro;
  ro.width = 640;
  ro.height = 480;
  // The three pictures are independent: the spline's boundary is drawn on a
  // thread of its own from here, the parameterization's cut on another
  // while this one draws the solid's cut.
  std::future<ReportImage> splinePicture;
  if (volume)
    splinePicture = std::async(std::launch::async, [volume, ro] {
      Eigen::MatrixX3d V;
      Eigen::MatrixX3i F;
      Eigen::VectorXd sj;
      splineSurface(*volume, 48, V, F, sj);
      SurfaceColors colors;
      colors.vertexScalar = sj;
      RenderOptions so = ro;
      so.scalarMin = 0;
      so.scalarMax = 1;
      ReportImage pic("the spline's boundary, coloured by the scaled Jacobian", renderSurface(V, F, colors, so));
      pic.hasColorBar = true;
      pic.scalarMin = 0;
      pic.scalarMax = 1;
      pic.scalarLabel = "scaled Jacobian";
      return pic;
    });
  if (param) {
    const Eigen::Index nt = param->mesh.numTets();
    std::vector<double> ratios(static_cast<size_t>(nt));
    Eigen::VectorXd logRatio(nt);
    for (Eigen::Index t = 0; t < nt; ++t) {
      ratios[static_cast<size_t>(t)] = param->parametricVolume(t) / param->targetVolume(t);
      logRatio(t) = std::log10(std::max(1e-6, ratios[static_cast<size_t>(t)]));
    }
    ReportHistogram hist;
    hist.title = "parametric / target volume per tet";
    hist.xLabel = "volume ratio";
    hist.values = ratios;
    hist.rangeMin = 0;
    hist.rangeMax = std::max(2.0, param->param.volumeRatio.p99);
    hist.hasReference = true;
    hist.reference = 1;
    hist.referenceLabel = "target";
    hist.logCounts = true;
    h.histograms.push_back(hist);
    // Cut through the middle of the solid, coloured by region, and the same
    // tets at their parameter positions, coloured by log10 volume ratio.
    const Eigen::Vector3d centre = 0.5 * (param->mesh.V.colwise().minCoeff() + param->mesh.V.colwise().maxCoeff()).transpose();
    ClipPlane cut{centre, Eigen::Vector3d(0.3, 1, 0.2)};
    TetColors byRegion;
    byRegion.tetLabel = param->mesh.region;
    RenderOptions cutOptions = ro;
    cutOptions.edges = nt < 200000;
    const Eigen::Vector3d ucentre = 0.5 * (param->U.colwise().minCoeff() + param->U.colwise().maxCoeff()).transpose();
    TetColors byRatio;
    byRatio.tetScalar = logRatio;
    RenderOptions ratioOptions = cutOptions;
    ratioOptions.colorMap = ColorMap::Diverging;
    ratioOptions.scalarMin = -1;
    ratioOptions.scalarMax = 1;
    // (Declared after everything it reads: an exception here waits for it.)
    std::future<Image> domainCut = std::async(std::launch::async, [&] {
      return renderTetCut(param->U, param->mesh.T, ClipPlane{ucentre, Eigen::Vector3d(0.3, 1, 0.2)}, byRatio, ratioOptions);
    });
    ReportImage solid("cut through the solid, coloured by region",
                      renderTetCut(param->mesh.V, param->mesh.T, cut, byRegion, cutOptions));
    for (int id : std::vector<int>(param->mesh.region.data(), param->mesh.region.data() + nt))
      if (std::none_of(solid.legend.begin(), solid.legend.end(), [&](const auto& l) { return l.first == id; }))
        solid.legend.emplace_back(id, "region " + std::to_string(id) + (param->mesh.voidRegions.count(id) ? " (void)" : ""));
    h.images.push_back(std::move(solid));
    ReportImage domain("the parameterization cut through its domain, coloured by log10(parametric / target volume)",
                       domainCut.get());
    domain.hasColorBar = true;
    domain.colorMap = ColorMap::Diverging;
    domain.scalarMin = -1;
    domain.scalarMax = 1;
    domain.scalarLabel = "log10 volume ratio";
    h.images.push_back(std::move(domain));
  }
  if (volume) {
    h.images.push_back(splinePicture.get());
    ReportHistogram hist;
    hist.title = "scaled Jacobian of the spline";
    hist.xLabel = "scaled Jacobian at sample points";
    const int n = 12;
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          const Eigen::Vector3d u((i + 0.5) / n, (j + 0.5) / n, (k + 0.5) / n);
          const Eigen::Vector3d lo = volume->parameterMin(), hi = volume->parameterMax();
          hist.values.push_back(volume->scaledJacobian(lo + u.cwiseProduct(hi - lo)));
        }
    hist.rangeMin = -1;
    hist.rangeMax = 1;
    hist.hasReference = true;
    hist.reference = 0;
    hist.referenceLabel = "invalid below";
    h.histograms.push_back(hist);
  }
  writeHtmlReport(h, path);
}

}  // namespace tet2spline::cli

#pragma once
// report.html of a convert run: the figures of report.json, histograms, and
// pictures rendered by the program itself (io/render.h).
#include <string>

#include "cli_common.h"
#include "tet2spline/param/parameterize.h"

namespace tet2spline::spline {
class BSplineVolume;
}

namespace tet2spline::cli {

/// Writes report.html (atomically). `param` may be null (no param stage ran),
/// `volume` null (no spline). Figures come from `report` (the JSON of the run).
void writeRunHtml(const json& report, const ParamResult* param, const spline::BSplineVolume* volume,
                  const std::string& inputPath, const std::string& path);

}  // namespace tet2spline::cli

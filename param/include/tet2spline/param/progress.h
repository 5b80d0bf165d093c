#pragma once
#include <functional>
#include <string>

namespace tet2spline {

/// Progress of a long stage: `fraction` in [0,1] (negative when unknown) and a
/// short message ("newton 3: max rel. mass error 2.1e-3"). Return false to stop.
using ProgressCallback = std::function<bool(double fraction, const std::string& message)>;

}  // namespace tet2spline

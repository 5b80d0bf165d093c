#include "weighted_points.h"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "tet2spline/param/error.h"

namespace tet2spline::cli {
namespace {

// Next non-empty, non-comment line; false at the end of the file.
bool nextLine(std::istream& in, std::string& line, long& lineNo) {
  while (std::getline(in, line)) {
    ++lineNo;
    const size_t hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    if (line.find_first_not_of(" \t\r") != std::string::npos) return true;
  }
  return false;
}

}  // namespace

WeightedPoints readWeightedPoints(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(ErrorKind::Input, path + ": cannot open the file");
  std::string line;
  long lineNo = 0;
  auto fail = [&](const std::string& what) { throw Error(ErrorKind::Input, path + ":" + std::to_string(lineNo) + ": " + what); };
  if (!nextLine(in, line, lineNo)) throw Error(ErrorKind::Input, path + ": empty file (expected the number of points)");
  std::istringstream head(line);
  long n = 0;
  std::string extra;
  if (!(head >> n) || (head >> extra) || n <= 0 || n > 100000000) fail("expected the number of points (an integer > 0)");
  WeightedPoints p;
  p.points.resize(n, 3);
  p.masses.resize(n);
  for (long i = 0; i < n; ++i) {
    if (!nextLine(in, line, lineNo))
      throw Error(ErrorKind::Input, path + ": the file ends after " + std::to_string(i) + " of " + std::to_string(n) + " points");
    // strtod, not >>, so that nan and inf are read and then refused by name.
    double v[4];
    const char* cursor = line.c_str();
    for (double& value : v) {
      char* end = nullptr;
      value = std::strtod(cursor, &end);
      if (end == cursor) fail("expected four numbers: x y z mass");
      cursor = end;
    }
    while (*cursor == ' ' || *cursor == '\t' || *cursor == '\r') ++cursor;
    if (*cursor) fail("expected four numbers: x y z mass");
    const double x = v[0], y = v[1], z = v[2], m = v[3];
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) fail("coordinates must be finite");
    if (!(std::isfinite(m) && m > 0)) fail("the mass must be a finite number > 0");
    p.points.row(i) << x, y, z;
    p.masses(i) = m;
  }
  if (nextLine(in, line, lineNo)) fail("more points than the " + std::to_string(n) + " announced on the first line");
  return p;
}


}  // namespace tet2spline::cli

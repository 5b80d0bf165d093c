#pragma once
// Helpers shared by the io tests: scratch directories under the build tree,
// a small reference mesh, error checks and running the independent writers
// (gmsh, tetgen) installed by scripts/install-deps.sh.
#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <string>

#include "tet2spline/io/mesh_io.h"
#include "tet2spline/param/error.h"
#include "test_data.h"

namespace t2stest {

namespace fs = std::filesystem;

/// A fresh, empty directory under the build tree (ctest runs in build/tests).
/// Names are unique per test, so parallel ctest runs do not collide.
inline std::string scratchDir(const std::string& name) {
  const fs::path dir = fs::current_path() / "io_test_tmp" / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir.string();
}

/// A directory shared by the test processes of one suite (cached outputs).
inline std::string sharedDir(const std::string& name) {
  const fs::path dir = fs::current_path() / "io_test_tmp" / name;
  fs::create_directories(dir);
  return dir.string();
}

inline void writeFile(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  ASSERT_TRUE(out.good()) << path;
}

inline std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// Runs f, expects Error(Input) whose message starts with "path" (and ":line: "
/// when line > 0) and contains `cause`. Returns the message.
inline std::string expectInputError(const std::function<void()>& f, const std::string& path, long line,
                                    const std::string& cause) {
  try {
    f();
  } catch (const tet2spline::Error& e) {
    const std::string msg = e.what();
    EXPECT_EQ(e.kind(), tet2spline::ErrorKind::Input) << msg;
    const std::string prefix = path + (line > 0 ? ":" + std::to_string(line) + ":" : std::string(":"));
    EXPECT_EQ(msg.rfind(prefix, 0), 0u) << "message '" << msg << "' should start with '" << prefix << "'";
    EXPECT_NE(msg.find(cause), std::string::npos) << "message '" << msg << "' should mention '" << cause << "'";
    EXPECT_EQ(msg.find('\n'), std::string::npos) << "one line: " << msg;
    return msg;
  } catch (const std::exception& e) {
    ADD_FAILURE() << "expected tet2spline::Error, got std::exception: " << e.what();
    return {};
  }
  ADD_FAILURE() << "expected an error reading " << path;
  return {};
}

/// 9 vertices (a box and an inner point), 12 tets in two interleaved regions,
/// point and cell fields with 1 and 3/2 components. Coordinates need all 17
/// digits, so only exact round trips compare equal.
inline tet2spline::TetMesh referenceMesh() {
  tet2spline::TetMesh m;
  m.V.resize(9, 3);
  const double a = 1.0 / 3.0, b = 0.1, c = std::sqrt(2.0);
  m.V << 0, 0, 0, c, 0, 0, c, a + 1, 0, 0, a + 1, 0, 0, 0, b + 1, c, 0, b + 1, c, a + 1, b + 1, 0, a + 1, b + 1,
      c / 2, (a + 1) / 2, (b + 1) / 2 + 1e-17;
  const int faces[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};
  m.T.resize(12, 4);
  for (int f = 0; f < 6; ++f) {
    m.T.row(2 * f) << faces[f][0], faces[f][1], faces[f][2], 8;
    m.T.row(2 * f + 1) << faces[f][0], faces[f][2], faces[f][3], 8;
  }
  m.region.resize(12);
  for (int t = 0; t < 12; ++t) m.region(t) = t % 3 == 0 ? 7 : 3;
  m.region(11) = -2;
  tet2spline::Field temp{"temperature", Eigen::MatrixXd(9, 1)};
  tet2spline::Field disp{"U", Eigen::MatrixXd(9, 3)};
  for (int i = 0; i < 9; ++i) {
    temp.values(i, 0) = std::exp(0.3 * i) - 1e-300 * i;
    disp.values.row(i) = m.V.row(i) * a;
  }
  tet2spline::Field dens{"density", Eigen::MatrixXd(12, 1)};
  tet2spline::Field pair{"two & \"quoted\" <parts>", Eigen::MatrixXd(12, 2)};
  for (int t = 0; t < 12; ++t) {
    dens.values(t, 0) = 1.0 / (t + 1);
    pair.values(t, 0) = -t * 1e10;
    pair.values(t, 1) = std::nextafter(1.0, 2.0) * t;
  }
  m.pointFields = {temp, disp};
  m.cellFields = {dens, pair};
  return m;
}

inline double tetVolume(const tet2spline::TetMesh& m, Eigen::Index t) {
  const Eigen::Vector3d a = m.V.row(m.T(t, 0)), b = m.V.row(m.T(t, 1)), c = m.V.row(m.T(t, 2)),
                        d = m.V.row(m.T(t, 3));
  return (b - a).cross(c - a).dot(d - a) / 6.0;
}

/// Sum of |tet volume| per region.
inline std::map<int, double> regionVolumes(const tet2spline::TetMesh& m) {
  std::map<int, double> v;
  for (Eigen::Index t = 0; t < m.numTets(); ++t) v[m.region(t)] += std::fabs(tetVolume(m, t));
  return v;
}

/// Volume enclosed by a closed, consistently oriented surface (divergence theorem).
inline double enclosedVolume(const tet2spline::SurfaceMesh& s) {
  double v = 0;
  for (Eigen::Index f = 0; f < s.F.rows(); ++f) {
    const Eigen::Vector3d a = s.V.row(s.F(f, 0)), b = s.V.row(s.F(f, 1)), c = s.V.row(s.F(f, 2));
    v += a.dot(b.cross(c)) / 6.0;
  }
  return std::fabs(v);
}

inline bool haveProgram(const std::string& name) {
  return std::system(("command -v " + name + " >/dev/null 2>&1").c_str()) == 0;
}

inline int run(const std::string& cmd) { return std::system((cmd + " >/dev/null 2>&1").c_str()); }

/// Box [0,2]^3 holding a sphere of radius 0.5: physical volume 7 = box minus
/// sphere, 9 = sphere. Meshed by gmsh once per format and cached.
inline std::string gmshNested(const std::string& format, bool binary, const std::string& ext) {
  const std::string dir = sharedDir("gmsh");
  const std::string geo = dir + "/nested.geo";
  if (!fs::exists(geo)) {
    const std::string tmp = geo + ".tmp." + std::to_string(::getpid());
    writeFile(tmp,
              "SetFactory(\"OpenCASCADE\");\n"
              "Box(1) = {0,0,0, 2,2,2};\n"
              "Sphere(2) = {1,1,1, 0.5};\n"
              "BooleanFragments{ Volume{1}; Delete; }{ Volume{2}; Delete; }\n"
              "Physical Volume(\"outer\", 7) = {3};\n"
              "Physical Volume(\"inner\", 9) = {2};\n"
              "Mesh.MeshSizeMax = 0.4;\n"
              "Mesh.RandomSeed = 1;\n");
    fs::rename(tmp, geo);
  }
  const std::string out = dir + "/nested_" + format + (binary ? "_bin" : "") + "." + ext;
  if (!fs::exists(out)) {
    const std::string tmp = out + ".tmp." + std::to_string(::getpid());
    const int rc = run("gmsh -3 -nt 1 " + geo + " -format " + format + (binary ? " -bin" : "") + " -o " + tmp);
    if (rc != 0 || !fs::exists(tmp)) return {};
    fs::rename(tmp, out);
  }
  return out;
}

}  // namespace t2stest

// STEP/IGES export of a B-spline volume's boundary: read back with
// OpenCASCADE (one valid solid, its volume, its faces' B-spline poles and
// sampled boundary points) and meshed by gmsh as an independent reader.
#include <gtest/gtest.h>

#include <BRepBuilderAPI_MakeVertex.hxx>
#include <BRepCheck_Analyzer.hxx>
#include <BRepExtrema_DistShapeShape.hxx>
#include <BRepGProp.hxx>
#include <BRep_Tool.hxx>
#include <GProp_GProps.hxx>
#include <Geom_BSplineSurface.hxx>
#include <IFSelect_ReturnStatus.hxx>
#include <IGESControl_Reader.hxx>
#include <STEPControl_Reader.hxx>
#include <TopExp_Explorer.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Face.hxx>

#include <chrono>
#include <thread>

#include "io_test_util.h"
#include "spline_test_volumes.h"
#include "tet2spline/io/cad_export.h"
#include "tet2spline/io/mesh_io.h"

namespace {

using namespace t2stest;
using tet2spline::spline::VolumeFace;

enum class Kind { Step, Iges };

std::string ext(Kind k) { return k == Kind::Step ? ".step" : ".iges"; }

void write(Kind k, const BSplineVolume& V, const std::string& path) {
  if (k == Kind::Step) tet2spline::writeStep(V, path);
  else tet2spline::writeIges(V, path);
}

/// Test-only reader: the file's shape as OpenCASCADE translates it.
TopoDS_Shape readCad(Kind k, const std::string& path) {
  if (k == Kind::Step) {
    STEPControl_Reader r;
    EXPECT_EQ(r.ReadFile(path.c_str()), IFSelect_RetDone) << path;
    r.TransferRoots();
    return r.OneShape();
  }
  IGESControl_Reader r;
  EXPECT_EQ(r.ReadFile(path.c_str()), IFSelect_RetDone) << path;
  r.TransferRoots();
  return r.OneShape();
}

int countOf(const TopoDS_Shape& s, TopAbs_ShapeEnum type) {
  int n = 0;
  for (TopExp_Explorer ex(s, type); ex.More(); ex.Next()) ++n;
  return n;
}

double cadVolume(const TopoDS_Shape& s) {
  GProp_GProps props;
  BRepGProp::VolumeProperties(s, props);
  return props.Mass();
}

double diagonal(const BSplineVolume& V) {
  const Eigen::MatrixX3d& P = V.controlPoints();
  return (P.colwise().maxCoeff() - P.colwise().minCoeff()).norm();
}

// Sorted poles of a surface, for comparing up to the order of its net.
std::vector<std::array<double, 3>> sortedPoles(const Eigen::MatrixX3d& Q) {
  std::vector<std::array<double, 3>> p;
  for (Eigen::Index i = 0; i < Q.rows(); ++i) p.push_back({Q(i, 0), Q(i, 1), Q(i, 2)});
  std::sort(p.begin(), p.end());
  return p;
}

bool samePoles(std::vector<std::array<double, 3>> a, std::vector<std::array<double, 3>> b, double tol) {
  if (a.size() != b.size()) return false;
  // Rounding may reorder nearly equal points: match greedily.
  for (const auto& p : a) {
    auto it = std::find_if(b.begin(), b.end(), [&](const auto& q) {
      return std::fabs(p[0] - q[0]) <= tol && std::fabs(p[1] - q[1]) <= tol && std::fabs(p[2] - q[2]) <= tol;
    });
    if (it == b.end()) return false;
    b.erase(it);
  }
  return true;
}

// Parameter n (1-based) of an IGES global section: ',' separated, ';' ends
// it, strings are Hollerith (nH followed by n characters).
std::string igesGlobalParameter(const std::string& file, int n) {
  std::istringstream in(file);
  std::string line, g;
  while (std::getline(in, line))
    if (line.size() >= 73 && line[72] == 'G') g += line.substr(0, 72);
  std::vector<std::string> params;
  std::string cur;
  for (size_t i = 0; i < g.size(); ++i) {
    const char ch = g[i];
    if (ch == ',' || ch == ';') {
      params.push_back(cur);
      cur.clear();
      if (ch == ';') break;
    } else if (ch == 'H' && !cur.empty() && std::all_of(cur.begin(), cur.end(), ::isdigit)) {
      const size_t len = std::stoul(cur);
      cur = g.substr(i + 1, len);
      i += len;
    } else if (ch != ' ') {
      cur += ch;
    }
  }
  return n >= 1 && static_cast<size_t>(n) <= params.size() ? params[static_cast<size_t>(n) - 1] : std::string("<missing>");
}

void checkReadBack(Kind k, const BSplineVolume& V, const std::string& path) {
  ASSERT_TRUE(fs::exists(path));
  const TopoDS_Shape shape = readCad(k, path);
  ASSERT_FALSE(shape.IsNull());
  EXPECT_EQ(countOf(shape, TopAbs_SOLID), 1);
  EXPECT_EQ(countOf(shape, TopAbs_SHELL), 1);
  EXPECT_EQ(countOf(shape, TopAbs_FACE), 6);
  EXPECT_TRUE(BRepCheck_Analyzer(shape).IsValid());

  const double exact = V.volume();
  const double cad = cadVolume(shape);
  std::cout << "[ measured ] " << path.substr(path.find_last_of('/') + 1) << ": volume " << cad << " vs spline "
            << exact << " (relative " << std::fabs(cad - exact) / exact << ")\n";
  EXPECT_NEAR(cad, exact, 0.01 * exact);

  // Every face is one of our six B-spline faces: same degrees, same poles.
  const double diag = diagonal(V);
  std::vector<bool> matched(6, false);
  for (TopExp_Explorer ex(shape, TopAbs_FACE); ex.More(); ex.Next()) {
    const Handle(Geom_BSplineSurface) s = Handle(Geom_BSplineSurface)::DownCast(BRep_Tool::Surface(TopoDS::Face(ex.Current())));
    ASSERT_FALSE(s.IsNull()) << "a face is not a B-spline surface";
    Eigen::MatrixX3d Q(s->NbUPoles() * s->NbVPoles(), 3);
    for (int j = 1; j <= s->NbVPoles(); ++j)
      for (int i = 1; i <= s->NbUPoles(); ++i) {
        const gp_Pnt p = s->Pole(i, j);
        Q.row((i - 1) + s->NbUPoles() * (j - 1)) << p.X(), p.Y(), p.Z();
      }
    bool found = false;
    for (int f = 0; f < 6 && !found; ++f) {
      const auto face = V.face(static_cast<VolumeFace>(f));
      const std::set<int> ours{face.degree(0), face.degree(1)}, theirs{s->UDegree(), s->VDegree()};
      if (!matched[f] && ours == theirs && samePoles(sortedPoles(face.controlPoints()), sortedPoles(Q), 1e-9 * diag))
        matched[f] = found = true;
    }
    EXPECT_TRUE(found) << "a face matches none of the volume's boundary faces";
  }

  // Sampled boundary points lie on the read-back shell.
  TopExp_Explorer shellEx(shape, TopAbs_SHELL);
  ASSERT_TRUE(shellEx.More());
  const TopoDS_Shape shell = shellEx.Current();
  double worst = 0;
  for (int f = 0; f < 6; ++f) {
    const auto face = V.face(static_cast<VolumeFace>(f));
    const double s0 = face.knots(0).front(), s1 = face.knots(0).back(), t0 = face.knots(1).front(), t1 = face.knots(1).back();
    for (int j = 0; j <= 4; ++j)
      for (int i = 0; i <= 4; ++i) {
        const Eigen::Vector3d x = face.evaluate(s0 + (s1 - s0) * (0.05 + 0.9 * i / 4), t0 + (t1 - t0) * (0.05 + 0.9 * j / 4));
        BRepExtrema_DistShapeShape dist(BRepBuilderAPI_MakeVertex(gp_Pnt(x.x(), x.y(), x.z())).Vertex(), shell);
        ASSERT_TRUE(dist.IsDone());
        worst = std::max(worst, dist.Value());
      }
  }
  std::cout << "[ measured ] max distance of 150 boundary samples: " << worst << " (diagonal " << diag << ")\n";
  EXPECT_LT(worst, 1e-7 * diag);
}

TEST(CadExport, StepReadsBackAsTheSameSolid) {
  const std::string dir = scratchDir("cad_step");
  for (const auto& [name, V] : testVolumes()) {
    SCOPED_TRACE(name);
    ASSERT_GT(minInteriorDetJ(V), 0);
    const std::string path = dir + "/" + name + ".step";
    tet2spline::writeStep(V, path);
    checkReadBack(Kind::Step, V, path);
    const std::string text = readFile(path);
    EXPECT_NE(text.find("AUTOMOTIVE_DESIGN"), std::string::npos) << "AP214 schema";
    EXPECT_NE(text.find("B_SPLINE_SURFACE_WITH_KNOTS"), std::string::npos);
    EXPECT_NE(text.find("MANIFOLD_SOLID_BREP"), std::string::npos);
  }
}

TEST(CadExport, IgesReadsBackAsTheSameSolid) {
  const std::string dir = scratchDir("cad_iges");
  for (const auto& [name, V] : testVolumes()) {
    SCOPED_TRACE(name);
    const std::string path = dir + "/" + name + ".iges";
    tet2spline::writeIges(V, path);
    checkReadBack(Kind::Iges, V, path);
    // Directory entries (lines ending in D + sequence number): B-spline
    // surfaces (128) and one manifold solid B-rep object (186).
    std::istringstream in(readFile(path));
    std::string line;
    int bsplineSurfaces = 0, solids = 0, dLines = 0;
    while (std::getline(in, line)) {
      if (line.size() < 73 || line[72] != 'D') continue;
      if (dLines++ % 2) continue;  // two lines per entry; the type is on the first
      const int type = std::stoi(line.substr(0, 8));
      bsplineSurfaces += type == 128;
      solids += type == 186;
    }
    EXPECT_GE(bsplineSurfaces, 6);
    EXPECT_EQ(solids, 1);
    // Global section parameter 23, the version flag: 11 = IGES 5.3.
    EXPECT_EQ(igesGlobalParameter(readFile(path), 23), "11");
  }
}

// gmsh (Debian's, built with OpenCASCADE) meshes the STEP/IGES solid; the
// tet volume is compared with the spline's exact volume.
TEST(CadExport, GmshMeshesTheExportedSolid) {
  if (!haveProgram("gmsh")) GTEST_SKIP() << "gmsh not installed";
  const std::string dir = scratchDir("cad_gmsh");
  for (const auto& [name, V] : testVolumes()) {
    for (Kind k : {Kind::Step, Kind::Iges}) {
      SCOPED_TRACE(name + ext(k));
      const std::string in = dir + "/" + name + ext(k), out = dir + "/" + name + (k == Kind::Step ? "_step" : "_iges") + ".msh";
      write(k, V, in);
      const double h = diagonal(V) / 15;
      const auto t0 = std::chrono::steady_clock::now();
      ASSERT_EQ(run("gmsh -3 -nt 1 " + in + " -clmax " + std::to_string(h) + " -format msh2 -o " + out), 0);
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const tet2spline::TetMesh m = tet2spline::readTetMesh(out);
      double vol = 0;
      for (Eigen::Index t = 0; t < m.numTets(); ++t) vol += std::fabs(tetVolume(m, t));
      std::cout << "[ measured ] gmsh " << name << ext(k) << ": " << m.numTets() << " tets, volume " << vol
                << " vs spline " << V.volume() << " (relative " << std::fabs(vol - V.volume()) / V.volume() << "), "
                << seconds << " s\n";
      EXPECT_GT(m.numTets(), 100);
      EXPECT_NEAR(vol, V.volume(), 0.02 * V.volume());
    }
  }
}

// Faces meeting tangentially along four edges (det J = 0 there) still sew
// into one valid solid.
TEST(CadExport, TangentFacesAlongEdges) {
  const std::string dir = scratchDir("cad_tangent");
  const BSplineVolume V = cylinderPatch(0.5);
  ASSERT_GT(minInteriorDetJ(V), 0);
  EXPECT_NEAR(V.detJacobian(Eigen::Vector3d(1, 1, 0.5)), 0, 1e-12);
  for (Kind k : {Kind::Step, Kind::Iges}) {
    const std::string path = dir + "/smooth_cylinder" + ext(k);
    write(k, V, path);
    checkReadBack(k, V, path);
  }
}

// A left-handed volume (det J < 0 everywhere, mirrored): the B-rep is still
// oriented outward, with volume |∫ det J|.
TEST(CadExport, LeftHandedVolumeIsOrientedOutward) {
  const std::string dir = scratchDir("cad_left_handed");
  BSplineVolume V = curvedCube();
  Eigen::MatrixX3d P = V.controlPoints();
  P.col(0) *= -1;
  V.setControlPoints(P);
  ASSERT_LT(V.volume(), 0);
  const std::string path = dir + "/mirrored.step";
  tet2spline::writeStep(V, path);
  const TopoDS_Shape shape = readCad(Kind::Step, path);
  EXPECT_EQ(countOf(shape, TopAbs_SOLID), 1);
  EXPECT_TRUE(BRepCheck_Analyzer(shape).IsValid());
  EXPECT_NEAR(cadVolume(shape), -V.volume(), 1e-4 * -V.volume());
}

TEST(CadExport, DegenerateVolumeIsANumericalErrorAndLeavesNoFile) {
  const std::string dir = scratchDir("cad_degenerate");
  BSplineVolume V = refinedBox();
  V.setControlPoints(Eigen::MatrixX3d::Ones(V.numControlPoints(), 3));  // collapses to a point
  for (Kind k : {Kind::Step, Kind::Iges}) {
    const std::string path = dir + "/flat" + ext(k);
    try {
      write(k, V, path);
      ADD_FAILURE() << "expected an error";
    } catch (const tet2spline::Error& e) {
      EXPECT_EQ(e.kind(), tet2spline::ErrorKind::Numerical) << e.what();
      EXPECT_EQ(std::string(e.what()).rfind(path + ": ", 0), 0u) << e.what();
    }
  }
  // Flattened in z: the faces w = 0 and w = 1 coincide, sewing cannot close it.
  V = refinedBox();
  Eigen::MatrixX3d P = V.controlPoints();
  P.col(2).setZero();
  V.setControlPoints(P);
  for (Kind k : {Kind::Step, Kind::Iges}) {
    const std::string path = dir + "/thin" + ext(k);
    try {
      write(k, V, path);
      ADD_FAILURE() << "expected an error";
    } catch (const tet2spline::Error& e) {
      EXPECT_EQ(e.kind(), tet2spline::ErrorKind::Numerical) << e.what();
      EXPECT_EQ(std::string(e.what()).rfind(path + ": ", 0), 0u) << e.what();
      std::cout << "[ message  ] " << e.what() << "\n";
    }
  }
  EXPECT_TRUE(fs::is_empty(dir));
}

TEST(CadExport, Deterministic) {
  const std::string dir = scratchDir("cad_determinism");
  const BSplineVolume V = cylinderPatch();
  fs::create_directory(dir + "/a");
  fs::create_directory(dir + "/b");
  for (Kind k : {Kind::Step, Kind::Iges}) {
    write(k, V, dir + "/a/v" + ext(k));
    std::this_thread::sleep_for(std::chrono::milliseconds(1100));  // past the seconds of a time stamp
    write(k, V, dir + "/b/v" + ext(k));
    EXPECT_TRUE(readFile(dir + "/a/v" + ext(k)) == readFile(dir + "/b/v" + ext(k))) << "diff " << dir << "/{a,b}/v" << ext(k);
  }
}

TEST(CadExport, UnwritablePathLeavesNoFile) {
  const std::string dir = scratchDir("cad_unwritable");
  const BSplineVolume V = curvedCube();
  for (Kind k : {Kind::Step, Kind::Iges}) {
    const std::string missing = dir + "/missing/v" + ext(k);
    expectInputError([&] { write(k, V, missing); }, missing, 0, "cannot");
  }
  fs::create_directory(dir + "/target.step");
  expectInputError([&] { tet2spline::writeStep(V, dir + "/target.step"); }, dir + "/target.step", 0, "cannot");
  std::vector<std::string> left;
  for (const auto& e : fs::directory_iterator(dir)) left.push_back(e.path().filename().string());
  EXPECT_EQ(left, std::vector<std::string>{"target.step"});
  EXPECT_TRUE(fs::is_empty(dir + "/target.step"));
}

}  // namespace

// readCadSurface: OCCT builds the solids, writes them as STEP and IGES, and the
// tessellation read back must be a closed, consistently oriented surface
// whose shells have χ = 2 and enclose the B-rep's volume, with every shell's
// normals pointing out of the material (outer shell > 0, voids < 0).
#include "tet2spline/io/cad_io.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <BRepAlgoAPI_Cut.hxx>
#include <BRepBuilderAPI_MakeFace.hxx>
#include <BRepBuilderAPI_Transform.hxx>
#include <BRepFilletAPI_MakeFillet.hxx>
#include <BRepGProp.hxx>
#include <BRepPrimAPI_MakeBox.hxx>
#include <BRepPrimAPI_MakeCylinder.hxx>
#include <BRepPrimAPI_MakeSphere.hxx>
#include <BRep_Builder.hxx>
#include <GProp_GProps.hxx>
#include <IGESControl_Controller.hxx>
#include <IGESControl_Writer.hxx>
#include <Message.hxx>
#include <Message_Messenger.hxx>
#include <STEPControl_Reader.hxx>
#include <STEPControl_Writer.hxx>
#include <TopExp_Explorer.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Compound.hxx>
#include <gp_Pln.hxx>

#include <Eigen/Geometry>
#include <filesystem>
#include <fstream>
#include <map>
#include <iterator>
#include <numeric>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "tet2spline/io/mesh_io.h"
#include "tet2spline/param/error.h"
#include "test_data.h"

namespace fs = std::filesystem;
using namespace tet2spline;

namespace {

// ---------------------------------------------------------------------------
// Surface properties

struct Shell {
  int chi = 0;
  double volume = 0;  ///< signed volume enclosed, > 0 for outward normals
};

// Connected components (triangles sharing a vertex), with χ and signed volume.
std::vector<Shell> shellsOf(const SurfaceMesh& s) {
  std::vector<int> parent(static_cast<size_t>(s.V.rows()));
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  for (Eigen::Index f = 0; f < s.F.rows(); ++f)
    for (int k = 1; k < 3; ++k) parent[find(s.F(f, k))] = find(s.F(f, 0));
  std::map<int, int> id;
  std::vector<std::set<int>> verts;
  std::vector<std::set<std::pair<int, int>>> edges;
  std::vector<int> faces;
  std::vector<Shell> shells;
  for (Eigen::Index f = 0; f < s.F.rows(); ++f) {
    auto [it, inserted] = id.emplace(find(s.F(f, 0)), static_cast<int>(id.size()));
    if (inserted) {
      verts.emplace_back();
      edges.emplace_back();
      faces.push_back(0);
      shells.emplace_back();
    }
    const int k = it->second;
    ++faces[k];
    for (int j = 0; j < 3; ++j) {
      const int a = s.F(f, j), b = s.F(f, (j + 1) % 3);
      verts[k].insert(a);
      edges[k].insert({std::min(a, b), std::max(a, b)});
    }
    const Eigen::Vector3d a = s.V.row(s.F(f, 0)), b = s.V.row(s.F(f, 1)), c = s.V.row(s.F(f, 2));
    shells[k].volume += a.dot(b.cross(c)) / 6;
  }
  for (size_t k = 0; k < shells.size(); ++k)
    shells[k].chi = static_cast<int>(verts[k].size()) - static_cast<int>(edges[k].size()) + faces[k];
  return shells;
}

double totalVolume(const SurfaceMesh& s) {
  double v = 0;
  for (const Shell& sh : shellsOf(s)) v += sh.volume;
  return v;
}

// Closed and consistently oriented: every directed edge occurs exactly once
// and so does its reverse.
::testing::AssertionResult isWatertight(const SurfaceMesh& s) {
  if (s.F.rows() == 0) return ::testing::AssertionFailure() << "no triangles";
  std::map<std::pair<int, int>, int> directed;
  for (Eigen::Index f = 0; f < s.F.rows(); ++f) {
    for (int k = 0; k < 3; ++k) {
      if (s.F(f, k) < 0 || s.F(f, k) >= s.V.rows()) return ::testing::AssertionFailure() << "index out of range";
      ++directed[{s.F(f, k), s.F(f, (k + 1) % 3)}];
    }
    if (s.F(f, 0) == s.F(f, 1) || s.F(f, 1) == s.F(f, 2) || s.F(f, 0) == s.F(f, 2))
      return ::testing::AssertionFailure() << "triangle " << f << " repeats a vertex";
  }
  int once = 0, open = 0, repeated = 0;
  for (const auto& [e, n] : directed) {
    if (n != 1) ++repeated;
    auto r = directed.find({e.second, e.first});
    if (r == directed.end()) ++open;
    else if (n == 1 && r->second == 1) ++once;
  }
  if (open || repeated)
    return ::testing::AssertionFailure() << open << " directed edges without their reverse, " << repeated
                                         << " directed edges used more than once";
  return ::testing::AssertionSuccess() << once << " directed edges";
}

// ---------------------------------------------------------------------------
// OCCT shapes and files

double volumeOf(const TopoDS_Shape& s) {
  GProp_GProps props;
  BRepGProp::VolumeProperties(s, props);
  return props.Mass();
}

// Detaches OCCT's stdout printers while a writer runs.
struct QuietOcct {
  Handle(Message_Messenger) m = Message::DefaultMessenger();
  Message_SequenceOfPrinters saved = m->Printers();
  QuietOcct() { m->ChangePrinters().Clear(); }
  ~QuietOcct() { m->ChangePrinters() = saved; }
};

void writeStep(const TopoDS_Shape& shape, const std::string& path) {
  QuietOcct quiet;
  STEPControl_Writer writer;
  ASSERT_EQ(writer.Transfer(shape, STEPControl_AsIs), IFSelect_RetDone);
  ASSERT_EQ(writer.Write(path.c_str()), IFSelect_RetDone);
}

/// IGES mode 0 writes trimmed faces only (the common case: the reader must sew
/// them into a solid); mode 1 writes B-rep entities (MSBO solids).
void writeIges(const TopoDS_Shape& shape, const std::string& path, int mode = 0) {
  QuietOcct quiet;
  IGESControl_Controller::Init();
  IGESControl_Writer writer("MM", mode);
  ASSERT_TRUE(writer.AddShape(shape));
  writer.ComputeModel();
  ASSERT_TRUE(writer.Write(path.c_str()));
}

TopoDS_Shape makeBox(double x0 = 0, double y0 = 0, double z0 = 0, double dx = 30, double dy = 20, double dz = 10) {
  return BRepPrimAPI_MakeBox(gp_Pnt(x0, y0, z0), dx, dy, dz).Shape();
}

TopoDS_Shape makeCylinder() { return BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(1, 2, 3), gp::DZ()), 10, 25).Shape(); }

TopoDS_Shape makeSphere() { return BRepPrimAPI_MakeSphere(gp_Pnt(5, -3, 2), 12).Shape(); }

TopoDS_Shape makeFilletedBox() {
  TopoDS_Shape box = makeBox(0, 0, 0, 40, 30, 20);
  BRepFilletAPI_MakeFillet fillet(box);
  for (TopExp_Explorer e(box, TopAbs_EDGE); e.More(); e.Next()) fillet.Add(3, TopoDS::Edge(e.Current()));
  fillet.Build();
  EXPECT_TRUE(fillet.IsDone());
  return fillet.Shape();
}

TopoDS_Shape makeBoxWithVoid() {
  return BRepAlgoAPI_Cut(makeBox(0, 0, 0, 40, 30, 30), BRepPrimAPI_MakeSphere(gp_Pnt(22, 14, 16), 8).Shape()).Shape();
}

// A compound of two disjoint boxes of different sizes (the second one larger).
TopoDS_Shape makeTwoBoxes() {
  TopoDS_Compound c;
  BRep_Builder b;
  b.MakeCompound(c);
  b.Add(c, makeBox(0, 0, 0, 10, 10, 10));
  b.Add(c, makeBox(50, 0, 0, 20, 10, 10));
  return c;
}

class CadIoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("t2s_cad_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override {
    if (std::getenv("T2S_KEEP_TMP")) return;
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  // A fine tessellation, so that the volume is within 0.5 % of the B-rep's.
  static CadReadOptions fine() {
    CadReadOptions o;
    o.relativeDeflection = 2e-4;
    o.angularDeflection = 0.2;
    return o;
  }

  // Writes `shape`, reads it back, checks the laws; returns the surface.
  SurfaceMesh roundTrip(const TopoDS_Shape& shape, const std::string& file, int expectedShells = 1) {
    const std::string p = path(file);
    const std::string ext = fs::path(file).extension().string();
    if (ext == ".step" || ext == ".stp") writeStep(shape, p);
    else writeIges(shape, p, file.find("brep") != std::string::npos ? 1 : 0);
    const SurfaceMesh s = readCadSurface(p, fine());
    EXPECT_TRUE(isWatertight(s)) << file;
    const std::vector<Shell> shells = shellsOf(s);
    EXPECT_EQ(static_cast<int>(shells.size()), expectedShells) << file;
    for (const Shell& sh : shells) EXPECT_EQ(sh.chi, 2) << file << ": every shell is a sphere (genus 0)";
    const double expected = volumeOf(shape);
    EXPECT_NEAR(totalVolume(s), expected, 5e-3 * expected) << file;
    return s;
  }

  fs::path dir_;
};

void expectInputError(const std::string& file, const CadReadOptions& options = {},
                      const std::string& mentions = {}) {
  try {
    readCadSurface(file, options);
    ADD_FAILURE() << file << ": expected Error(Input)";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::Input) << e.what();
    EXPECT_NE(std::string(e.what()).find(file), std::string::npos) << "message names the file: " << e.what();
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << "one line: " << e.what();
    if (!mentions.empty()) {
      EXPECT_NE(std::string(e.what()).find(mentions), std::string::npos) << e.what();
    }
  }
}

// ---------------------------------------------------------------------------
// Round trips

TEST_F(CadIoTest, BoxStepAndIges) {
  roundTrip(makeBox(), "box.step");
  roundTrip(makeBox(), "box.igs");
  roundTrip(makeBox(), "box_brep.iges");
}

TEST_F(CadIoTest, CylinderStepAndIges) {
  roundTrip(makeCylinder(), "cylinder.step");
  roundTrip(makeCylinder(), "cylinder.igs");
}

TEST_F(CadIoTest, SphereWithPolesStepAndIges) {
  roundTrip(makeSphere(), "sphere.stp");
  roundTrip(makeSphere(), "sphere.iges");
}

TEST_F(CadIoTest, FilletedBoxStepAndIges) {
  roundTrip(makeFilletedBox(), "filleted.step");
  roundTrip(makeFilletedBox(), "filleted.igs");
}

TEST_F(CadIoTest, OutwardNormalsOnEveryShape) {
  for (const auto& [shape, name] : {std::pair{makeBox(), "b.step"}, {makeCylinder(), "c.step"},
                                    {makeFilletedBox(), "f.step"}}) {
    const SurfaceMesh s = roundTrip(shape, name);
    EXPECT_GT(totalVolume(s), 0) << name;
  }
}

TEST_F(CadIoTest, RigidMotionKeepsVolumeAndMovesTheBoundingBox) {
  gp_Trsf t;
  t.SetRotation(gp_Ax1(gp_Pnt(0, 0, 0), gp_Dir(1, 1, 1)), 0.7);
  t.SetTranslationPart(gp_Vec(100, -50, 25));
  const TopoDS_Shape moved = BRepBuilderAPI_Transform(makeFilletedBox(), t, /*copy=*/false).Shape();
  const SurfaceMesh s = roundTrip(moved, "moved.step");
  const Eigen::Vector3d centroid = s.V.colwise().mean();
  EXPECT_GT(centroid.x(), 80);
  EXPECT_LT(centroid.y(), -20);
}

TEST_F(CadIoTest, VoidGivesTwoShellsWithTheInnerOneOrientedIntoTheVoid) {
  for (const std::string name : {"void.step", "void.igs"}) {
    const SurfaceMesh s = roundTrip(makeBoxWithVoid(), name, 2);
    std::vector<Shell> shells = shellsOf(s);
    ASSERT_EQ(shells.size(), 2u);
    std::sort(shells.begin(), shells.end(), [](const Shell& a, const Shell& b) { return a.volume > b.volume; });
    // Normals point out of the material: the outer shell encloses the box
    // (positive), the void's shell the sphere with a negative sign.
    EXPECT_NEAR(shells[0].volume, 40.0 * 30 * 30, 5e-3 * 40 * 30 * 30) << name;
    const double sphere = 4.0 / 3 * M_PI * 8 * 8 * 8;
    EXPECT_NEAR(shells[1].volume, -sphere, 5e-3 * sphere) << name;
  }
}

TEST_F(CadIoTest, DefaultDeflectionIsCoarserButStillWatertight) {
  writeStep(makeFilletedBox(), path("coarse.step"));
  const SurfaceMesh coarse = readCadSurface(path("coarse.step"));
  const SurfaceMesh fineMesh = readCadSurface(path("coarse.step"), fine());
  EXPECT_TRUE(isWatertight(coarse));
  EXPECT_LT(coarse.F.rows(), fineMesh.F.rows());
  EXPECT_NEAR(totalVolume(coarse), volumeOf(makeFilletedBox()), 0.02 * volumeOf(makeFilletedBox()));
}

// ---------------------------------------------------------------------------
// Choosing a solid

TEST_F(CadIoTest, SeveralSolidsNeedSolidOption) {
  for (const std::string name : {"two.step", "two.igs"}) {
    const std::string p = path(name);
    if (name == "two.step") writeStep(makeTwoBoxes(), p);
    else writeIges(makeTwoBoxes(), p);
    try {
      readCadSurface(p);
      ADD_FAILURE() << name << ": two solids must be refused without --solid";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_EQ(e.kind(), ErrorKind::Input);
      EXPECT_NE(what.find(p), std::string::npos) << what;
      EXPECT_NE(what.find("2 solids"), std::string::npos) << what;
      EXPECT_NE(what.find("--solid"), std::string::npos) << what;
      EXPECT_NE(what.find("1..2"), std::string::npos) << what;
    }
    CadReadOptions o = fine();
    o.solid = 1;
    const SurfaceMesh first = readCadSurface(p, o);
    o.solid = 2;
    const SurfaceMesh second = readCadSurface(p, o);
    EXPECT_TRUE(isWatertight(first));
    EXPECT_TRUE(isWatertight(second));
    EXPECT_NEAR(totalVolume(first), 1000, 1e-6 * 1000) << name;
    EXPECT_NEAR(totalVolume(second), 2000, 1e-6 * 2000) << name;
    EXPECT_GE(second.V.col(0).minCoeff(), 50 - 1e-6) << name << ": --solid 2 is the box at x >= 50";
    o.solid = 3;
    try {
      readCadSurface(p, o);
      ADD_FAILURE() << name << ": --solid 3 of 2 must be refused";
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::Usage) << e.what();
      EXPECT_NE(std::string(e.what()).find("--solid 3"), std::string::npos) << e.what();
    }
  }
}

TEST_F(CadIoTest, OneSolidAcceptsSolidOne) {
  writeStep(makeBox(), path("one.step"));
  CadReadOptions o;
  o.solid = 1;
  EXPECT_TRUE(isWatertight(readCadSurface(path("one.step"), o)));
}

// ---------------------------------------------------------------------------
// Bad input: one line naming the file, ErrorKind::Input, never an abort.

TEST_F(CadIoTest, MissingFile) { expectInputError(path("does_not_exist.step"), {}, "cannot open"); }

TEST_F(CadIoTest, EmptyFiles) {
  for (const std::string name : {"empty.step", "empty.igs"}) {
    std::ofstream(path(name)).close();
    expectInputError(path(name), {}, "empty");
  }
}

TEST_F(CadIoTest, GarbageFiles) {
  for (const std::string name : {"garbage.step", "garbage.iges"}) {
    {
      std::ofstream out(path(name), std::ios::binary);
      out << "this is not a CAD file\n";
      for (int i = 0; i < 4096; ++i) out << static_cast<char>((i * 7919 + 13) % 256);
    }
    expectInputError(path(name));
  }
}

TEST_F(CadIoTest, TruncatedStep) {
  writeStep(makeFilletedBox(), path("full.step"));
  std::ifstream in(path("full.step"), std::ios::binary);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (double fraction : {0.05, 0.5, 0.9}) {
    const std::string p = path("truncated_" + std::to_string(static_cast<int>(100 * fraction)) + ".step");
    std::ofstream(p, std::ios::binary) << text.substr(0, static_cast<size_t>(fraction * text.size()));
    expectInputError(p);
  }
}

TEST_F(CadIoTest, TruncatedIges) {
  writeIges(makeFilletedBox(), path("full.igs"));
  std::ifstream in(path("full.igs"), std::ios::binary);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string p = path("truncated.igs");
  std::ofstream(p, std::ios::binary) << text.substr(0, text.size() / 2);
  expectInputError(p);
}

// Corrupts the text of a STEP file written by OCCT.
std::string readText(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

std::string replaceFirst(const std::string& text, const std::regex& pattern, const std::string& replacement) {
  return std::regex_replace(text, pattern, replacement, std::regex_constants::format_first_only);
}

TEST_F(CadIoTest, EntityOfTheWrongTypeIsMalformed) {
  // Without the load checks OCCT's translator dereferences a null handle here.
  writeStep(makeBoxWithVoid(), path("good.step"));
  const std::string text = readText(path("good.step"));
  std::smatch direction;
  ASSERT_TRUE(std::regex_search(text, direction, std::regex("#(\\d+) = DIRECTION")));
  const std::string bad = replaceFirst(text, std::regex("VERTEX_POINT\\('',#\\d+\\)"),
                                       "VERTEX_POINT(''," + direction.str(0).substr(0, direction.str(0).find(' ')) + ")");
  ASSERT_NE(bad, text);
  std::ofstream(path("wrong_type.step"), std::ios::binary) << bad;
  expectInputError(path("wrong_type.step"), {}, "malformed STEP file");
}

TEST_F(CadIoTest, OverflowingNumberIsRefusedWithItsLine) {
  // OCCT loops forever or crashes on such values.
  writeStep(makeBoxWithVoid(), path("good.step"));
  const std::string text = readText(path("good.step"));
  for (const std::string& number : {std::string("1.E+400"), std::string("-3.5E+30")}) {
    const std::string bad = replaceFirst(text, std::regex("CARTESIAN_POINT\\('',\\(([-0-9.E+]+),"),
                                         "CARTESIAN_POINT('',(" + number + ",");
    ASSERT_NE(bad, text);
    const std::string p = path("overflow.step");
    std::ofstream(p, std::ios::binary) << bad;
    expectInputError(p, {}, number);
    try {
      readCadSurface(p);
    } catch (const Error& e) {
      EXPECT_TRUE(std::regex_search(std::string(e.what()), std::regex("overflow\\.step:[0-9]+: "))) << e.what();
    }
  }
}

TEST_F(CadIoTest, OverflowingIgesNumberIsRefusedWithItsLine) {
  writeIges(makeBoxWithVoid(), path("good.igs"));
  std::istringstream in(readText(path("good.igs")));
  std::string line, out;
  bool replaced = false;
  while (std::getline(in, line)) {
    // The first parameter of the first line entity (110), kept in its columns.
    if (!replaced && line.size() >= 73 && line[72] == 'P' && line.rfind("110,", 0) == 0) {
      const size_t a = line.find(',') + 1, b = line.find(',', a);
      std::string data = line.substr(0, 64);
      data.replace(a, b - a, "1.D+400");
      const size_t pad = data.find_last_not_of(' ') + 1;
      if (pad <= 64) {
        line = data.substr(0, pad) + std::string(64 - pad, ' ') + line.substr(64);
        replaced = true;
      }
    }
    out += line + "\n";
  }
  ASSERT_TRUE(replaced);
  std::ofstream(path("overflow.igs"), std::ios::binary) << out;
  expectInputError(path("overflow.igs"), {}, "1.D+400");
}

TEST_F(CadIoTest, DegenerateVoidIsRefusedNotDropped) {
  // With a void of radius 0 the translator returns the solid without its
  // void shell (left loose beside it); taking the solid would lose the void.
  writeStep(makeBoxWithVoid(), path("good.step"));
  const std::string bad = replaceFirst(readText(path("good.step")),
                                       std::regex("(SPHERICAL_SURFACE\\('',#\\d+,)[0-9.E+]+\\)"), "$010.)");
  std::ofstream(path("zero_radius.step"), std::ios::binary) << bad;
  expectInputError(path("zero_radius.step"), {}, "outside its solids");
}

TEST_F(CadIoTest, OpenShellIsNotASolid) {
  const TopoDS_Shape face = BRepBuilderAPI_MakeFace(gp_Pln(gp::XOY()), 0, 10, 0, 10).Shape();
  writeStep(face, path("face.step"));
  expectInputError(path("face.step"), {}, "no solid");
}

TEST_F(CadIoTest, UnknownExtension) {
  writeStep(makeBox(), path("box.dat"));
  expectInputError(path("box.dat"), {}, "extension");
}

TEST_F(CadIoTest, BadDeflectionIsAUsageError) {
  writeStep(makeBox(), path("box.step"));
  CadReadOptions o;
  o.relativeDeflection = 0;
  try {
    readCadSurface(path("box.step"), o);
    ADD_FAILURE() << "zero deflection must be refused";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::Usage) << e.what();
  }
}

// ---------------------------------------------------------------------------
// The committed demo models (apps/make_models.cpp)

TopoDS_Shape readStepShape(const std::string& file) {
  QuietOcct quiet;
  STEPControl_Reader reader;
  EXPECT_EQ(reader.ReadFile(file.c_str()), IFSelect_RetDone);
  reader.TransferRoots();
  return reader.OneShape();
}

TEST(CadModels, BracketIsWatertightGenusZero) {
  const std::string file = t2stest::sourceDir() + "/models/bracket.step";
  const SurfaceMesh s = readCadSurface(file);
  EXPECT_TRUE(isWatertight(s));
  const std::vector<Shell> shells = shellsOf(s);
  ASSERT_EQ(shells.size(), 1u);
  EXPECT_EQ(shells[0].chi, 2);
  const double expected = volumeOf(readStepShape(file));
  EXPECT_NEAR(shells[0].volume, expected, 5e-3 * expected);
  EXPECT_LT(s.F.rows(), 20000) << "the default model stays small";
}

TEST(CadModels, ReadingTwiceGivesIdenticalSurfaces) {
  const std::string file = t2stest::sourceDir() + "/models/bracket.step";
  const SurfaceMesh a = readCadSurface(file), b = readCadSurface(file);
  ASSERT_EQ(a.V.rows(), b.V.rows());
  ASSERT_EQ(a.F.rows(), b.F.rows());
  EXPECT_TRUE(a.V == b.V) << "parallel meshing must not change the result";
  EXPECT_TRUE(a.F == b.F);
}

TEST(CadModels, BlockWithVoidHasTwoShells) {
  const std::string file = t2stest::sourceDir() + "/models/block_with_void.step";
  const SurfaceMesh s = readCadSurface(file);
  EXPECT_TRUE(isWatertight(s));
  const std::vector<Shell> shells = shellsOf(s);
  ASSERT_EQ(shells.size(), 2u);
  for (const Shell& sh : shells) EXPECT_EQ(sh.chi, 2);
  EXPECT_NE(shells[0].volume > 0, shells[1].volume > 0) << "one outer shell (> 0) and one void shell (< 0)";
}

TEST(CadModels, TwoMaterialHasTwoNestedOutwardShells) {
  const SurfaceMesh s = readSurface(t2stest::sourceDir() + "/models/two_material.off");
  EXPECT_TRUE(isWatertight(s));
  const std::vector<Shell> shells = shellsOf(s);
  ASSERT_EQ(shells.size(), 2u);
  for (const Shell& sh : shells) {
    EXPECT_EQ(sh.chi, 2);
    EXPECT_GT(sh.volume, 0) << "each shell bounds its own material region, normals outward";
  }
}

}  // namespace

// t2s_make_models OUTDIR — builds the demo models with OpenCASCADE:
//   bracket.step          genus-0 filleted L-bracket with a boss, a blind hole and two blind pockets
//   block_with_void.step  a rounded block with an internal spherical void (outer shell + inner shell)
//   two_material.off      a rounded box and an off-centre sphere inside it, as two nested closed shells
// Each model is read back with readCadSurface (or checked as a surface) and
// its triangle count, Euler characteristic per shell and timings are printed.
// See models/README.md.
#include <APIHeaderSection_MakeHeader.hxx>
#include <BRepAlgoAPI_Cut.hxx>
#include <BRepAlgoAPI_Fuse.hxx>
#include <BRepBndLib.hxx>
#include <BRepCheck_Analyzer.hxx>
#include <BRepFilletAPI_MakeFillet.hxx>
#include <BRepGProp.hxx>
#include <BRepLib.hxx>
#include <BRepPrimAPI_MakeBox.hxx>
#include <BRepPrimAPI_MakeCylinder.hxx>
#include <BRepPrimAPI_MakeSphere.hxx>
#include <BRep_Tool.hxx>
#include <Bnd_Box.hxx>
#include <GProp_GProps.hxx>
#include <Interface_Static.hxx>
#include <Message.hxx>
#include <Message_Messenger.hxx>
#include <STEPControl_Writer.hxx>
#include <ShapeUpgrade_UnifySameDomain.hxx>
#include <Standard_Failure.hxx>
#include <TCollection_HAsciiString.hxx>
#include <TopExp.hxx>
#include <TopExp_Explorer.hxx>
#include <TopTools_IndexedDataMapOfShapeListOfShape.hxx>
#include <TopTools_ListOfShape.hxx>
#include <TopoDS.hxx>
#include <gp_Ax2.hxx>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <numeric>
#include <set>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "tet2spline/io/cad_io.h"
#include "tet2spline/param/error.h"

namespace fs = std::filesystem;
using tet2spline::SurfaceMesh;

namespace {

[[noreturn]] void die(const std::string& message) { throw std::runtime_error(message); }

TopoDS_Shape unify(const TopoDS_Shape& shape) {
  ShapeUpgrade_UnifySameDomain u(shape, /*UnifyEdges=*/true, /*UnifyFaces=*/true, /*ConcatBSplines=*/false);
  u.Build();
  return u.Shape();
}

TopoDS_Shape fuse(const TopoDS_Shape& a, const TopoDS_Shape& b, const char* what) {
  BRepAlgoAPI_Fuse op(a, b);
  if (!op.IsDone()) die(std::string("fuse failed: ") + what);
  return unify(op.Shape());
}

TopoDS_Shape cut(const TopoDS_Shape& a, const TopoDS_Shape& b, const char* what) {
  BRepAlgoAPI_Cut op(a, b);
  if (!op.IsDone()) die(std::string("cut failed: ") + what);
  return unify(op.Shape());
}

Bnd_Box boxOf(double x0, double y0, double z0, double x1, double y1, double z1) {
  Bnd_Box b;
  b.Update(x0, y0, z0, x1, y1, z1);
  return b;
}

bool inside(const Bnd_Box& inner, const Bnd_Box& outer) {
  double a[6], b[6];
  inner.Get(a[0], a[1], a[2], a[3], a[4], a[5]);
  outer.Get(b[0], b[1], b[2], b[3], b[4], b[5]);
  return a[0] >= b[0] && a[1] >= b[1] && a[2] >= b[2] && a[3] <= b[3] && a[4] <= b[4] && a[5] <= b[5];
}

// Fillets every sharp edge (two distinct faces meeting at a crease) whose
// bounding box lies in `region` (all edges when region is void). Edges that
// already join tangentially (fillet borders) are left alone.
TopoDS_Shape filletSharpEdges(const TopoDS_Shape& shape, const Bnd_Box& region, double radius, const char* what) {
  BRepLib::EncodeRegularity(shape, 1e-4);
  TopTools_IndexedDataMapOfShapeListOfShape edgeFaces;
  TopExp::MapShapesAndAncestors(shape, TopAbs_EDGE, TopAbs_FACE, edgeFaces);
  BRepFilletAPI_MakeFillet fillet(shape);
  int added = 0;
  for (int i = 1; i <= edgeFaces.Extent(); ++i) {
    const TopoDS_Edge edge = TopoDS::Edge(edgeFaces.FindKey(i));
    if (BRep_Tool::Degenerated(edge)) continue;
    const TopTools_ListOfShape& faces = edgeFaces.FindFromIndex(i);
    if (faces.Extent() != 2) continue;
    const TopoDS_Face f1 = TopoDS::Face(faces.First()), f2 = TopoDS::Face(faces.Last());
    if (f1.IsSame(f2)) continue;  // seam
    if (BRep_Tool::Continuity(edge, f1, f2) != GeomAbs_C0) continue;
    if (!region.IsVoid()) {
      Bnd_Box eb;
      BRepBndLib::Add(edge, eb);
      if (!inside(eb, region)) continue;
    }
    fillet.Add(radius, edge);
    ++added;
  }
  if (added == 0) die(std::string("no edge to fillet: ") + what);
  fillet.Build();
  if (!fillet.IsDone()) die(std::string("fillet failed: ") + what);
  return fillet.Shape();
}

TopoDS_Shape box(double x0, double y0, double z0, double x1, double y1, double z1) {
  return BRepPrimAPI_MakeBox(gp_Pnt(x0, y0, z0), gp_Pnt(x1, y1, z1)).Shape();
}

TopoDS_Shape cylinderZ(double x, double y, double z0, double z1, double r) {
  return BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(x, y, z0), gp::DZ()), r, z1 - z0).Shape();
}

/// The filleted CAD part: an L-bracket (base 80 × 50 × 10 mm, upright 12 mm thick
/// and 60 mm tall), every edge filleted, a filleted boss with a blind hole on
/// the base, a blind pocket in the upright and one in the base. Genus 0.
TopoDS_Shape makeBracket() {
  const Bnd_Box all;
  TopoDS_Shape s = fuse(box(0, 0, 0, 80, 50, 10), box(0, 0, 0, 12, 50, 60), "L");
  s = filletSharpEdges(s, all, 2.5, "L-bracket edges");

  // Boss on the base, overlapping into it so that the fuse has no coplanar faces.
  s = fuse(s, cylinderZ(54, 25, 5, 20, 10), "boss");
  s = filletSharpEdges(s, boxOf(43, 14, 9, 65, 36, 21), 1.5, "boss edges");
  // Blind hole in the boss: 8 mm deep from the boss top (z = 20), floor at z = 12.
  s = cut(s, cylinderZ(54, 25, 12, 25, 4), "blind hole");
  s = filletSharpEdges(s, boxOf(49.5, 20.5, 11, 58.5, 29.5, 21), 0.8, "hole edges");

  // Blind pocket 5 mm deep in the upright's outer face (x = 0).
  s = cut(s, box(-1, 15, 25, 5, 35, 48), "upright pocket");
  s = filletSharpEdges(s, boxOf(-0.5, 14.5, 24.5, 5.5, 35.5, 48.5), 1.5, "upright pocket edges");
  // Blind pocket 4 mm deep in the base's top face (z = 10).
  s = cut(s, box(22, 14, 6, 36, 36, 11), "base pocket");
  s = filletSharpEdges(s, boxOf(21.5, 13.5, 5.5, 36.5, 36.5, 10.5), 1.5, "base pocket edges");
  return s;
}

TopoDS_Shape makeRoundedBox(double x, double y, double z, double radius) {
  return filletSharpEdges(box(0, 0, 0, x, y, z), Bnd_Box(), radius, "rounded box");
}

/// A 40 × 30 × 30 mm rounded block with a spherical void (radius 8 mm) at its centre.
TopoDS_Shape makeBlockWithVoid() {
  TopoDS_Shape block = makeRoundedBox(40, 30, 30, 4);
  return cut(block, BRepPrimAPI_MakeSphere(gp_Pnt(20, 15, 15), 8).Shape(), "spherical void");
}

/// The two-material model as a solid: rounded 40 × 30 × 30 mm box minus an
/// off-centre sphere (radius 7 mm at (26, 13, 16)); its shells are the two
/// material interfaces.
TopoDS_Shape makeInnerSphere() { return BRepPrimAPI_MakeSphere(gp_Pnt(26, 13, 16), 7).Shape(); }
TopoDS_Shape makeTwoMaterial() {
  TopoDS_Shape block = makeRoundedBox(40, 30, 30, 5);
  return cut(block, makeInnerSphere(), "inner sphere");
}

void requireValid(const TopoDS_Shape& s, const char* what) {
  if (!BRepCheck_Analyzer(s).IsValid()) die(std::string(what) + " is not a valid solid");
  int solids = 0;
  for (TopExp_Explorer e(s, TopAbs_SOLID); e.More(); e.Next()) ++solids;
  if (solids != 1) die(std::string(what) + " has " + std::to_string(solids) + " solids, expected 1");
}

// Writes to a temporary name and renames, with a fixed header so that the
// output is the same on every run.
void writeStep(const TopoDS_Shape& shape, const fs::path& path) {
  // The writer's statistics go to the default messenger: keep stdout for our summary.
  const Handle(Message_Messenger) messenger = Message::DefaultMessenger();
  const Message_SequenceOfPrinters printers = messenger->Printers();
  messenger->ChangePrinters().Clear();
  struct Restore {
    const Handle(Message_Messenger)& m;
    const Message_SequenceOfPrinters& p;
    ~Restore() { m->ChangePrinters() = p; }
  } restore{messenger, printers};
  STEPControl_Writer writer;
  Interface_Static::SetCVal("write.step.schema", "AP214IS");
  Interface_Static::SetCVal("write.step.unit", "MM");
  if (writer.Transfer(shape, STEPControl_AsIs) != IFSelect_RetDone) die("STEP transfer failed: " + path.string());
  APIHeaderSection_MakeHeader header(writer.Model());
  header.SetName(new TCollection_HAsciiString(path.filename().string().c_str()));
  header.SetTimeStamp(new TCollection_HAsciiString("2026-01-01T00:00:00"));
  header.SetOriginatingSystem(new TCollection_HAsciiString("tet2spline t2s_make_models"));
  const fs::path tmp = path.string() + ".tmp";
  if (writer.Write(tmp.string().c_str()) != IFSelect_RetDone) die("cannot write " + tmp.string());
  fs::rename(tmp, path);
}

void writeOff(const SurfaceMesh& s, const fs::path& path) {
  const fs::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp);
    if (!out) die("cannot write " + tmp.string());
    out << "OFF\n" << s.V.rows() << ' ' << s.F.rows() << " 0\n";
    out.precision(9);
    for (Eigen::Index i = 0; i < s.V.rows(); ++i) out << s.V(i, 0) << ' ' << s.V(i, 1) << ' ' << s.V(i, 2) << '\n';
    for (Eigen::Index f = 0; f < s.F.rows(); ++f) out << "3 " << s.F(f, 0) << ' ' << s.F(f, 1) << ' ' << s.F(f, 2) << '\n';
    if (!out) die("cannot write " + tmp.string());
  }
  fs::rename(tmp, path);
}

// Connected components of the triangles (sharing a vertex).
std::vector<int> shellOfFaces(const SurfaceMesh& s, int& count) {
  std::vector<int> parent(static_cast<size_t>(s.V.rows()));
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  for (Eigen::Index f = 0; f < s.F.rows(); ++f)
    for (int k = 1; k < 3; ++k) parent[find(s.F(f, k))] = find(s.F(f, 0));
  std::map<int, int> id;
  std::vector<int> shell(static_cast<size_t>(s.F.rows()));
  for (Eigen::Index f = 0; f < s.F.rows(); ++f) {
    auto [it, inserted] = id.emplace(find(s.F(f, 0)), static_cast<int>(id.size()));
    shell[f] = it->second;
  }
  count = static_cast<int>(id.size());
  return shell;
}

struct ShellSummary {
  int chi = 0;
  double volume = 0;
};

std::vector<ShellSummary> summarize(const SurfaceMesh& s) {
  int n = 0;
  const std::vector<int> shell = shellOfFaces(s, n);
  std::vector<ShellSummary> out(n);
  std::vector<std::set<int>> verts(n);
  std::vector<std::set<std::pair<int, int>>> edges(n);
  std::vector<int> faces(n, 0);
  for (Eigen::Index f = 0; f < s.F.rows(); ++f) {
    const int k = shell[f];
    ++faces[k];
    for (int j = 0; j < 3; ++j) {
      const int a = s.F(f, j), b = s.F(f, (j + 1) % 3);
      verts[k].insert(a);
      edges[k].insert({std::min(a, b), std::max(a, b)});
    }
    const Eigen::Vector3d a = s.V.row(s.F(f, 0)), b = s.V.row(s.F(f, 1)), c = s.V.row(s.F(f, 2));
    out[k].volume += a.dot(b.cross(c)) / 6;
  }
  for (int k = 0; k < n; ++k)
    out[k].chi = static_cast<int>(verts[k].size()) - static_cast<int>(edges[k].size()) + faces[k];
  return out;
}

double volumeOf(const TopoDS_Shape& s) {
  GProp_GProps props;
  BRepGProp::VolumeProperties(s, props);
  return props.Mass();
}

void report(const std::string& name, const SurfaceMesh& s, double cadVolume, double seconds) {
  const std::vector<ShellSummary> shells = summarize(s);
  double volume = 0;
  for (const auto& sh : shells) volume += sh.volume;
  std::printf("%-21s %5ld vertices %5ld triangles, read+tessellate %.3f s, volume %.1f mm^3 (B-rep %.1f), shells:",
              name.c_str(), static_cast<long>(s.V.rows()), static_cast<long>(s.F.rows()), seconds, volume, cadVolume);
  for (const auto& sh : shells) std::printf(" [chi %d, volume %.1f]", sh.chi, sh.volume);
  std::printf("\n");
}

SurfaceMesh readTimed(const fs::path& path, double& seconds) {
  const auto t0 = std::chrono::steady_clock::now();
  SurfaceMesh s = tet2spline::readCadSurface(path.string());
  seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: t2s_make_models OUTDIR   (writes bracket.step, block_with_void.step, two_material.off)\n";
    return 2;
  }
  try {
    const fs::path dir = argv[1];
    fs::create_directories(dir);
    double seconds = 0;

    const TopoDS_Shape bracket = makeBracket();
    requireValid(bracket, "bracket");
    writeStep(bracket, dir / "bracket.step");
    const SurfaceMesh bracketSurface = readTimed(dir / "bracket.step", seconds);
    report("bracket.step", bracketSurface, volumeOf(bracket), seconds);

    const TopoDS_Shape block = makeBlockWithVoid();
    requireValid(block, "block_with_void");
    writeStep(block, dir / "block_with_void.step");
    const SurfaceMesh blockSurface = readTimed(dir / "block_with_void.step", seconds);
    report("block_with_void.step", blockSurface, volumeOf(block), seconds);

    // Tessellate through the same reader as the CAD inputs, then turn the
    // inner shell outward: in a two-material surface every shell is the
    // outward boundary of the region it encloses directly.
    const TopoDS_Shape two = makeTwoMaterial();
    requireValid(two, "two_material");
    const fs::path tmpStep = dir / "two_material.tmp.step";
    writeStep(two, tmpStep);
    SurfaceMesh surface = readTimed(tmpStep, seconds);
    fs::remove(tmpStep);
    int shells = 0;
    const std::vector<int> shell = shellOfFaces(surface, shells);
    if (shells != 2) die("two_material: expected 2 shells, got " + std::to_string(shells));
    const std::vector<ShellSummary> before = summarize(surface);
    for (Eigen::Index f = 0; f < surface.F.rows(); ++f)
      if (before[shell[f]].volume < 0) std::swap(surface.F(f, 1), surface.F(f, 2));
    writeOff(surface, dir / "two_material.off");
    // Both shells now enclose positive volume: box + sphere for the B-rep check.
    report("two_material.off", surface, volumeOf(two) + 2 * volumeOf(makeInnerSphere()), seconds);
    return 0;
  } catch (const tet2spline::Error& e) {
    std::cerr << "t2s_make_models: " << e.what() << '\n';
    return e.exitStatus();
  } catch (const Standard_Failure& e) {
    std::cerr << "t2s_make_models: OpenCASCADE failed: " << e.GetMessageString() << '\n';
    return 5;
  } catch (const std::exception& e) {
    std::cerr << "t2s_make_models: " << e.what() << '\n';
    return 5;
  }
}

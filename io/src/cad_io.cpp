// STEP and IGES input: OpenCASCADE reads the B-rep, picks one solid, repairs
// it if needed, tessellates it and returns a watertight triangle surface.
//
// Watertightness comes from the B-rep topology, not from welding: BRepMesh
// discretises every edge once, and each face's triangulation references that
// discretisation through BRep_Tool::PolygonOnTriangulation. Mapping every
// face's boundary nodes onto one global node list per edge (and one node per
// TopoDS_Vertex) therefore glues the faces exactly. Welding coincident points
// is only a fallback for shapes whose polygons are missing or inconsistent.
//
// Orientation: triangles follow the face orientation inside the solid, so the
// normals point out of the material on every shell: the outer shell encloses
// a positive volume, each void shell a negative one.
#include "tet2spline/io/cad_io.h"

#include <signal.h>

#include <algorithm>
#include <array>
#include <cfenv>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <iterator>
#include <cstdint>
#include <fstream>
#include <numeric>
#include <set>
#include <type_traits>
#include <unordered_map>
#include <vector>

#include <Eigen/Geometry>

#include <BRepBndLib.hxx>
#include <BRepBuilderAPI_MakeSolid.hxx>
#include <BRepBuilderAPI_Sewing.hxx>
#include <BRepCheck_Analyzer.hxx>
#include <BRepClass3d_SolidClassifier.hxx>
#include <BRepLib.hxx>
#include <BRepMesh_IncrementalMesh.hxx>
#include <BRepTools.hxx>
#include <BRep_Builder.hxx>
#include <BRep_Tool.hxx>
#include <Bnd_Box.hxx>
#include <Geom_Curve.hxx>
#include <IFSelect_ReturnStatus.hxx>
#include <IGESControl_Reader.hxx>
#include <Interface_Check.hxx>
#include <Interface_CheckIterator.hxx>
#include <Interface_InterfaceModel.hxx>
#include <Message.hxx>
#include <Message_Messenger.hxx>
#include <OSD.hxx>
#include <Poly_PolygonOnTriangulation.hxx>
#include <Poly_Triangulation.hxx>
#include <STEPControl_Reader.hxx>
#include <StepGeom_CartesianPoint.hxx>
#include <StepShape_FaceSurface.hxx>
#include <Transfer_TransientProcess.hxx>
#include <ShapeFix_Shape.hxx>
#include <ShapeFix_Solid.hxx>
#include <Standard_Failure.hxx>
#include <TopExp.hxx>
#include <TopExp_Explorer.hxx>
#include <TopTools_IndexedMapOfShape.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Edge.hxx>
#include <TopoDS_Face.hxx>
#include <TopoDS_Shell.hxx>
#include <TopoDS_Solid.hxx>
#include <TopoDS_TShape.hxx>
#include <TopoDS_Vertex.hxx>
#include <XSControl_TransferReader.hxx>
#include <XSControl_WorkSession.hxx>

#include "tet2spline/io/mesh_io.h"
#include "tet2spline/param/error.h"

namespace tet2spline {

namespace {

[[noreturn]] void fail(const std::string& path, const std::string& message) { throwInputError(path, 0, message); }

// OCCT's translators report to the default messenger, which prints to stdout;
// library code prints nothing unless asked (style.md), so the printers are
// detached while a file is read. Not thread-safe: the messenger is global.
class SilenceOcctMessages {
 public:
  SilenceOcctMessages() : messenger_(Message::DefaultMessenger()) {
    if (messenger_.IsNull()) return;
    saved_ = messenger_->Printers();
    messenger_->ChangePrinters().Clear();
  }
  ~SilenceOcctMessages() {
    if (!messenger_.IsNull()) messenger_->ChangePrinters() = saved_;
  }
  SilenceOcctMessages(const SilenceOcctMessages&) = delete;
  SilenceOcctMessages& operator=(const SilenceOcctMessages&) = delete;

 private:
  Handle(Message_Messenger) messenger_;
  Message_SequenceOfPrinters saved_;
};

// OCCT still dereferences null pointers on some malformed input. While a
// file is read, OCCT's own handlers (OSD::SetSignal) turn SIGSEGV, SIGBUS,
// SIGILL and SIGFPE into Standard_Failure exceptions, which the translators
// catch per entity and readCadSurface catches overall. Handlers that the
// application installed itself are kept (SetUnhandled), and every previous
// handler and the floating-point environment are restored afterwards.
class OcctSignalGuard {
 public:
  OcctSignalGuard() {
    fegetenv(&fenv_);
    for (int s = 1; s < kSignals; ++s) saved_[s].valid = sigaction(s, nullptr, &saved_[s].action) == 0;
    OSD::SetSignal(OSD_SignalMode_SetUnhandled, /*theFloatingSignal=*/false);
  }
  ~OcctSignalGuard() {
    for (int s = 1; s < kSignals; ++s)
      if (saved_[s].valid) sigaction(s, &saved_[s].action, nullptr);
    fesetenv(&fenv_);
  }
  OcctSignalGuard(const OcctSignalGuard&) = delete;
  OcctSignalGuard& operator=(const OcctSignalGuard&) = delete;

 private:
  static constexpr int kSignals = 32;
  struct Saved {
    struct sigaction action {};
    bool valid = false;
  };
  Saved saved_[kSignals];
  fenv_t fenv_{};
};

std::string trimmed(std::string s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  const auto e = s.find_last_not_of(" \t\r\n");
  return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
}

const char* statusName(IFSelect_ReturnStatus s) {
  switch (s) {
    case IFSelect_RetVoid: return "nothing to read";
    case IFSelect_RetDone: return "done";
    case IFSelect_RetError: return "read error";
    case IFSelect_RetFail: return "read failure";
    case IFSelect_RetStop: return "read stopped";
  }
  return "unknown status";
}

void requireReadableFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) fail(path, "cannot open file");
  if (in.tellg() <= 0) fail(path, "empty file");
}

// OCCT's translators dereference null handles when an entity has the wrong
// type or too few parameters, so a file whose entities fail the load checks
// is refused before any transfer.
template <class Reader>
void requireLoadChecksPass(Reader& reader, const std::string& path, const char* format) {
  const Interface_CheckIterator checks = reader.WS()->ModelCheckList(/*complete=*/false);
  int failed = 0;
  std::string first;
  for (checks.Start(); checks.More(); checks.Next()) {
    const Handle(Interface_Check)& check = checks.Value();
    if (!check->HasFailed()) continue;
    if (failed++ == 0) {
      Handle(TCollection_HAsciiString) label;
      if (!check->Entity().IsNull() && !reader.Model().IsNull()) label = reader.Model()->StringLabel(check->Entity());
      first = (label.IsNull() ? std::string() : std::string(label->ToCString()) + ": ") +
              (check->NbFails() > 0 ? check->CFail(1) : "invalid entity");
    }
  }
  if (failed > 0)
    fail(path, std::string("malformed ") + format + " file: " + std::to_string(failed) +
                   (failed == 1 ? " entity fails" : " entities fail") + " to load (first: " + trimmed(first) + ")");
}

// Any real beyond 1e15 in magnitude, or one that overflows (1.E+400), is
// refused with its line: no part needs it, and OCCT's geometry code loops
// forever or crashes on such values. Only tokens with a '.' or an exponent
// are reals.
bool isAbsurdReal(std::string token) {
  if (token.find_first_of("0123456789") == std::string::npos || token.find_first_of(".EeDd") == std::string::npos)
    return false;
  std::replace(token.begin(), token.end(), 'D', 'E');  // IGES exponents
  std::replace(token.begin(), token.end(), 'd', 'e');
  char* end = nullptr;
  const double v = std::strtod(token.c_str(), &end);
  if (end == token.c_str()) return false;
  return !std::isfinite(v) || std::abs(v) > 1e15;
}

[[noreturn]] void absurdReal(const std::string& path, long line, const std::string& token) {
  throwInputError(path, line, "real number " + token.substr(0, 40) + " is out of range (|x| > 1e15)");
}

// STEP: a character scan that skips quoted strings and comments.
void requireSaneStepNumbers(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "cannot open file");
  long line = 1;
  bool inString = false, inComment = false;
  char prev = '\n';
  std::string token;
  std::istreambuf_iterator<char> it(in), end;
  for (; it != end; ++it) {
    const char c = *it;
    if (!token.empty()) {
      if (std::isdigit(static_cast<unsigned char>(c)) || c == '.' || c == 'E' || c == 'e' || c == '+' || c == '-') {
        if (token.size() < 400) token += c;
        prev = c;
        continue;
      }
      if (isAbsurdReal(token)) absurdReal(path, line, token);
      token.clear();
    }
    if (c == '\n') ++line;
    if (inComment) {
      if (prev == '*' && c == '/') inComment = false;
    } else if (inString) {
      if (c == '\'') inString = false;  // '' (an escaped quote) closes and reopens
    } else if (c == '\'') {
      inString = true;
    } else if (prev == '/' && c == '*') {
      inComment = true;
    } else if ((std::isdigit(static_cast<unsigned char>(c)) || c == '-' || c == '+' || c == '.') &&
               (prev == '(' || prev == ',' || prev == '=' || std::isspace(static_cast<unsigned char>(prev)))) {
      token = c;
    }
    prev = c;
  }
  if (!token.empty() && isAbsurdReal(token)) absurdReal(path, line, token);
}

// IGES: the parameter-data lines ('P' in column 73), columns 1-64, split at
// ',' and ';'; Hollerith strings (nH...) are skipped.
void requireSaneIgesNumbers(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "cannot open file");
  std::string text;
  long line = 0;
  while (std::getline(in, text)) {
    ++line;
    if (text.size() < 73 || text[72] != 'P') continue;
    const std::string data = text.substr(0, 64);
    size_t begin = 0;
    while (begin <= data.size()) {
      size_t stop = data.find_first_of(",;", begin);
      if (stop == std::string::npos) stop = data.size();
      const std::string token = trimmed(data.substr(begin, stop - begin));
      if (!token.empty() && token.find_first_of("Hh") == std::string::npos && isAbsurdReal(token))
        absurdReal(path, line, token);
      begin = stop + 1;
    }
  }
}

// Coordinates far beyond any part (1e10 in the file's unit) send OCCT's
// projections into endless loops; refuse them before the transfer.
void requireSaneStepPoints(const STEPControl_Reader& reader, const std::string& path) {
  const Handle(Interface_InterfaceModel) model = reader.Model();
  if (model.IsNull()) return;
  for (int i = 1; i <= model->NbEntities(); ++i) {
    const Handle(StepGeom_CartesianPoint) point = Handle(StepGeom_CartesianPoint)::DownCast(model->Value(i));
    if (point.IsNull()) continue;  // (Coordinates() would build an array and throw for 2D points)
    for (int k = 1; k <= point->NbCoordinates(); ++k) {
      const double v = point->CoordinatesValue(k);
      if (!std::isfinite(v) || std::abs(v) > 1e10)
        fail(path, std::string("malformed STEP file: ") + model->StringLabel(point)->ToCString() +
                       " has a non-finite or absurdly large coordinate");
    }
  }
}

// A translator that cannot build an entity skips it and carries on: a face
// (or a whole void) would silently go missing. Any transfer failure, or
// fewer translated faces than the STEP file's face entities, is refused.
template <class Reader>
void requireCompleteTransfer(Reader& reader, const TopoDS_Shape& shape, const std::string& path, const char* format) {
  const Handle(XSControl_TransferReader) transfer = reader.WS()->TransferReader();
  if (!transfer.IsNull() && !transfer->TransientProcess().IsNull()) {
    const Interface_CheckIterator checks = transfer->TransientProcess()->CheckList(/*erronly=*/true);
    int failed = 0;
    std::string first;
    for (checks.Start(); checks.More(); checks.Next()) {
      const Handle(Interface_Check)& check = checks.Value();
      if (!check->HasFailed()) continue;
      if (failed++ == 0) {
        Handle(TCollection_HAsciiString) label;
        if (!check->Entity().IsNull() && !reader.Model().IsNull()) label = reader.Model()->StringLabel(check->Entity());
        first = (label.IsNull() ? std::string() : std::string(label->ToCString()) + ": ") + check->CFail(1);
      }
    }
    if (failed > 0)
      fail(path, std::string("the ") + format + " translator failed on " + std::to_string(failed) +
                     (failed == 1 ? " entity" : " entities") + " (first: " + trimmed(first) + ")");
  }
  if constexpr (std::is_same_v<Reader, STEPControl_Reader>) {
    int stepFaces = 0;
    const Handle(Interface_InterfaceModel) model = reader.Model();
    for (int i = 1; i <= model->NbEntities(); ++i)
      if (model->Value(i)->IsKind(STANDARD_TYPE(StepShape_FaceSurface))) ++stepFaces;
    std::set<const TopoDS_TShape*> faces;  // distinct faces; instances of one part share them
    for (TopExp_Explorer e(shape, TopAbs_FACE); e.More(); e.Next()) faces.insert(e.Current().TShape().get());
    if (static_cast<int>(faces.size()) < stepFaces)
      fail(path, "only " + std::to_string(faces.size()) + " of the STEP file's " + std::to_string(stepFaces) +
                     " faces could be translated");
  }
}

template <class Reader>
TopoDS_Shape translate(Reader& reader, const std::string& path, const char* format) {
  const IFSelect_ReturnStatus status = reader.ReadFile(path.c_str());
  if (status != IFSelect_RetDone)
    fail(path, std::string("not a readable ") + format + " file (" + statusName(status) + ")");
  requireLoadChecksPass(reader, path, format);
  if constexpr (std::is_same_v<Reader, STEPControl_Reader>) {
    requireSaneStepNumbers(path);
    requireSaneStepPoints(reader, path);
  } else {
    requireSaneIgesNumbers(path);
  }
  if (reader.NbRootsForTransfer() <= 0) fail(path, std::string(format) + " file holds no shape");
  reader.TransferRoots();
  if (reader.NbShapes() <= 0) fail(path, std::string("no shape could be translated from the ") + format + " file");
  TopoDS_Shape shape = reader.OneShape();
  if (shape.IsNull()) fail(path, std::string("no shape could be translated from the ") + format + " file");
  requireCompleteTransfer(reader, shape, path, format);
  return shape;
}

TopoDS_Shape readShape(const std::string& path) {
  const FileFormat format = formatFromPath(path);
  SilenceOcctMessages quiet;
  if (format == FileFormat::Step) {
    STEPControl_Reader reader;
    return translate(reader, path, "STEP");
  }
  if (format == FileFormat::Iges) {
    IGESControl_Reader reader;
    return translate(reader, path, "IGES");
  }
  fail(path, "unknown CAD file extension (expected .step, .stp, .iges or .igs)");
}

// Translators accept coordinates such as 1.E+400 (inf); OCCT's algorithms
// then crash rather than throw, so such files are refused up front.
void requireFiniteGeometry(const TopoDS_Shape& shape, const std::string& path) {
  constexpr double kHuge = 1e12;
  auto bad = [&](double v) { return !std::isfinite(v) || std::abs(v) > kHuge; };
  for (TopExp_Explorer e(shape, TopAbs_VERTEX); e.More(); e.Next()) {
    const gp_Pnt p = BRep_Tool::Pnt(TopoDS::Vertex(e.Current()));
    if (bad(p.X()) || bad(p.Y()) || bad(p.Z()))
      fail(path, "a vertex has a non-finite or absurdly large coordinate");
  }
  for (TopExp_Explorer e(shape, TopAbs_EDGE); e.More(); e.Next()) {
    const TopoDS_Edge edge = TopoDS::Edge(e.Current());
    if (BRep_Tool::Degenerated(edge)) continue;
    double first = 0, last = 0;
    const Handle(Geom_Curve) curve = BRep_Tool::Curve(edge, first, last);
    if (curve.IsNull()) continue;
    if (bad(first) || bad(last)) fail(path, "an edge has a non-finite parameter range");
    for (double t : {first, 0.5 * (first + last), last}) {
      const gp_Pnt p = curve->Value(t);
      if (bad(p.X()) || bad(p.Y()) || bad(p.Z())) fail(path, "an edge curve has non-finite points");
    }
  }
  Bnd_Box box;
  BRepBndLib::Add(shape, box);
  if (box.IsVoid()) return;
  double b[6];
  box.Get(b[0], b[1], b[2], b[3], b[4], b[5]);
  for (double v : b)
    if (bad(v)) fail(path, "the shape's bounding box is not finite");
}

double diagonal(const TopoDS_Shape& shape) {
  Bnd_Box box;
  BRepBndLib::Add(shape, box);
  if (box.IsVoid()) return 0;
  return std::sqrt(box.SquareExtent());
}

int countFaces(const TopoDS_Shape& shape) {
  int n = 0;
  for (TopExp_Explorer e(shape, TopAbs_FACE); e.More(); e.Next()) ++n;
  return n;
}

// A point on the shell (one of its vertices), for nesting tests.
gp_Pnt pointOf(const TopoDS_Shape& shell) {
  TopExp_Explorer e(shell, TopAbs_VERTEX);
  return BRep_Tool::Pnt(TopoDS::Vertex(e.Current()));
}

// Files without solids (IGES writes faces by default) are sewn; every closed
// shell becomes a solid, and a shell nested inside another one at odd depth
// becomes a void of its innermost container.
std::vector<TopoDS_Solid> solidsFromFaces(const TopoDS_Shape& shape, const std::string& path) {
  const int faces = countFaces(shape);
  if (faces == 0) fail(path, "the file holds no solid and no faces");
  const double diag = diagonal(shape);
  BRepBuilderAPI_Sewing sewing(std::max(1e-7, 1e-5 * diag));
  for (TopExp_Explorer e(shape, TopAbs_FACE); e.More(); e.Next()) sewing.Add(e.Current());
  sewing.Perform();
  const TopoDS_Shape sewn = sewing.SewedShape();

  // Candidate shells: the sewn shells, plus one per face left outside any
  // shell (a sphere or a torus is one face that closes on itself).
  std::vector<TopoDS_Shell> candidates;
  for (TopExp_Explorer e(sewn, TopAbs_SHELL); e.More(); e.Next()) candidates.push_back(TopoDS::Shell(e.Current()));
  BRep_Builder builder;
  for (TopExp_Explorer e(sewn, TopAbs_FACE, TopAbs_SHELL); e.More(); e.Next()) {
    TopoDS_Shell shell;
    builder.MakeShell(shell);
    builder.Add(shell, e.Current());
    candidates.push_back(shell);
  }

  std::vector<TopoDS_Shell> shells;
  std::vector<TopoDS_Solid> single;  // each closed shell as a solid of its own
  int openShells = 0;
  ShapeFix_Solid fixSolid;
  for (const TopoDS_Shell& shell : candidates) {
    if (!BRep_Tool::IsClosed(shell)) {
      ++openShells;
      continue;
    }
    TopoDS_Solid solid = fixSolid.SolidFromShell(shell);  // oriented so that it is finite
    TopExp_Explorer s(solid, TopAbs_SHELL);
    shells.push_back(TopoDS::Shell(s.Current()));
    single.push_back(solid);
  }
  if (shells.empty())
    fail(path, "the file holds no solid, and its " + std::to_string(faces) +
                   " faces do not close a volume after sewing (" + std::to_string(sewing.NbFreeEdges()) +
                   " free edges, " + std::to_string(openShells) + " open shells)");

  const size_t n = shells.size();
  std::vector<std::vector<size_t>> containers(n);  // shells whose solid holds shell i
  for (size_t i = 0; i < n; ++i)
    for (size_t j = 0; j < n; ++j) {
      if (i == j) continue;
      BRepClass3d_SolidClassifier classifier(single[j], pointOf(shells[i]), 1e-7 * diag);
      if (classifier.State() == TopAbs_IN) containers[i].push_back(j);
    }
  // A shell inside an even number of others is an outer shell; one inside an
  // odd number is a void of its innermost container (held by the most others).
  std::vector<std::vector<size_t>> voidsOf(n);
  for (size_t i = 0; i < n; ++i) {
    if (containers[i].size() % 2 == 0) continue;
    size_t parent = containers[i].front();
    for (size_t c : containers[i])
      if (containers[c].size() > containers[parent].size()) parent = c;
    voidsOf[parent].push_back(i);
  }
  std::vector<TopoDS_Solid> solids;
  for (size_t i = 0; i < n; ++i) {
    if (containers[i].size() % 2 != 0) continue;
    BRepBuilderAPI_MakeSolid maker(shells[i]);
    for (size_t v : voidsOf[i]) maker.Add(shells[v]);
    TopoDS_Solid solid = maker.Solid();
    BRepLib::OrientClosedSolid(solid);
    solids.push_back(solid);
  }
  return solids;
}

// Shells that hold at least one face.
int countShells(const TopoDS_Shape& solid) {
  int n = 0;
  for (TopExp_Explorer e(solid, TopAbs_SHELL); e.More(); e.Next())
    if (TopExp_Explorer(e.Current(), TopAbs_FACE).More()) ++n;
  return n;
}

// BRepCheck first; ShapeFix only when the check fails, and only a repair that
// keeps every shell counts (ShapeFix may "repair" a bad void by dropping it).
TopoDS_Solid validSolid(const TopoDS_Solid& solid, const std::string& path, int index) {
  if (BRepCheck_Analyzer(solid).IsValid()) return solid;
  const std::string which = "solid " + std::to_string(index);
  ShapeFix_Shape fix(solid);
  fix.Perform();
  const TopoDS_Shape fixed = fix.Shape();
  TopExp_Explorer e(fixed, TopAbs_SOLID);
  if (e.More()) {
    TopoDS_Solid repaired = TopoDS::Solid(e.Current());
    e.Next();
    if (!e.More() && BRepCheck_Analyzer(repaired).IsValid()) {
      if (countShells(repaired) != countShells(solid))
        fail(path, which + " is not a valid B-rep (BRepCheck_Analyzer); ShapeFix repairs it only by dropping shells (" +
                       std::to_string(countShells(solid)) + " -> " + std::to_string(countShells(repaired)) + ")");
      return repaired;
    }
  }
  fail(path, which + " is not a valid B-rep (BRepCheck_Analyzer) and ShapeFix could not repair it");
}

// ---------------------------------------------------------------------------
// Tessellation into one indexed surface.

struct Soup {
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector3i> triangles;
  int add(const gp_Pnt& p) {
    points.emplace_back(p.X(), p.Y(), p.Z());
    return static_cast<int>(points.size()) - 1;
  }
};

Eigen::Vector3d toEigen(const gp_Pnt& p) { return {p.X(), p.Y(), p.Z()}; }

void addFaceTriangles(const TopoDS_Face& face, const Poly_Triangulation& tri, const gp_Trsf& trsf,
                      const std::vector<int>& global, Soup& soup) {
  // Poly_Triangulation triangles turn counter-clockwise in the surface's (u,v)
  // space, i.e. around the surface normal; a REVERSED face (and a mirroring
  // location) flips that.
  const bool flip = (face.Orientation() == TopAbs_REVERSED) != trsf.IsNegative();
  for (int t = 1; t <= tri.NbTriangles(); ++t) {
    int a, b, c;
    tri.Triangle(t).Get(a, b, c);
    if (flip) std::swap(b, c);
    const Eigen::Vector3i g(global[a], global[b], global[c]);
    if (g[0] == g[1] || g[1] == g[2] || g[2] == g[0]) continue;  // collapsed at a degenerated edge (pole, apex)
    soup.triangles.push_back(g);
  }
}

// Shares the nodes of every edge and vertex between the faces that use it.
// Returns false when a face lacks a polygon on triangulation or the polygons
// of two faces disagree, so that the caller can fall back to welding.
bool shareEdgeNodes(const TopoDS_Solid& solid, Soup& soup) {
  TopTools_IndexedMapOfShape vertices, edges;
  TopExp::MapShapes(solid, TopAbs_VERTEX, vertices);
  TopExp::MapShapes(solid, TopAbs_EDGE, edges);
  std::vector<int> vertexNode(vertices.Extent() + 1, -1);
  std::vector<std::vector<int>> edgeNodes(edges.Extent() + 1);
  auto vertexId = [&](const TopoDS_Vertex& v) {
    int& id = vertexNode[vertices.FindIndex(v)];
    if (id < 0) id = soup.add(BRep_Tool::Pnt(v));
    return id;
  };

  for (TopExp_Explorer fe(solid, TopAbs_FACE); fe.More(); fe.Next()) {
    const TopoDS_Face face = TopoDS::Face(fe.Current());
    TopLoc_Location loc;
    const Handle(Poly_Triangulation)& tri = BRep_Tool::Triangulation(face, loc);
    if (tri.IsNull()) return false;
    const gp_Trsf trsf = loc.Transformation();
    auto node = [&](int i) { return tri->Node(i).Transformed(trsf); };
    std::vector<int> global(tri->NbNodes() + 1, -1);

    for (TopExp_Explorer ee(face, TopAbs_EDGE); ee.More(); ee.Next()) {
      const TopoDS_Edge edge = TopoDS::Edge(ee.Current());
      // For a seam edge the orientation selects which of its two polygons.
      const Handle(Poly_PolygonOnTriangulation)& poly = BRep_Tool::PolygonOnTriangulation(edge, tri, loc);
      if (poly.IsNull() || poly->NbNodes() < 2) return false;
      const int n = poly->NbNodes();
      TopoDS_Vertex v1, v2;
      TopExp::Vertices(edge, v1, v2);  // start and end of the edge's parameter range
      if (v1.IsNull() || v2.IsNull()) return false;
      if (BRep_Tool::Degenerated(edge)) {
        const int id = vertexId(v1);
        for (int k = 1; k <= n; ++k) global[poly->Node(k)] = id;
        continue;
      }
      std::vector<int>& shared = edgeNodes[edges.FindIndex(edge)];
      const double tol = 4 * BRep_Tool::Tolerance(edge) + 1e-9;
      if (shared.empty()) {
        // Polygons run along the edge's parameter; check it against the
        // vertices rather than trust it.
        bool reversed = false;
        if (!v1.IsSame(v2)) {
          const gp_Pnt p = node(poly->Node(1));
          reversed = p.Distance(BRep_Tool::Pnt(v2)) < p.Distance(BRep_Tool::Pnt(v1));
        }
        shared.resize(n);
        shared[0] = vertexId(reversed ? v2 : v1);
        shared[n - 1] = vertexId(reversed ? v1 : v2);
        for (int k = 1; k + 1 < n; ++k) shared[k] = soup.add(node(poly->Node(k + 1)));
      } else if (static_cast<int>(shared.size()) != n) {
        return false;
      }
      // Match this face's polygon to the shared nodes forwards or backwards,
      // whichever is closer, and insist that it is close.
      double forward = 0, backward = 0;
      for (int k = 0; k < n; ++k) {
        const Eigen::Vector3d p = toEigen(node(poly->Node(k + 1)));
        forward = std::max(forward, (p - soup.points[shared[k]]).norm());
        backward = std::max(backward, (p - soup.points[shared[n - 1 - k]]).norm());
      }
      const bool backwards = backward < forward;
      if (std::min(forward, backward) > tol + BRep_Tool::Tolerance(v1) + BRep_Tool::Tolerance(v2)) return false;
      for (int k = 0; k < n; ++k) {
        const int g = shared[backwards ? n - 1 - k : k];
        int& slot = global[poly->Node(k + 1)];
        if (slot >= 0 && slot != g) return false;  // one face node on two different edge nodes
        slot = g;
      }
    }
    for (int i = 1; i <= tri->NbNodes(); ++i)
      if (global[i] < 0) global[i] = soup.add(node(i));
    addFaceTriangles(face, *tri, trsf, global, soup);
  }
  return true;
}

// Fallback: every face gets its own nodes, then points closer than `tol` are
// merged (hash grid of cell size tol, union-find).
void weldFaces(const TopoDS_Solid& solid, double tol, Soup& soup, const std::string& path) {
  for (TopExp_Explorer fe(solid, TopAbs_FACE); fe.More(); fe.Next()) {
    const TopoDS_Face face = TopoDS::Face(fe.Current());
    TopLoc_Location loc;
    const Handle(Poly_Triangulation)& tri = BRep_Tool::Triangulation(face, loc);
    if (tri.IsNull()) fail(path, "a face of the solid could not be tessellated");
    const gp_Trsf trsf = loc.Transformation();
    std::vector<int> global(tri->NbNodes() + 1, -1);
    for (int i = 1; i <= tri->NbNodes(); ++i) global[i] = soup.add(tri->Node(i).Transformed(trsf));
    addFaceTriangles(face, *tri, trsf, global, soup);
  }
  const int n = static_cast<int>(soup.points.size());
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  using Cell = std::array<std::int64_t, 3>;
  struct CellHash {
    size_t operator()(const Cell& c) const {
      return static_cast<size_t>(c[0] * 73856093) ^ static_cast<size_t>(c[1] * 19349663) ^
             static_cast<size_t>(c[2] * 83492791);
    }
  };
  std::unordered_map<Cell, std::vector<int>, CellHash> grid;
  grid.reserve(static_cast<size_t>(n));
  auto cellOf = [&](const Eigen::Vector3d& p) {
    return Cell{static_cast<std::int64_t>(std::floor(p.x() / tol)), static_cast<std::int64_t>(std::floor(p.y() / tol)),
                static_cast<std::int64_t>(std::floor(p.z() / tol))};
  };
  for (int i = 0; i < n; ++i) {
    const Cell c = cellOf(soup.points[i]);
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          auto it = grid.find(Cell{c[0] + dx, c[1] + dy, c[2] + dz});
          if (it == grid.end()) continue;
          for (int j : it->second)
            if ((soup.points[i] - soup.points[j]).norm() <= tol) {
              const int ri = find(i), rj = find(j);
              if (ri != rj) parent[std::max(ri, rj)] = std::min(ri, rj);
            }
        }
    grid[c].push_back(i);
  }
  std::vector<Eigen::Vector3i> kept;
  kept.reserve(soup.triangles.size());
  for (Eigen::Vector3i t : soup.triangles) {
    for (int k = 0; k < 3; ++k) t[k] = find(t[k]);
    if (t[0] != t[1] && t[1] != t[2] && t[2] != t[0]) kept.push_back(t);
  }
  soup.triangles = std::move(kept);
}

SurfaceMesh compact(const Soup& soup) {
  std::vector<int> newIndex(soup.points.size(), -1);
  int used = 0;
  for (const auto& t : soup.triangles)
    for (int k = 0; k < 3; ++k)
      if (newIndex[t[k]] < 0) newIndex[t[k]] = used++;
  SurfaceMesh s;
  s.V.resize(used, 3);
  for (size_t i = 0; i < soup.points.size(); ++i)
    if (newIndex[i] >= 0) s.V.row(newIndex[i]) = soup.points[i].transpose();
  s.F.resize(static_cast<Eigen::Index>(soup.triangles.size()), 3);
  for (size_t f = 0; f < soup.triangles.size(); ++f)
    for (int k = 0; k < 3; ++k) s.F(static_cast<Eigen::Index>(f), k) = newIndex[soup.triangles[f][k]];
  return s;
}

// Every directed edge exactly once and its reverse exactly once: closed,
// edge-manifold and consistently oriented. Returns a description of what is
// wrong, or an empty string.
std::string watertightnessProblem(const SurfaceMesh& s) {
  if (s.F.rows() == 0) return "the tessellation has no triangles";
  std::unordered_map<std::uint64_t, int> directed;
  directed.reserve(static_cast<size_t>(3 * s.F.rows()));
  auto key = [](int a, int b) { return (static_cast<std::uint64_t>(a) << 32) | static_cast<std::uint32_t>(b); };
  for (Eigen::Index f = 0; f < s.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) ++directed[key(s.F(f, k), s.F(f, (k + 1) % 3))];
  long open = 0, repeated = 0;
  for (const auto& [k, count] : directed) {
    if (count > 1) ++repeated;
    const int a = static_cast<int>(k >> 32), b = static_cast<int>(k & 0xffffffffu);
    if (directed.find(key(b, a)) == directed.end()) ++open;
  }
  if (open == 0 && repeated == 0) return {};
  return "the tessellation is not watertight (" + std::to_string(open) + " edges with one triangle, " +
         std::to_string(repeated) + " edges used twice in the same direction or by more than two triangles)";
}

// Connected components of the triangles (sharing a vertex).
int countComponents(const SurfaceMesh& s) {
  std::vector<int> parent(static_cast<size_t>(s.V.rows()));
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  for (Eigen::Index f = 0; f < s.F.rows(); ++f)
    for (int k = 1; k < 3; ++k) parent[find(s.F(f, k))] = find(s.F(f, 0));
  int n = 0;
  for (int i = 0; i < static_cast<int>(parent.size()); ++i)
    if (find(i) == i) ++n;
  return n;  // every vertex is used (compact), so isolated vertices do not occur
}

double signedVolume(const SurfaceMesh& s) {
  double v = 0;
  for (Eigen::Index f = 0; f < s.F.rows(); ++f) {
    const Eigen::Vector3d a = s.V.row(s.F(f, 0)), b = s.V.row(s.F(f, 1)), c = s.V.row(s.F(f, 2));
    v += a.dot(b.cross(c));
  }
  return v / 6;
}

SurfaceMesh tessellate(const TopoDS_Solid& solid, const CadReadOptions& options, const std::string& path) {
  const double diag = diagonal(solid);
  if (!(diag > 0)) fail(path, "the solid has an empty bounding box");
  BRepTools::Clean(solid);  // drop triangulations stored in the file, so that the options apply
  BRepMesh_IncrementalMesh mesher(solid, options.relativeDeflection * diag, /*isRelative=*/false,
                                  options.angularDeflection, /*isInParallel=*/true);
  if (!mesher.IsDone()) fail(path, "tessellation of the solid failed (BRepMesh_IncrementalMesh)");

  Soup soup;
  SurfaceMesh surface;
  std::string problem;
  if (shareEdgeNodes(solid, soup)) {
    surface = compact(soup);
    problem = watertightnessProblem(surface);
  } else {
    problem = "edge polygons missing or inconsistent";
  }
  if (!problem.empty()) {
    double tol = 1e-7 * diag;
    for (TopExp_Explorer e(solid, TopAbs_EDGE); e.More(); e.Next())
      tol = std::max(tol, 2 * BRep_Tool::Tolerance(TopoDS::Edge(e.Current())));
    tol = std::min(tol, 0.1 * options.relativeDeflection * diag);
    Soup welded;
    weldFaces(solid, tol, welded, path);
    SurfaceMesh retry = compact(welded);
    const std::string retryProblem = watertightnessProblem(retry);
    if (!retryProblem.empty()) fail(path, retryProblem);
    surface = std::move(retry);
  }
  const int components = countComponents(surface);
  if (components != countShells(solid))
    fail(path, "the tessellation has " + std::to_string(components) + " closed surfaces but the solid has " +
                   std::to_string(countShells(solid)) + " shells (a shell tessellated to nothing)");
  // A solid whose faces are all inside out still gives a consistent surface;
  // turn it so that the normals point out of the material.
  if (signedVolume(surface) < 0) surface.F.col(1).swap(surface.F.col(2));
  return surface;
}

SurfaceMesh readCadSurfaceImpl(const std::string& path, const CadReadOptions& options) {
  if (!(options.relativeDeflection > 0) || !(options.angularDeflection > 0))
    throw Error(ErrorKind::Usage, path + ": CAD tessellation needs a positive linear and angular deflection");
  if (options.solid < 0)
    throw Error(ErrorKind::Usage, path + ": --solid must be a positive index, got " + std::to_string(options.solid));
  requireReadableFile(path);
  const TopoDS_Shape shape = readShape(path);
  requireFiniteGeometry(shape, path);

  std::vector<TopoDS_Solid> solids;
  for (TopExp_Explorer e(shape, TopAbs_SOLID); e.More(); e.Next()) solids.push_back(TopoDS::Solid(e.Current()));
  if (solids.empty()) {
    solids = solidsFromFaces(shape, path);
  } else {
    // Faces next to the solids that reach into a solid's bounding box are
    // most likely a void that the translator could not attach (it does so
    // with a degenerate void); taking the solid alone would drop it. Loose
    // faces elsewhere (construction surfaces) are ignored.
    std::vector<Bnd_Box> boxes(solids.size());
    for (size_t i = 0; i < solids.size(); ++i) BRepBndLib::Add(solids[i], boxes[i]);
    int inside = 0;
    for (TopExp_Explorer e(shape, TopAbs_FACE, TopAbs_SOLID); e.More(); e.Next()) {
      Bnd_Box box;
      BRepBndLib::Add(e.Current(), box);
      for (const Bnd_Box& b : boxes)
        if (!box.IsVoid() && !b.IsOut(box)) {
          ++inside;
          break;
        }
    }
    if (inside > 0)
      fail(path, "the file holds " + std::to_string(inside) + (inside == 1 ? " face" : " faces") +
                     " outside its solids but within a solid's bounding box (a void the translator could not attach?)");
  }
  const int count = static_cast<int>(solids.size());
  int index = options.solid;
  if (index == 0) {
    if (count > 1)
      fail(path, "the file holds " + std::to_string(count) + " solids; pass --solid N (1.." + std::to_string(count) +
                     ") to choose one");
    index = 1;
  } else if (index > count) {
    throw Error(ErrorKind::Usage, path + ": --solid " + std::to_string(index) + " is out of range; the file holds " +
                                      std::to_string(count) + (count == 1 ? " solid" : " solids"));
  }
  TopoDS_Solid solid = validSolid(solids[static_cast<size_t>(index - 1)], path, index);
  BRepLib::OrientClosedSolid(solid);  // outer shell outward, voids inward
  return tessellate(solid, options, path);
}

}  // namespace

SurfaceMesh readCadSurface(const std::string& path, const CadReadOptions& options) {
  OcctSignalGuard signals;
  try {
    return readCadSurfaceImpl(path, options);
  } catch (const Standard_Failure& e) {
    const char* what = e.GetMessageString();
    fail(path, std::string("OpenCASCADE failed: ") + e.DynamicType()->Name() +
                   (what && *what ? std::string(": ") + what : std::string()));
  }
}

}  // namespace tet2spline

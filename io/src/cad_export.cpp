// STEP/IGES export of a B-spline volume's boundary (see cad_export.h).
#include "tet2spline/io/cad_export.h"

#include <APIHeaderSection_MakeHeader.hxx>
#include <BRepBuilderAPI_MakeFace.hxx>
#include <BRepBuilderAPI_MakeSolid.hxx>
#include <BRepBuilderAPI_Sewing.hxx>
#include <BRepCheck_Analyzer.hxx>
#include <BRepGProp.hxx>
#include <GProp_GProps.hxx>
#include <BRepLib.hxx>
#include <Geom_BSplineSurface.hxx>
#include <IFSelect_ReturnStatus.hxx>
#include <IGESControl_Controller.hxx>
#include <IGESControl_Writer.hxx>
#include <IGESData_GlobalSection.hxx>
#include <IGESData_IGESModel.hxx>
#include <Interface_Static.hxx>
#include <Message.hxx>
#include <Message_Messenger.hxx>
#include <Message_Printer.hxx>
#include <STEPControl_Controller.hxx>
#include <STEPControl_Writer.hxx>
#include <StepBasic_Product.hxx>
#include <StepData_StepModel.hxx>
#include <TCollection_HAsciiString.hxx>
#include <Precision.hxx>
#include <ShapeFix_Solid.hxx>
#include <Standard_Failure.hxx>
#include <TColStd_Array1OfInteger.hxx>
#include <TColStd_Array1OfReal.hxx>
#include <TColgp_Array2OfPnt.hxx>
#include <TopExp_Explorer.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Face.hxx>
#include <TopoDS_Shell.hxx>
#include <TopoDS_Solid.hxx>

#include <cmath>
#include <mutex>
#include <utility>
#include <vector>

#include "tet2spline/io/atomic_file.h"
#include "tet2spline/param/error.h"

namespace tet2spline {

namespace {

[[noreturn]] void fail(const std::string& path, const std::string& cause) {
  throw Error(ErrorKind::Numerical, path + ": " + cause);
}

// Distinct knots and their multiplicities, as OCCT wants them.
void knotsAndMults(const spline::KnotVector& kv, TColStd_Array1OfReal& knots, TColStd_Array1OfInteger& mults) {
  const std::vector<double> bp = kv.breakpoints();
  knots.Resize(1, static_cast<int>(bp.size()), false);
  mults.Resize(1, static_cast<int>(bp.size()), false);
  for (size_t i = 0; i < bp.size(); ++i) {
    knots.SetValue(static_cast<int>(i) + 1, bp[i]);
    mults.SetValue(static_cast<int>(i) + 1, kv.multiplicity(bp[i]));
  }
}

Handle(Geom_BSplineSurface) toOcct(const spline::BSplineSurface& s) {
  const int ns = s.numControl(0), nt = s.numControl(1);
  TColgp_Array2OfPnt poles(1, ns, 1, nt);
  const Eigen::MatrixX3d& Q = s.controlPoints();
  for (int j = 0; j < nt; ++j)
    for (int i = 0; i < ns; ++i) {
      const auto r = s.controlIndex(i, j);
      poles.SetValue(i + 1, j + 1, gp_Pnt(Q(r, 0), Q(r, 1), Q(r, 2)));
    }
  TColStd_Array1OfReal uk(1, 1), vk(1, 1);
  TColStd_Array1OfInteger um(1, 1), vm(1, 1);
  knotsAndMults(s.knots(0), uk, um);
  knotsAndMults(s.knots(1), vk, vm);
  return new Geom_BSplineSurface(poles, uk, vk, um, vm, s.degree(0), s.degree(1));
}

// The closed, valid, outward-oriented solid bounded by the six faces.
TopoDS_Solid boundarySolid(const spline::BSplineVolume& volume, const std::string& path,
                           const CadExportOptions& options) {
  const Eigen::MatrixX3d& P = volume.controlPoints();
  const double diagonal = (P.colwise().maxCoeff() - P.colwise().minCoeff()).norm();
  if (!(diagonal > 0) || !std::isfinite(diagonal))
    fail(path, "the control points span no volume (bounding-box diagonal " + std::to_string(diagonal) + ")");
  const double tolerance = options.relativeSewingTolerance * diagonal;

  BRepBuilderAPI_Sewing sewing(tolerance);
  for (int f = 0; f < 6; ++f) {
    const Handle(Geom_BSplineSurface) surface = toOcct(volume.face(static_cast<spline::VolumeFace>(f)));
    BRepBuilderAPI_MakeFace face(surface, Precision::Confusion());
    if (!face.IsDone())
      fail(path, "cannot make boundary face " + std::to_string(f) + " (error " + std::to_string(face.Error()) + ")");
    sewing.Add(face.Face());
  }
  sewing.Perform();
  const TopoDS_Shape sewn = sewing.SewedShape();
  if (sewing.NbFreeEdges() > 0)
    fail(path, "sewing the six boundary faces left " + std::to_string(sewing.NbFreeEdges()) +
                   " free edges (tolerance " + std::to_string(tolerance) + ")");
  if (sewing.NbMultipleEdges() > 0)
    fail(path, "sewing the six boundary faces found " + std::to_string(sewing.NbMultipleEdges()) +
                   " edges shared by more than two faces");
  TopoDS_Shell shell;
  int shells = 0;
  for (TopExp_Explorer ex(sewn, TopAbs_SHELL); ex.More(); ex.Next()) {
    shell = TopoDS::Shell(ex.Current());
    ++shells;
  }
  if (shells != 1) fail(path, "sewing the six boundary faces gave " + std::to_string(shells) + " shells, not one");

  BRepBuilderAPI_MakeSolid makeSolid(shell);
  if (!makeSolid.IsDone()) fail(path, "cannot make a solid from the sewn shell");
  ShapeFix_Solid fix(makeSolid.Solid());
  fix.Perform();
  TopoDS_Solid solid;
  for (TopExp_Explorer ex(fix.Solid(), TopAbs_SOLID); ex.More(); ex.Next()) {
    solid = TopoDS::Solid(ex.Current());
    break;
  }
  if (solid.IsNull()) fail(path, "ShapeFix_Solid gave no solid");
  BRepLib::OrientClosedSolid(solid);
  BRepCheck_Analyzer check(solid);
  if (!check.IsValid()) fail(path, "the boundary solid is not valid (BRepCheck_Analyzer)");

  // A flat or collapsed volume still sews into a "valid" closed shell; its
  // enclosed volume tells. By the divergence theorem the solid's volume is
  // |∫ det J| exactly, so a disagreement means the B-rep is not the spline's boundary.
  GProp_GProps props;
  BRepGProp::VolumeProperties(solid, props);
  const double cadVolume = props.Mass(), splineVolume = std::fabs(volume.volume());
  if (!(cadVolume > 1e-9 * diagonal * diagonal * diagonal))
    fail(path, "the boundary solid encloses no volume (" + std::to_string(cadVolume) + ")");
  if (std::fabs(cadVolume - splineVolume) > 1e-2 * splineVolume)
    fail(path, "the boundary solid's volume " + std::to_string(cadVolume) + " differs from the spline's " +
                   std::to_string(splineVolume));
  return solid;
}

// OCCT's writers keep their settings in process-wide statics.
std::mutex& occtMutex() {
  static std::mutex m;
  return m;
}

// OCCT's writers report transfer statistics through the default messenger;
// library code prints nothing, so its printers only pass failures meanwhile.
class QuietOcct {
 public:
  QuietOcct() {
    const Message_SequenceOfPrinters& printers = Message::DefaultMessenger()->Printers();
    for (Message_SequenceOfPrinters::Iterator it(printers); it.More(); it.Next()) {
      saved_.emplace_back(it.Value(), it.Value()->GetTraceLevel());
      it.Value()->SetTraceLevel(Message_Fail);
    }
  }
  ~QuietOcct() {
    for (auto& [printer, level] : saved_) printer->SetTraceLevel(level);
  }
  QuietOcct(const QuietOcct&) = delete;
  QuietOcct& operator=(const QuietOcct&) = delete;

 private:
  std::vector<std::pair<Handle(Message_Printer), Message_Gravity>> saved_;
};

// Header fields that would otherwise hold the time and the user: fixed, so
// that the same volume gives byte-identical files.
constexpr const char* kSystem = "tet2spline";

std::string baseName(const std::string& path) {
  const auto slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

Handle(TCollection_HAsciiString) hstring(const std::string& s) { return new TCollection_HAsciiString(s.c_str()); }

}  // namespace

void writeStep(const spline::BSplineVolume& volume, const std::string& path, const CadExportOptions& options) {
  try {
    const TopoDS_Solid solid = boundarySolid(volume, path, options);
    AtomicFile file(path);
    std::lock_guard<std::mutex> lock(occtMutex());
    const QuietOcct quiet;
    STEPControl_Controller::Init();
    STEPControl_Writer writer;
    Interface_Static::SetCVal("write.step.schema", "AP214IS");
    if (writer.Transfer(solid, STEPControl_ManifoldSolidBrep) != IFSelect_RetDone)
      fail(path, "STEP translation of the boundary solid failed");
    // OCCT names the product with a process-wide counter; name it after the file.
    const Handle(StepData_StepModel) model = writer.Model();
    const std::string stem = baseName(path).substr(0, baseName(path).find_last_of('.'));
    for (int i = 1; i <= model->NbEntities(); ++i) {
      const Handle(StepBasic_Product) product = Handle(StepBasic_Product)::DownCast(model->Value(i));
      if (product.IsNull()) continue;
      product->SetId(hstring(stem));
      product->SetName(hstring(stem));
    }
    APIHeaderSection_MakeHeader header(model);
    header.SetName(hstring(baseName(path)));
    header.SetTimeStamp(hstring("1970-01-01T00:00:00"));
    header.SetAuthorValue(1, hstring(kSystem));
    header.SetOrganizationValue(1, hstring(kSystem));
    header.SetOriginatingSystem(hstring(kSystem));
    if (writer.Write(file.temporaryPath().c_str()) != IFSelect_RetDone)
      throwInputError(path, 0, "cannot write the STEP file");
    file.commit();
  } catch (const Standard_Failure& e) {
    fail(path, std::string("OpenCASCADE: ") + e.GetMessageString());
  }
}

void writeIges(const spline::BSplineVolume& volume, const std::string& path, const CadExportOptions& options) {
  try {
    const TopoDS_Solid solid = boundarySolid(volume, path, options);
    AtomicFile file(path);
    std::lock_guard<std::mutex> lock(occtMutex());
    const QuietOcct quiet;
    IGESControl_Controller::Init();
    Interface_Static::SetIVal("write.iges.brep.mode", 1);
    IGESControl_Writer writer("MM", 1);
    if (!writer.AddShape(solid)) fail(path, "IGES translation of the boundary solid failed");
    writer.ComputeModel();
    IGESData_GlobalSection global = writer.Model()->GlobalSection();
    global.SetFileName(hstring(baseName(path)));
    global.SetDate(hstring("19700101.000000"));
    global.SetLastChangeDate(hstring("19700101.000000"));
    global.SetAuthorName(hstring(kSystem));
    global.SetCompanyName(hstring(kSystem));
    writer.Model()->SetGlobalSection(global);
    if (!writer.Write(file.temporaryPath().c_str())) throwInputError(path, 0, "cannot write the IGES file");
    file.commit();
  } catch (const Standard_Failure& e) {
    fail(path, std::string("OpenCASCADE: ") + e.GetMessageString());
  }
}

}  // namespace tet2spline

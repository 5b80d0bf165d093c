// Real meshes that nobody on the team wrote (Debian's libcgal-demo data):
// each class of unsupported input is refused by the program with the
// documented status and a line that says why; genus-0 solids mesh and check.
#include <gtest/gtest.h>

#include "cli_runner.h"

namespace fs = std::filesystem;
using t2stest::filesIn;
using t2stest::q;
using t2stest::runCli;

namespace {

void expectRefused(const std::string& name, int status, const std::string& cause) {
  const auto dir = t2stest::scratchDir("refuse_" + name);
  const auto out = dir / (name + ".vtu");
  const auto r = runCli("mesh " + q(t2stest::cgalMesh(name)) + " -o " + q(out.string()), dir);
  EXPECT_EQ(r.status, status) << name << ": " << r.err;
  EXPECT_EQ(r.errLines(), 1) << r.err;
  EXPECT_NE(r.err.find(name + ".off"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(cause), std::string::npos) << name << ": expected '" << cause << "' in " << r.err;
  EXPECT_TRUE(t2stest::listDir(dir).empty()) << name << ": a failed run left a file";
}
}  // namespace

TEST(CliRealData, HigherGenusIsRefusedWithItsGenus) {
  expectRefused("elephant", 4, "genus");
  expectRefused("femur", 4, "genus");
  expectRefused("knot", 4, "genus");
  expectRefused("rotor", 4, "genus");
}

TEST(CliRealData, SelfIntersectingSurfacesAreRefused) {
  for (const char* name : {"cow", "camel", "man"}) expectRefused(name, 3, "intersects itself");
}

TEST(CliRealData, OpenSurfacesAreRefused) {
  for (const char* name : {"lion", "head"}) expectRefused(name, 4, "open");
}

TEST(CliRealData, SmallGenus0SolidsMeshAndCheck) {
  for (const char* name : {"blob-closed", "spool", "part"}) {
    const auto dir = t2stest::scratchDir(std::string("ok_") + name);
    const auto out = (dir / (std::string(name) + ".msh")).string();
    const auto m = runCli("mesh " + q(t2stest::cgalMesh(name)) + " -o " + q(out), dir);
    ASSERT_EQ(m.status, 0) << name << ": " << m.err;
    const auto c = runCli("check --json " + q(out), dir);
    ASSERT_EQ(c.status, 0) << c.err;
    EXPECT_NE(c.out.find("\"genus\": 0"), std::string::npos) << c.out;
    EXPECT_NE(c.out.find("\"inverted_tets\": 0"), std::string::npos) << c.out;
    EXPECT_NE(c.out.find("\"components\": 1"), std::string::npos) << c.out;
  }
}

// Across formats: regions and fields survive every writer and every chain of
// conversions, writers are deterministic, and corrupted files never crash.
#include <random>
#include <tuple>

#include "surface_test_util.h"

using namespace tet2spline;
using namespace t2stest;

namespace {
void expectSame(const TetMesh& a, const TetMesh& b) {
  EXPECT_TRUE(a.V == b.V);
  EXPECT_TRUE(a.T == b.T);
  EXPECT_TRUE(a.region == b.region);
}
}  // namespace

TEST(MeshIo, RegionsOfAGmshMeshSurviveEveryWriterAndChain) {
  if (!haveProgram("gmsh")) GTEST_SKIP() << "gmsh not installed (scripts/install-deps.sh)";
  const std::string src = gmshNested("msh41", true, "msh");
  ASSERT_FALSE(src.empty());
  const TetMesh m = readTetMesh(src);
  const auto volumes = regionVolumes(m);
  ASSERT_EQ(volumes.size(), 2u);
  const std::string dir = scratchDir("mesh_chain");
  // Every writer, binary and ASCII.
  for (const char* ext : {"mesh", "msh", "vtu"})
    for (bool binary : {true, false}) {
      SCOPED_TRACE(std::string(ext) + (binary ? " binary" : " ascii"));
      const std::string path = dir + "/direct_" + (binary ? "b." : "a.") + ext;
      writeTetMesh(m, path, MeshWriteOptions{binary});
      const TetMesh r = readTetMesh(path);
      expectSame(r, m);
      EXPECT_EQ(regionVolumes(r), volumes);
    }
  // A chain msh -> vtu -> mesh -> msh -> vtu (ASCII) ends where it started.
  TetMesh cur = m;
  int i = 0;
  for (const char* ext : {"vtu", "mesh", "msh", "vtu"}) {
    const std::string path = dir + "/chain" + std::to_string(i++) + "." + ext;
    writeTetMesh(cur, path, MeshWriteOptions{i % 2 == 0});
    cur = readTetMesh(path);
  }
  expectSame(cur, m);
}

TEST(MeshIo, VoidRegionTagsAreKeptAsRegions) {
  // A void filled with tets keeps its own region tag through every format.
  TetMesh m = referenceMesh();
  m.region.setConstant(1);
  m.region.tail(4).setConstant(2);
  m.voidRegions = {2};
  const std::string dir = scratchDir("mesh_void");
  for (const char* ext : {"mesh", "msh", "vtu"}) {
    const std::string path = dir + "/v." + ext;
    writeTetMesh(m, path);
    EXPECT_TRUE(readTetMesh(path).region == m.region) << ext;
  }
  // Which regions are voids: only .vtu has a place for it (FieldData).
  for (bool binary : {true, false}) {
    const std::string path = dir + "/v.vtu";
    writeTetMesh(m, path, MeshWriteOptions{binary});
    EXPECT_EQ(readTetMesh(path).voidRegions, m.voidRegions);
  }
}

TEST(MeshIo, MeshWithoutRegionsIsWrittenAsRegionOne) {
  TetMesh m = referenceMesh();
  m.region.resize(0);
  const std::string dir = scratchDir("mesh_noregion");
  for (const char* ext : {"mesh", "msh", "vtu"}) {
    const std::string path = dir + "/n." + ext;
    writeTetMesh(m, path);
    const TetMesh r = readTetMesh(path);
    EXPECT_TRUE(r.region == Eigen::VectorXi::Ones(m.numTets())) << ext;
  }
}

TEST(MeshIo, EveryWriterIsDeterministic) {
  const std::string dir = scratchDir("mesh_det");
  for (const char* ext : {"mesh", "msh", "vtu"})
    for (bool binary : {true, false}) {
      const std::string a = dir + "/a." + ext, b = dir + "/b." + ext;
      writeTetMesh(referenceMesh(), a, MeshWriteOptions{binary});
      writeTetMesh(referenceMesh(), b, MeshWriteOptions{binary});
      EXPECT_EQ(readFile(a), readFile(b)) << ext;
    }
  for (const char* ext : {"off", "obj", "stl", "ply"}) {
    const std::string a = dir + "/a." + ext, b = dir + "/b." + ext;
    writeSurface(octahedron(), a);
    writeSurface(octahedron(), b);
    EXPECT_EQ(readFile(a), readFile(b)) << ext;
  }
}

// Random byte corruption: every outcome is a mesh or an Error(Input), never a
// crash, a std::bad_alloc or another exception type.
TEST(MeshIo, CorruptedFilesNeverCrash) {
  const std::string dir = scratchDir("mesh_fuzz");
  std::vector<std::string> sources;
  const TetMesh m = referenceMesh();
  for (const char* ext : {"mesh", "msh", "vtu"})
    for (bool binary : {true, false}) {
      const std::string p = dir + "/src_" + (binary ? "b." : "a.") + ext;
      writeTetMesh(m, p, MeshWriteOptions{binary});
      sources.push_back(p);
    }
  for (const char* ext : {"off", "obj", "stl", "ply"}) {
    const std::string p = dir + "/src." + ext;
    writeSurface(octahedron(), p);
    sources.push_back(p);
  }
  if (haveProgram("gmsh"))
    for (auto [format, binary, ext] : {std::tuple{"msh22", true, "msh"}, {"msh41", true, "msh"}, {"vtk", true, "vtk"}}) {
      const std::string p = gmshNested(format, binary, ext);
      if (!p.empty()) sources.push_back(p);
    }
  // T2S_FUZZ_TRIALS raises the number of corruptions per file for a longer run.
  const char* env = std::getenv("T2S_FUZZ_TRIALS");
  const int trials = env ? std::max(1, std::atoi(env)) : 100;
  std::mt19937 rng(12345);
  int errors = 0, reads = 0;
  for (const std::string& src : sources) {
    const std::string bytes = readFile(src);
    const std::string ext = src.substr(src.find_last_of('.'));
    const bool surface = isSurfaceFormat(formatFromPath(src));
    for (int trial = 0; trial < trials; ++trial) {
      std::string b = bytes;
      const int flips = 1 + static_cast<int>(rng() % 4);
      for (int f = 0; f < flips; ++f) {
        const size_t at = rng() % b.size();
        switch (rng() % 3) {
          case 0: b[at] = static_cast<char>(rng()); break;
          case 1: b[at] = static_cast<char>(b[at] ^ (1 << (rng() % 8))); break;
          default: b.resize(at); break;
        }
        if (b.empty()) break;
      }
      const std::string path = dir + "/fuzz" + ext;
      writeFile(path, b);
      try {
        if (surface) readSurface(path);
        else readTetMesh(path);
        ++reads;
      } catch (const Error& e) {
        EXPECT_EQ(e.kind(), ErrorKind::Input) << e.what();
        EXPECT_EQ(std::string(e.what()).rfind(path, 0), 0u) << e.what();
        ++errors;
      } catch (const std::exception& e) {
        ADD_FAILURE() << src << " trial " << trial << ": " << typeid(e).name() << ": " << e.what();
      }
    }
  }
  EXPECT_GT(errors, 0);
  RecordProperty("reads", reads);
}

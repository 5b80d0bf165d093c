// AtomicFile and the writers' no-partial-file guarantee; the extension dispatcher.
#include "tet2spline/io/atomic_file.h"

#include "io_test_util.h"

using namespace tet2spline;
using namespace t2stest;

namespace {
size_t filesIn(const std::string& dir) {
  size_t n = 0;
  for (auto it = fs::directory_iterator(dir); it != fs::directory_iterator(); ++it) ++n;
  return n;
}
}  // namespace

TEST(AtomicFile, CommitRenamesOntoTarget) {
  const std::string dir = scratchDir("atomic_commit");
  const std::string path = dir + "/out.txt";
  {
    AtomicFile f(path);
    EXPECT_NE(f.temporaryPath(), path);
    EXPECT_EQ(fs::path(f.temporaryPath()).parent_path(), fs::path(path).parent_path());
    f.stream() << "hello\n";
    EXPECT_FALSE(fs::exists(path)) << "target must not appear before commit";
    f.commit();
  }
  EXPECT_EQ(readFile(path), "hello\n");
  EXPECT_EQ(filesIn(dir), 1u) << "temporary file left behind";
}

TEST(AtomicFile, ReplacesExistingFileOnlyOnCommit) {
  const std::string dir = scratchDir("atomic_replace");
  const std::string path = dir + "/out.txt";
  writeFile(path, "old");
  {
    AtomicFile f(path);
    f.stream() << "new";
    EXPECT_EQ(readFile(path), "old");
    f.commit();
  }
  EXPECT_EQ(readFile(path), "new");
}

TEST(AtomicFile, NoCommitLeavesNothing) {
  const std::string dir = scratchDir("atomic_abort");
  const std::string path = dir + "/out.txt";
  try {
    AtomicFile f(path);
    f.stream() << "partial";
    throw std::runtime_error("writer failed half way");
  } catch (const std::runtime_error&) {
  }
  EXPECT_FALSE(fs::exists(path));
  EXPECT_EQ(filesIn(dir), 0u);
}

// StagedFiles: a set of outputs appears together on commit, or not at all.
TEST(StagedFiles, CommitMovesEveryWrittenFileTogether) {
  const std::string dir = scratchDir("staged_commit");
  writeFile(dir + "/b.txt", "old");
  std::vector<std::string> moved;
  {
    StagedFiles out(dir);
    writeFile(out.stagingPath("a.txt"), "A");
    {
      AtomicFile f(out.stagingPath("b.txt"));
      f.stream() << "B";
      f.commit();
    }
    out.stagingPath("never_written.txt");
    EXPECT_FALSE(fs::exists(dir + "/a.txt")) << "nothing appears before commit";
    EXPECT_EQ(readFile(dir + "/b.txt"), "old");
    EXPECT_EQ(out.finalPath("a.txt"), dir + "/a.txt");
    moved = out.commit();
  }
  EXPECT_EQ(moved, (std::vector<std::string>{dir + "/a.txt", dir + "/b.txt"}));
  EXPECT_EQ(readFile(dir + "/a.txt"), "A");
  EXPECT_EQ(readFile(dir + "/b.txt"), "B");
  EXPECT_EQ(filesIn(dir), 2u) << "staging folder left behind";
}

TEST(StagedFiles, NoCommitLeavesTheFolderAsItWas) {
  const std::string dir = scratchDir("staged_abort");
  writeFile(dir + "/keep.txt", "mine");
  try {
    StagedFiles out(dir);
    writeFile(out.stagingPath("a.txt"), "A");
    throw std::runtime_error("a later stage failed");
  } catch (const std::runtime_error&) {
  }
  EXPECT_EQ(filesIn(dir), 1u);
  EXPECT_EQ(readFile(dir + "/keep.txt"), "mine");
}

TEST(StagedFiles, RefusesBadNamesAndMissingFolders) {
  const std::string dir = scratchDir("staged_bad");
  StagedFiles out(dir);
  out.stagingPath("a.txt");
  EXPECT_THROW(out.stagingPath("a.txt"), Error);
  EXPECT_THROW(out.stagingPath("sub/a.txt"), Error);
  EXPECT_THROW(out.stagingPath(""), Error);
  expectInputError([&] { StagedFiles s(dir + "/missing"); }, dir + "/missing", 0, "staging folder");
}

TEST(AtomicFile, UnwritableDirectoryNamesThePath) {
  const std::string path = scratchDir("atomic_missing") + "/no/such/dir/out.vtu";
  expectInputError([&] { AtomicFile f(path); }, path, 0, "cannot write");
}

TEST(AtomicFile, WritersLeaveNoFileWhenThePathIsUnwritable) {
  const std::string dir = scratchDir("atomic_writers");
  const TetMesh m = referenceMesh();
  for (const char* ext : {"mesh", "msh", "vtu"}) {
    const std::string path = dir + "/missing/out." + ext;
    expectInputError([&] { writeTetMesh(m, path); }, path, 0, "cannot write");
  }
  SurfaceMesh s;
  s.V = m.V;
  s.F = m.T.leftCols<3>();
  for (const char* ext : {"off", "obj", "stl", "ply"}) {
    const std::string path = dir + "/missing/out." + ext;
    expectInputError([&] { writeSurface(s, path); }, path, 0, "cannot write");
  }
  EXPECT_EQ(filesIn(dir), 0u);
}

TEST(AtomicFile, InconsistentMeshIsRefusedBeforeAnyFileIsCreated) {
  const std::string dir = scratchDir("atomic_inconsistent");
  TetMesh m = referenceMesh();
  m.T(3, 2) = 99;
  const std::string path = dir + "/bad.vtu";
  expectInputError([&] { writeTetMesh(m, path); }, path, 0, "outside");
  m = referenceMesh();
  m.cellFields[0].values.resize(5, 1);
  expectInputError([&] { writeTetMesh(m, path); }, path, 0, "density");
  EXPECT_EQ(filesIn(dir), 0u);
}

TEST(MeshIo, UnknownExtensions) {
  expectInputError([] { readTetMesh("/tmp/x.foo"); }, "/tmp/x.foo", 0, "unknown or unsupported volume mesh extension");
  expectInputError([] { readTetMesh("/tmp/noext"); }, "/tmp/noext", 0, "extension");
  expectInputError([] { readSurface("/tmp/x.mesh"); }, "/tmp/x.mesh", 0, "unknown or unsupported surface file extension");
  expectInputError([] { writeTetMesh(referenceMesh(), "/tmp/x.stl"); }, "/tmp/x.stl", 0, "unsupported output extension");
  expectInputError([] { writeSurface(SurfaceMesh{}, "/tmp/x.msh"); }, "/tmp/x.msh", 0, "unsupported output extension");
  EXPECT_EQ(formatFromPath("a/B.MSH"), FileFormat::Gmsh);
  EXPECT_EQ(formatFromPath("dir.vtu/file"), FileFormat::Unknown);
  EXPECT_EQ(formatFromPath("x.1.ele"), FileFormat::TetGen);
}

TEST(MeshIo, MissingFileNamesIt) {
  for (const char* p : {"/nonexistent/a.mesh", "/nonexistent/a.msh", "/nonexistent/a.vtu", "/nonexistent/a.vtk"})
    expectInputError([&] { readTetMesh(p); }, p, 0, "cannot open");
  for (const char* p : {"/nonexistent/a.off", "/nonexistent/a.obj", "/nonexistent/a.stl", "/nonexistent/a.ply"})
    expectInputError([&] { readSurface(p); }, p, 0, "cannot open");
}

TEST(MeshIo, EmptyFilesAreNamed) {
  const std::string dir = scratchDir("empty");
  for (const char* ext : {"mesh", "msh", "vtu", "vtk", "node"}) {
    const std::string p = dir + "/e." + ext;
    writeFile(p, "");
    expectInputError([&] { readTetMesh(p); }, p, 0, "empty file");
  }
  for (const char* ext : {"off", "obj", "stl", "ply"}) {
    const std::string p = dir + "/e." + ext;
    writeFile(p, "");
    expectInputError([&] { readSurface(p); }, p, 0, "empty file");
  }
}

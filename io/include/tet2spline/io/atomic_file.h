#pragma once
/// Write-then-rename, so that a failure never leaves a partial output file.

#include <fstream>
#include <string>
#include <vector>

namespace tet2spline {

/// Opens "<dir>/.<name>.tmp.<pid>.<n>" beside `path`. commit() flushes, checks
/// the stream and renames onto `path`; the destructor removes the temporary file
/// if commit() was not reached. Throws Error(Input) naming `path` when the
/// directory is not writable or a write fails.
class AtomicFile {
 public:
  explicit AtomicFile(std::string path, bool binary = false);
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;
  ~AtomicFile();

  std::ostream& stream() { return out_; }
  /// The temporary path, for libraries that write by file name (OpenCASCADE).
  /// Call commit() afterwards; the stream is unused then.
  const std::string& temporaryPath() const { return tmp_; }
  const std::string& path() const { return path_; }
  void commit();

 private:
  std::string path_;
  std::string tmp_;
  std::ofstream out_;
  bool committed_ = false;
};

/// Several outputs of one folder that appear together or not at all. Files
/// are written into a hidden staging folder "<dir>/.tet2spline-staging.<pid>.<n>"
/// (same file system, so renames are atomic) and moved into `dir` by
/// commit(); the destructor removes the staging folder and everything in it
/// when commit() was not reached (an exception on the way).
class StagedFiles {
 public:
  /// Creates the staging folder; `dir` must exist. Throws Error(Input) naming
  /// `dir` when it cannot.
  explicit StagedFiles(std::string dir);
  StagedFiles(const StagedFiles&) = delete;
  StagedFiles& operator=(const StagedFiles&) = delete;
  ~StagedFiles();

  /// Where to write the output `name` (a plain file name) before commit().
  /// Throws Error(Usage) for a name with a '/' or one given twice.
  std::string stagingPath(const std::string& name);
  /// Where `name` will be after commit().
  std::string finalPath(const std::string& name) const;
  const std::string& folder() const { return dir_; }
  /// Moves every staged file that was written into the folder (replacing
  /// files of the same name), in the order of stagingPath() calls, removes
  /// the staging folder and returns the final paths. Throws Error(Input) when
  /// a rename fails (the files not yet moved are removed).
  std::vector<std::string> commit();

 private:
  std::string dir_;
  std::string staging_;
  std::vector<std::string> names_;
  bool committed_ = false;
};

}  // namespace tet2spline

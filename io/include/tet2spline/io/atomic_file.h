#pragma once
/// Write-then-rename, so that a failure never leaves a partial output file.

#include <fstream>
#include <string>

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

}  // namespace tet2spline

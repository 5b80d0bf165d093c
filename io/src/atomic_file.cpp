// Write-then-rename output files.
#include "tet2spline/io/atomic_file.h"

#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <system_error>

#include "tet2spline/param/error.h"

namespace tet2spline {

namespace {
std::atomic<unsigned long> g_counter{0};

std::string temporaryNameBeside(const std::string& path) {
  const auto slash = path.find_last_of('/');
  const std::string dir = slash == std::string::npos ? std::string() : path.substr(0, slash + 1);
  const std::string name = slash == std::string::npos ? path : path.substr(slash + 1);
  return dir + "." + name + ".tmp." + std::to_string(::getpid()) + "." + std::to_string(g_counter++);
}
}  // namespace

AtomicFile::AtomicFile(std::string path, bool binary) : path_(std::move(path)) {
  if (path_.empty()) throwInputError("<empty path>", 0, "cannot write: empty output path");
  if (path_.back() == '/') throwInputError(path_, 0, "cannot write: the path names a directory");
  tmp_ = temporaryNameBeside(path_);
  errno = 0;
  out_.open(tmp_, binary ? std::ios::out | std::ios::binary | std::ios::trunc : std::ios::out | std::ios::trunc);
  if (!out_) {
    const int err = errno;
    throwInputError(path_, 0, std::string("cannot write: ") + (err ? std::strerror(err) : "cannot create a file in its directory"));
  }
}

AtomicFile::~AtomicFile() {
  if (!committed_) {
    if (out_.is_open()) out_.close();
    std::remove(tmp_.c_str());
  }
}

void AtomicFile::commit() {
  if (committed_) return;
  out_.flush();
  const bool streamOk = static_cast<bool>(out_);
  const int err = errno;
  out_.close();
  if (!streamOk || out_.fail()) {
    std::remove(tmp_.c_str());
    throwInputError(path_, 0, std::string("write failed: ") + (err ? std::strerror(err) : "stream error"));
  }
  if (std::rename(tmp_.c_str(), path_.c_str()) != 0) {
    const int rerr = errno;
    std::remove(tmp_.c_str());
    throwInputError(path_, 0, std::string("cannot rename the temporary file onto the target: ") + std::strerror(rerr));
  }
  committed_ = true;
}

StagedFiles::StagedFiles(std::string dir) : dir_(std::move(dir)) {
  namespace fs = std::filesystem;
  if (dir_.empty()) dir_ = ".";
  while (dir_.size() > 1 && dir_.back() == '/') dir_.pop_back();
  staging_ = dir_ + "/.tet2spline-staging." + std::to_string(::getpid()) + "." + std::to_string(g_counter++);
  std::error_code ec;
  if (!fs::create_directory(staging_, ec))
    throwInputError(dir_, 0, "cannot create a staging folder for the outputs: " +
                                 (ec ? ec.message() : std::string("it already exists")));
}

StagedFiles::~StagedFiles() {
  std::error_code ec;
  std::filesystem::remove_all(staging_, ec);
}

std::string StagedFiles::stagingPath(const std::string& name) {
  if (name.empty() || name.find('/') != std::string::npos)
    throw Error(ErrorKind::Usage, "StagedFiles: '" + name + "' is not a plain file name");
  for (const auto& n : names_)
    if (n == name) throw Error(ErrorKind::Usage, "StagedFiles: '" + name + "' staged twice");
  if (committed_) throw Error(ErrorKind::Usage, "StagedFiles: staging '" + name + "' after commit()");
  names_.push_back(name);
  return staging_ + "/" + name;
}

std::string StagedFiles::finalPath(const std::string& name) const { return dir_ + "/" + name; }

std::vector<std::string> StagedFiles::commit() {
  std::vector<std::string> out;
  if (committed_) return out;
  namespace fs = std::filesystem;
  for (const auto& n : names_) {
    const std::string from = staging_ + "/" + n, to = finalPath(n);
    std::error_code ec;
    if (!fs::exists(from, ec)) continue;
    if (std::rename(from.c_str(), to.c_str()) != 0)
      throwInputError(to, 0, std::string("cannot move the output into place: ") + std::strerror(errno));
    out.push_back(to);
  }
  committed_ = true;
  std::error_code ec;
  fs::remove_all(staging_, ec);
  return out;
}

}  // namespace tet2spline

#pragma once
/// Errors and status shared by every tet2spline module.
///
/// A caller's mistake or bad input throws `Error`, whose kind maps onto the
/// command line's documented exit status (design.md, "Command line"):
///   2 bad command line, 3 unreadable or malformed input,
///   4 unsupported topology, 5 numerical failure.
/// An expected numerical outcome (did not converge) is a `Status` in a result.

#include <stdexcept>
#include <string>

namespace tet2spline {

enum class ErrorKind {
  Usage = 2,      ///< bad command line or option value
  Input = 3,      ///< unreadable, malformed or geometrically invalid input
  Topology = 4,   ///< valid data, unsupported topology (genus > 0, open, several components)
  Numerical = 5,  ///< a numerical stage failed
};

/// Exception carrying the exit-status class. `what()` is one line that names
/// the file (and line for text formats) where that applies, and the cause.
class Error : public std::runtime_error {
 public:
  Error(ErrorKind kind, const std::string& message) : std::runtime_error(message), kind_(kind) {}
  ErrorKind kind() const { return kind_; }
  int exitStatus() const { return static_cast<int>(kind_); }

 private:
  ErrorKind kind_;
};

/// "file:line: message" (line omitted when <= 0), thrown as ErrorKind::Input.
[[noreturn]] inline void throwInputError(const std::string& file, long line, const std::string& message) {
  throw Error(ErrorKind::Input,
              file + (line > 0 ? ":" + std::to_string(line) : std::string()) + ": " + message);
}

/// Outcome of a numerical stage that may legitimately stop early.
struct Status {
  bool ok = true;
  std::string message;  ///< why it stopped, when !ok
  static Status success() { return {}; }
  static Status failure(std::string why) { return {false, std::move(why)}; }
};

}  // namespace tet2spline

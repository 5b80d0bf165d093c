#pragma once
// Shared helpers of the mesh readers and writers (internal to the io module):
// a cursor over a whole file in memory that reads text tokens (with line
// numbers for error messages) and raw binary values (bounds-checked against
// the file size before anything is allocated), and number formatting.
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>

#include "tet2spline/param/error.h"

namespace tet2spline::detail {

/// The whole file as bytes; throws Error(Input) "cannot open" / "empty file".
std::string readWholeFile(const std::string& path);

bool hostIsBigEndian();

template <class T>
T byteSwapped(T v) {
  static_assert(std::is_trivially_copyable_v<T>);
  unsigned char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  for (size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
  std::memcpy(&v, b, sizeof(T));
  return v;
}

/// Reads a T stored with the given endianness at p (no alignment needed).
template <class T>
T loadValue(const char* p, bool bigEndian) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return bigEndian != hostIsBigEndian() ? byteSwapped(v) : v;
}

/// A read position in a file held in memory. Text tokens are separated by
/// whitespace; `comment` (if non-zero) starts a comment up to the end of line.
class Cursor {
 public:
  Cursor(std::string path, std::string data, char comment = 0)
      : path_(std::move(path)), data_(std::move(data)), comment_(comment) {}

  const std::string& path() const { return path_; }
  const std::string& data() const { return data_; }
  size_t pos() const { return pos_; }
  size_t size() const { return data_.size(); }
  size_t remaining() const { return data_.size() - pos_; }
  /// Line of the last token read (1-based); 0 once raw binary data was read.
  long line() const { return binary_ ? 0 : tokenLine_; }

  /// Skips whitespace and comments; true when nothing but those is left.
  bool atEnd();
  /// Next token, or false at the end of the data.
  bool tryToken(std::string_view& tok);
  /// Next token; throws "truncated: expected <what>" at the end of the data.
  std::string_view token(const char* what);
  /// Peeks at the next token without consuming it ("" at the end).
  std::string_view peek();
  /// Rest of the current line (without the newline), consuming it.
  std::string_view restOfLine();
  /// Moves past the next '\n' (start of binary data that follows a text line).
  void skipLine();
  /// Moves past the end of the current line if only whitespace remains on it.
  void skipToLineStart();

  double real(const char* what);
  /// A finite real (NaN/Inf is an error naming `what`).
  double finiteReal(const char* what);
  long long integer(const char* what);
  /// Integer in [lo, hi]; otherwise an error naming `what`.
  long long integerIn(const char* what, long long lo, long long hi);

  /// Raw binary access. `need` throws "truncated" unless n bytes remain.
  void need(size_t n, const std::string& what);
  /// Throws unless count items of itemSize bytes fit in the rest of the file.
  void needItems(unsigned long long count, size_t itemSize, const std::string& what);
  const char* rawBytes(size_t n, const std::string& what);
  template <class T>
  T raw(bool bigEndian, const char* what) {
    const char* p = rawBytes(sizeof(T), what);
    return loadValue<T>(p, bigEndian);
  }
  void seek(size_t pos) { pos_ = pos; }
  /// Marks that binary data was read: later messages give byte offsets.
  void setBinary() { binary_ = true; }

  /// Throws Error(Input) "path:line: msg" (or "path: msg (at byte N)" in binary data).
  [[noreturn]] void fail(const std::string& msg) const;
  [[noreturn]] void failAtLine(long line, const std::string& msg) const;

 private:
  void skipSpace();
  std::string path_;
  std::string data_;
  char comment_;
  size_t pos_ = 0;
  long lineNo_ = 1;      // line of data_[pos_]
  long tokenLine_ = 0;   // line of the last token
  bool binary_ = false;
};

/// Case-insensitive equality for ASCII keywords.
bool iequals(std::string_view a, std::string_view b);
std::string lowerCase(std::string_view s);

/// Appends the shortest decimal that reads back to exactly the same double.
void appendReal(std::string& out, double v);
void appendInt(std::string& out, long long v);

template <class T>
void appendRaw(std::string& out, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  out.append(b, sizeof(T));
}

/// Appends v in little-endian byte order (binary STL, PLY).
template <class T>
void appendLittleEndian(std::string& out, T v) {
  appendRaw<T>(out, hostIsBigEndian() ? byteSwapped(v) : v);
}

/// "path: cause" for a value that a writer cannot represent.
[[noreturn]] void throwWriteError(const std::string& path, const std::string& cause);

}  // namespace tet2spline::detail

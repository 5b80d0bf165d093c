// Shared helpers of the mesh readers and writers.
#include "io_util.h"

#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace tet2spline::detail {

std::string readWholeFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throwInputError(path, 0, std::string("cannot open file (") + std::strerror(errno) + ")");
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throwInputError(path, 0, "read error");
  std::string data = std::move(ss).str();
  if (data.empty()) throwInputError(path, 0, "empty file");
  return data;
}

bool hostIsBigEndian() {
  const uint16_t one = 1;
  unsigned char b;
  std::memcpy(&b, &one, 1);
  return b == 0;
}

namespace {
bool isSpace(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v'; }
}  // namespace

void Cursor::skipSpace() {
  while (pos_ < data_.size()) {
    const char c = data_[pos_];
    if (c == '\n') {
      ++lineNo_;
      ++pos_;
    } else if (isSpace(c)) {
      ++pos_;
    } else if (comment_ && c == comment_) {
      while (pos_ < data_.size() && data_[pos_] != '\n') ++pos_;
    } else {
      break;
    }
  }
}

bool Cursor::atEnd() {
  skipSpace();
  return pos_ >= data_.size();
}

bool Cursor::tryToken(std::string_view& tok) {
  skipSpace();
  if (pos_ >= data_.size()) return false;
  const size_t start = pos_;
  while (pos_ < data_.size() && !isSpace(data_[pos_]) && !(comment_ && data_[pos_] == comment_)) ++pos_;
  tokenLine_ = lineNo_;
  tok = std::string_view(data_).substr(start, pos_ - start);
  return true;
}

std::string_view Cursor::token(const char* what) {
  std::string_view tok;
  if (!tryToken(tok)) {
    if (tokenLine_ == 0) tokenLine_ = lineNo_;  // else: the last line with data
    fail(std::string("truncated: expected ") + what + " but the file ends");
  }
  return tok;
}

std::string_view Cursor::peek() {
  const size_t p = pos_;
  const long l = lineNo_, t = tokenLine_;
  std::string_view tok;
  if (!tryToken(tok)) tok = {};
  pos_ = p;
  lineNo_ = l;
  tokenLine_ = t;
  return tok;
}

std::string_view Cursor::restOfLine() {
  const size_t start = pos_;
  while (pos_ < data_.size() && data_[pos_] != '\n') ++pos_;
  size_t end = pos_;
  tokenLine_ = lineNo_;
  if (pos_ < data_.size()) {
    ++pos_;
    ++lineNo_;
  }
  if (end > start && data_[end - 1] == '\r') --end;
  return std::string_view(data_).substr(start, end - start);
}

void Cursor::skipLine() { restOfLine(); }

void Cursor::skipToLineStart() {
  size_t p = pos_;
  while (p < data_.size() && (data_[p] == ' ' || data_[p] == '\t' || data_[p] == '\r')) ++p;
  if (p < data_.size() && data_[p] == '\n') {
    pos_ = p + 1;
    ++lineNo_;
  }
}

double Cursor::real(const char* what) {
  const std::string_view tok = token(what);
  double v = 0;
  const char* b = tok.data();
  const char* e = b + tok.size();
  if (*b == '+') ++b;  // from_chars refuses a leading '+'
  auto [ptr, ec] = std::from_chars(b, e, v);
  if (ec == std::errc::result_out_of_range) {
    // Denormal or huge: strtod gives the IEEE result (0 or Inf).
    std::string s(tok);
    char* end = nullptr;
    v = std::strtod(s.c_str(), &end);
    if (end != s.c_str() + s.size()) fail(std::string("malformed ") + what + " '" + s.substr(0, 30) + "'");
    return v;
  }
  if (ec != std::errc() || ptr != e) fail(std::string("malformed ") + what + " '" + std::string(tok.substr(0, 30)) + "'");
  return v;
}

double Cursor::finiteReal(const char* what) {
  const double v = real(what);
  if (!std::isfinite(v)) fail(std::string(what) + " is NaN or infinite");
  return v;
}

long long Cursor::integer(const char* what) {
  const std::string_view tok = token(what);
  long long v = 0;
  const char* b = tok.data();
  const char* e = b + tok.size();
  if (*b == '+') ++b;
  auto [ptr, ec] = std::from_chars(b, e, v);
  if (ec != std::errc() || ptr != e)
    fail(std::string("malformed ") + what + " '" + std::string(tok.substr(0, 30)) + "' (expected an integer)");
  return v;
}

long long Cursor::integerIn(const char* what, long long lo, long long hi) {
  const long long v = integer(what);
  if (v < lo || v > hi)
    fail(std::string(what) + " " + std::to_string(v) + " out of range [" + std::to_string(lo) + ", " +
         std::to_string(hi) + "]");
  return v;
}

void Cursor::need(size_t n, const std::string& what) {
  if (n > remaining())
    fail("truncated: " + what + " needs " + std::to_string(n) + " bytes but only " + std::to_string(remaining()) +
         " remain");
}

void Cursor::needItems(unsigned long long count, size_t itemSize, const std::string& what) {
  if (itemSize != 0 && count > remaining() / itemSize)
    fail("truncated or corrupt: " + what + " declares " + std::to_string(count) + " items of " +
         std::to_string(itemSize) + " bytes but only " + std::to_string(remaining()) + " bytes remain");
}

const char* Cursor::rawBytes(size_t n, const std::string& what) {
  binary_ = true;
  need(n, what);
  const char* p = data_.data() + pos_;
  pos_ += n;
  return p;
}

void Cursor::fail(const std::string& msg) const {
  if (binary_) throwInputError(path_, 0, msg + " (at byte " + std::to_string(pos_) + ")");
  throwInputError(path_, tokenLine_, msg);
}

void Cursor::failAtLine(long line, const std::string& msg) const { throwInputError(path_, line, msg); }

bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(a[i])) != std::tolower(static_cast<unsigned char>(b[i]))) return false;
  return true;
}

std::string lowerCase(std::string_view s) {
  std::string r(s);
  for (auto& c : r) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return r;
}

void appendReal(std::string& out, double v) {
  char buf[32];
  auto [ptr, ec] = std::to_chars(buf, buf + sizeof buf, v);
  (void)ec;
  out.append(buf, ptr);
}

void appendInt(std::string& out, long long v) {
  char buf[24];
  auto [ptr, ec] = std::to_chars(buf, buf + sizeof buf, v);
  (void)ec;
  out.append(buf, ptr);
}

void throwWriteError(const std::string& path, const std::string& cause) { throwInputError(path, 0, cause); }

}  // namespace tet2spline::detail

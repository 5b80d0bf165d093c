#pragma once
// A small XML tokenizer, enough for VTK's XML files (internal to the io
// module): elements, attributes with entity decoding, comments, processing
// instructions, CDATA, and the raw <AppendedData> block, after which parsing
// stops because the bytes that follow are not XML.
#include <algorithm>
#include <cctype>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "tet2spline/param/error.h"

namespace tet2spline::detail {

struct XmlElement {
  std::string name;
  std::vector<std::pair<std::string, std::string>> attrs;
  std::vector<XmlElement> children;
  size_t contentBegin = 0, contentEnd = 0;  // text between the tags (leaf elements)
  size_t offset = 0;                        // of '<'

  const std::string* attr(const std::string& key) const {
    for (const auto& [k, v] : attrs)
      if (k == key) return &v;
    return nullptr;
  }
  const XmlElement* child(const std::string& n) const {
    for (const auto& c : children)
      if (c.name == n) return &c;
    return nullptr;
  }
};

/// A small XML tokenizer sufficient for VTK files: elements, attributes,
/// comments, processing instructions, CDATA, and the raw AppendedData block.
class XmlParser {
 public:
  XmlParser(const std::string& path, const std::string& s) : path_(path), s_(s) {}

  XmlElement parseDocument() {
    skipMisc();
    if (pos_ >= s_.size() || s_[pos_] != '<') fail("not an XML file (no root element)");
    XmlElement root;
    parseElement(root, 0);
    return root;
  }
  /// Offset of the byte after '_' in <AppendedData>, or npos.
  size_t appendedStart() const { return appended_; }
  const std::string* appendedEncoding() const { return appendedEncoding_.empty() ? nullptr : &appendedEncoding_; }

  long lineAt(size_t off) const { return 1 + static_cast<long>(std::count(s_.begin(), s_.begin() + static_cast<std::ptrdiff_t>(std::min(off, s_.size())), '\n')); }
  [[noreturn]] void fail(const std::string& msg) const { throwInputError(path_, lineAt(pos_), msg); }

 private:
  bool startsWith(const char* lit) const { return s_.compare(pos_, std::strlen(lit), lit) == 0; }
  void skipTo(const char* end, const char* what) {
    const size_t at = s_.find(end, pos_);
    if (at == std::string::npos) fail(std::string("truncated XML: unterminated ") + what);
    pos_ = at + std::strlen(end);
  }
  void skipSpace() {
    while (pos_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[pos_]))) ++pos_;
  }
  void skipMisc() {
    for (;;) {
      skipSpace();
      if (startsWith("<?")) skipTo("?>", "processing instruction");
      else if (startsWith("<!--")) skipTo("-->", "comment");
      else if (startsWith("<!")) skipTo(">", "declaration");
      else return;
    }
  }
  static bool nameChar(char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == ':' || c == '-' || c == '.';
  }
  std::string name() {
    const size_t b = pos_;
    while (pos_ < s_.size() && nameChar(s_[pos_])) ++pos_;
    if (b == pos_) fail("malformed XML: expected a name");
    return s_.substr(b, pos_ - b);
  }
  static std::string unescape(const std::string& v) {
    std::string r;
    for (size_t i = 0; i < v.size(); ++i) {
      if (v[i] != '&') {
        r += v[i];
        continue;
      }
      const size_t semi = v.find(';', i);
      const std::string ent = semi == std::string::npos ? std::string() : v.substr(i + 1, semi - i - 1);
      if (ent == "lt") r += '<';
      else if (ent == "gt") r += '>';
      else if (ent == "amp") r += '&';
      else if (ent == "quot") r += '"';
      else if (ent == "apos") r += '\'';
      else {
        r += '&';
        continue;
      }
      i = semi;
    }
    return r;
  }

  void parseElement(XmlElement& el, int depth) {
    if (depth > 64) fail("XML nested too deeply");
    el.offset = pos_;
    ++pos_;  // '<'
    el.name = name();
    for (;;) {
      skipSpace();
      if (pos_ >= s_.size()) fail("truncated XML: unterminated <" + el.name + "> tag");
      if (s_[pos_] == '/') {
        if (pos_ + 1 >= s_.size() || s_[pos_ + 1] != '>') fail("malformed XML tag <" + el.name + ">");
        pos_ += 2;
        return;  // self-closing
      }
      if (s_[pos_] == '>') {
        ++pos_;
        break;
      }
      std::string key = name();
      skipSpace();
      if (pos_ >= s_.size() || s_[pos_] != '=') fail("malformed XML attribute '" + key + "' in <" + el.name + ">");
      ++pos_;
      skipSpace();
      if (pos_ >= s_.size() || (s_[pos_] != '"' && s_[pos_] != '\'')) fail("malformed XML attribute '" + key + "' (no quotes)");
      const char q = s_[pos_++];
      const size_t end = s_.find(q, pos_);
      if (end == std::string::npos) fail("truncated XML: unterminated attribute '" + key + "'");
      el.attrs.emplace_back(std::move(key), unescape(s_.substr(pos_, end - pos_)));
      pos_ = end + 1;
    }
    if (el.name == "AppendedData") {
      const std::string* enc = el.attr("encoding");
      appendedEncoding_ = enc ? *enc : "raw";
      const size_t us = s_.find('_', pos_);
      if (us == std::string::npos) fail("AppendedData without the '_' marker");
      appended_ = us + 1;
      pos_ = s_.size();
      stop_ = true;
      return;
    }
    el.contentBegin = pos_;
    for (;;) {
      const size_t lt = s_.find('<', pos_);
      if (lt == std::string::npos) fail("truncated XML: no </" + el.name + ">");
      pos_ = lt;
      if (startsWith("<!--")) {
        skipTo("-->", "comment");
        continue;
      }
      if (startsWith("<![CDATA[")) {
        skipTo("]]>", "CDATA");
        continue;
      }
      if (startsWith("</")) {
        el.contentEnd = pos_;
        pos_ += 2;
        const std::string n = name();
        if (n != el.name) fail("malformed XML: <" + el.name + "> closed by </" + n + ">");
        skipSpace();
        if (pos_ >= s_.size() || s_[pos_] != '>') fail("malformed XML end tag </" + n);
        ++pos_;
        return;
      }
      el.children.emplace_back();
      parseElement(el.children.back(), depth + 1);
      if (stop_) return;
    }
  }

  const std::string& path_;
  const std::string& s_;
  size_t pos_ = 0;
  size_t appended_ = std::string::npos;
  std::string appendedEncoding_;
  bool stop_ = false;
};

}  // namespace tet2spline::detail

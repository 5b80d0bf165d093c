#pragma once
// Helpers shared by the report tests: scratch directories, file contents, a tag-balance check.
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace t2stest {

inline std::string scratch(const std::string& name) {
  const std::filesystem::path dir = std::filesystem::current_path() / "io_test_tmp" / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir.string();
}

inline std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

inline size_t occurrences(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + what.size())) ++n;
  return n;
}

/// Checks that every element the page opens is closed in order (HTML void elements
/// and self-closing SVG elements aside). Returns the first problem, or "".
inline std::string tagBalanceProblem(const std::string& html) {
  static const std::set<std::string> kVoid = {"meta", "img", "br", "hr", "link", "input", "wbr", "col", "source"};
  std::vector<std::string> stack;
  size_t at = 0;
  while ((at = html.find('<', at)) != std::string::npos) {
    if (html.compare(at, 4, "<!--") == 0) {
      at = html.find("-->", at);
      if (at == std::string::npos) return "unterminated comment";
      continue;
    }
    const size_t end = html.find('>', at);
    if (end == std::string::npos) return "unterminated tag at " + std::to_string(at);
    const std::string tag = html.substr(at + 1, end - at - 1);
    at = end + 1;
    if (tag.empty()) return "empty tag";
    if (tag[0] == '!') continue;  // doctype
    if (tag.find('<') != std::string::npos) return "'<' inside a tag: " + tag;
    const bool closing = tag[0] == '/';
    const std::string body = closing ? tag.substr(1) : tag;
    const std::string name = body.substr(0, body.find_first_of(" \t\n/"));
    if (closing) {
      if (stack.empty() || stack.back() != name)
        return "</" + name + "> closes <" + (stack.empty() ? std::string("nothing") : stack.back()) + ">";
      stack.pop_back();
    } else if (!kVoid.count(name) && tag.back() != '/') {
      stack.push_back(name);
      if (name == "style") {  // raw text: skip to its end tag
        const size_t close = html.find("</style>", at);
        if (close == std::string::npos) return "unterminated <style>";
        if (html.substr(at, close - at).find('<') != std::string::npos) return "'<' inside <style>";
        at = close;
      }
    }
  }
  return stack.empty() ? "" : "<" + stack.back() + "> never closed";
}

}  // namespace t2stest

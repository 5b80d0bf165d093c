#pragma once
/// Runs the tet2spline program as a user would and captures what it says.
#include <sys/wait.h>

#include <nlohmann/json.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "test_data.h"

namespace t2stest {

struct RunResult {
  int status = -1;
  std::string out;
  std::string err;
  /// stderr without its trailing newline, and how many lines it has.
  int errLines() const {
    int n = 0;
    for (char c : err) n += c == '\n';
    return n;
  }
};

inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// A fresh, empty folder under the build tree for one test.
inline std::filesystem::path scratchDir(const std::string& name) {
  auto dir = std::filesystem::path(dataDir()).parent_path() / "test-scratch" / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

/// Runs `program <args>` (args are passed to the shell as written).
inline RunResult runProgram(const std::string& program, const std::string& args, const std::filesystem::path& dir) {
  const auto outFile = dir / "cli.stdout", errFile = dir / "cli.stderr";
  const std::string cmd = "'" + program + "' " + args + " >'" + outFile.string() + "' 2>'" + errFile.string() + "' </dev/null";
  const int raw = std::system(cmd.c_str());
  RunResult r;
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : 128 + WTERMSIG(raw);
  r.out = slurp(outFile);
  r.err = slurp(errFile);
  std::filesystem::remove(outFile);
  std::filesystem::remove(errFile);
  return r;
}

/// Runs `tet2spline <args>`.
inline RunResult runCli(const std::string& args, const std::filesystem::path& dir) { return runProgram(cliPath(), args, dir); }

/// Another program built beside tet2spline (the benchmarks).
inline std::string sibling(const std::string& name) {
  return (std::filesystem::path(cliPath()).parent_path() / name).string();
}

/// `p` in single quotes, for the command lines runCli passes to the shell.
inline std::string q(const std::filesystem::path& p) { return "'" + p.string() + "'"; }

/// A JSON file (report.json, check --json output saved to a file).
inline nlohmann::json readJson(const std::filesystem::path& p) { return nlohmann::json::parse(slurp(p)); }

/// Names of the files in `dir`, as a set (compare with the expected outputs).
inline std::set<std::string> filesIn(const std::filesystem::path& dir) {
  std::set<std::string> s;
  for (const auto& e : std::filesystem::directory_iterator(dir)) s.insert(e.path().filename().string());
  return s;
}

/// Files in `dir` (names only), to prove that a failure left nothing behind.
inline std::vector<std::string> listDir(const std::filesystem::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(dir)) names.push_back(e.path().filename().string());
  return names;
}

}  // namespace t2stest

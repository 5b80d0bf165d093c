// tet2spline: the command-line program (design.md, "Command line and report").
// Exit status: 0 ok, 2 bad command line, 3 malformed input, 4 unsupported
// topology, 5 numerical failure. Errors are one line on stderr.
// Each command lives in its own cmd_*.cpp and registers itself below.
#include <iostream>
#include <new>
#include <vector>

#include "allocator_tuning.h"
#include "cli_common.h"
#include "tet2spline/param/error.h"

using namespace tet2spline;

int main(int argc, char** argv) {
  tet2spline::apps::useHugePages(argv);
  tet2spline::apps::keepFreedMemory();
  CLI::App app{"tet2spline: measure-controlled volumetric parameterization and trivariate B-spline fitting"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "tet2spline 0.1.0");
  app.add_flag("-q,--quiet", cli::globals().quiet, "print no log lines");
  app.add_flag("-v,--verbose", cli::globals().verbose, "print every progress message as a log line");

  std::vector<cli::Command> commands;
  commands.push_back(cli::addCheckCommand(app));
  commands.push_back(cli::addMeshCommand(app));
  commands.push_back(cli::addParamCommand(app));
  commands.push_back(cli::addTransportCommand(app));
  commands.push_back(cli::addFitCommand(app));
  commands.push_back(cli::addConvertCommand(app));

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    std::cerr << "tet2spline: " << e.what() << " (see tet2spline --help)\n";
    return static_cast<int>(ErrorKind::Usage);
  }

  try {
    for (const auto& c : commands)
      if (c.app->parsed()) return c.run();
  } catch (const Error& e) {
    std::cerr << "tet2spline: " << e.what() << '\n';
    return e.exitStatus();
  } catch (const std::bad_alloc&) {
    std::cerr << "tet2spline: out of memory\n";
    return static_cast<int>(ErrorKind::Numerical);
  } catch (const std::exception& e) {
    std::cerr << "tet2spline: internal error: " << e.what() << '\n';
    return static_cast<int>(ErrorKind::Numerical);
  }
  return 0;
}

// main.cpp — the `t2m` binary: parses the command line (CLI11) and runs the chosen subcommand.
// Subcommands register themselves from tools/cmd_*.cpp (see tools/command.h).
#include <algorithm>
#include <cstdio>
#include <exception>

#include "tools/command.h"

namespace t2m::cli {
std::vector<CommandAdder>& command_registry() {
  static std::vector<CommandAdder> r;
  return r;
}
}  // namespace t2m::cli

int main(int argc, char** argv) {
  CLI::App app{"t2m — text to physically simulated human motion (t2m-engine)"};
  app.set_version_flag("--version", std::string("t2m-engine ") + T2M_VERSION);
  app.require_subcommand(1);
  for (auto add : t2m::cli::command_registry()) add(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "t2m: %s (see 't2m --help')\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "t2m: %s\n", e.what());
    return 1;
  }
  return 0;
}

// What every Ridgeline program shares: the exit code a command asks for, and one way to parse
// the command line and turn errors into exit codes (2: bad input, 1: anything else).
#include <iostream>

#include "apps/commands.hpp"
#include "core/error.hpp"

namespace ridgeline::apps {
namespace {
int g_exit_code = 0;
}  // namespace

int exit_code() { return g_exit_code; }
void set_exit_code(int code) { g_exit_code = code; }

int parse_and_run(CLI::App& app, int argc, char** argv) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version reach here as "errors" that print and exit 0. A real parse error
    // (a value that does not convert, an unknown or missing option) is bad input like any
    // other: one line naming the option and the reason, exit 2 (CLI11's own codes are 101–127
    // and its message takes two lines).
    if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) return app.exit(e);
    std::cerr << "error: " << e.what() << " (see --help)\n";
    return 2;
  } catch (const InputError& e) {
    std::cerr << "error: " << e.what() << '\n';
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << '\n';
    return 1;
  }
  return exit_code();
}

}  // namespace ridgeline::apps

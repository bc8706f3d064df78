// rigfit command line: one subcommand per job. Exit codes (docs/usage.md):
//   0 done; 1 internal error; 2 bad input or usage (nothing written);
//   3 ran, but the refinement was not applied (output written, success false).
#include <CLI/CLI.hpp>
#include <exception>
#include <iostream>

#include "cli/commands.h"
#include "core/errors.h"

int main(int argc, char** argv) {
  CLI::App app{
      "rigfit: refines the extrinsics of a rig of fixed depth cameras, and tracks moving RGB-D "
      "cameras"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "rigfit 0.1.0");
  rigfit::cli::RegisterCommands(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : rigfit::cli::kExitBadInput;
  }
  try {
    return rigfit::cli::RunSelected(app);
  } catch (const rigfit::InputError& e) {
    std::cerr << "rigfit: error: " << e.what() << "\n";
    return rigfit::cli::kExitBadInput;
  } catch (const std::exception& e) {
    std::cerr << "rigfit: internal error: " << e.what() << "\n";
    return rigfit::cli::kExitInternal;
  }
}

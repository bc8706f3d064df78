#include "cli/commands.h"

namespace rigfit::cli {
namespace {

std::vector<Command>& Registry() {
  static std::vector<Command> commands;
  return commands;
}

}  // namespace

void RegisterCommands(CLI::App& app) {
  Registry() = {AddSimulateCommand(app),  AddRefineCommand(app),  AddEvaluateCommand(app),
                AddImportPlyCommand(app), AddCompareCommand(app), AddExportPlyCommand(app)};
}

int RunSelected(const CLI::App& app) {
  for (const Command& c : Registry()) {
    if (c.app->parsed()) return c.run();
  }
  return kExitBadInput;
}

}  // namespace rigfit::cli

#include "cli/commands.h"

#include <algorithm>
#include <memory>
#include <sstream>
#include <string>

#include "core/setting_error.h"

namespace rigfit::cli {
namespace {

std::vector<Command>& Registry() {
  static std::vector<Command> commands;
  return commands;
}

/// `rigfit --help` lists each subcommand with the first clause of its description (up to the
/// first ": " or ". "); `rigfit CMD --help` keeps the whole paragraph.
class SummaryFormatter : public CLI::Formatter {
 public:
  std::string make_subcommand(const CLI::App* sub) const override {
    const std::string& text = sub->get_description();
    const size_t end = std::min(text.find(": "), text.find(". "));
    std::stringstream out;
    CLI::detail::format_help(out, sub->get_display_name(true), text.substr(0, end), column_width_);
    return out.str();
  }
};

}  // namespace

void RegisterCommands(CLI::App& app) {
  app.formatter(std::make_shared<SummaryFormatter>());
  Registry() = {AddSimulateCommand(app),
                AddRefineCommand(app),
                AddEvaluateCommand(app),
                AddImportPlyCommand(app),
                AddCompareCommand(app),
                AddExportPlyCommand(app),
                AddEvaluateTrajectoryCommand(app),
                AddSimulateSequenceCommand(app),
                AddTrackCommand(app),
                AddFuseCommand(app),
                AddSlamCommand(app)};
}

int RunSelected(const CLI::App& app) {
  for (const Command& c : Registry()) {
    if (!c.app->parsed()) continue;
    try {
      return c.run();
    } catch (const SettingError& e) {
      throw InputError(c.app->get_name() + ": " + e.Spelled(SettingError::Flag));
    }
  }
  return kExitBadInput;
}

}  // namespace rigfit::cli

// `rigfit --help` lists the subcommands one line each; `rigfit CMD --help` keeps the paragraph.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <sstream>
#include <string>

#include "cli_test_util.h"

namespace rigfit {
namespace {

using cli_test::RunRigfit;
using ::testing::HasSubstr;
using ::testing::Not;

/// A scratch directory of this process and test for the runs' stdout and stderr files.
std::filesystem::path Scratch(const std::string& name) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("rigfit_cli_help_" + name + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir;
}

TEST(CliHelp, TopLevelListsEachSubcommandOnOneLine) {
  const std::filesystem::path scratch = Scratch("top");
  const cli_test::RunResult r = RunRigfit({"--help"}, scratch);
  std::filesystem::remove_all(scratch);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  for (const std::string command :
       {"simulate", "refine", "evaluate", "import-ply", "compare", "export-ply"}) {
    std::istringstream lines(r.out);
    std::string line;
    bool listed = false;
    while (std::getline(lines, line)) {
      if (line.rfind("  " + command + " ", 0) != 0) continue;
      listed = true;
      // One line, and none of the paragraph after the summary (the exit codes, for one).
      EXPECT_LT(line.size(), 240u) << line;
      EXPECT_THAT(line, Not(HasSubstr("Exit codes"))) << line;
    }
    EXPECT_TRUE(listed) << command << "\n" << r.out;
  }
  EXPECT_THAT(r.out, HasSubstr("  refine                      Refine the extrinsics of a rig from "
                               "one capture\n"));
}

TEST(CliHelp, SubcommandHelpKeepsTheWholeParagraph) {
  const std::filesystem::path scratch = Scratch("refine");
  const cli_test::RunResult r = RunRigfit({"refine", "--help"}, scratch);
  std::filesystem::remove_all(scratch);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("Refine the extrinsics of a rig from one capture: ground leveling"));
  EXPECT_THAT(r.out, HasSubstr("Exit codes: 0 refined"));
}

}  // namespace
}  // namespace rigfit

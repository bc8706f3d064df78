// Running the built rigfit executable (RIGFIT_CLI_PATH) as a subprocess, for the CLI tests.
#pragma once

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "shell_test_util.h"

namespace rigfit::cli_test {

namespace fs = std::filesystem;

struct RunResult {
  int exit_code = -1;
  std::string out;  ///< stdout
  std::string err;  ///< stderr
};

using rigfit::shell_test::ReadText;
using rigfit::shell_test::ShellQuote;

/// Runs the rigfit executable with args; stdout and stderr go through files in `scratch`.
inline RunResult RunRigfit(const std::vector<std::string>& args, const fs::path& scratch) {
  std::string command = ShellQuote(RIGFIT_CLI_PATH);
  for (const std::string& arg : args) command += " " + ShellQuote(arg);
  const fs::path out = scratch / "stdout.txt";
  const fs::path err = scratch / "stderr.txt";
  command += " >" + ShellQuote(out.string()) + " 2>" + ShellQuote(err.string());
  const int status = std::system(command.c_str());
  RunResult result;
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  result.out = ReadText(out);
  result.err = ReadText(err);
  fs::remove(out);
  fs::remove(err);
  return result;
}

/// Every number in a JSON document is finite (an output of rigfit holds no NaN or infinity).
inline bool AllNumbersFinite(const nlohmann::json& j) {
  if (j.is_number()) return std::isfinite(j.get<double>());
  if (j.is_structured()) {
    for (const nlohmann::json& item : j) {
      if (!AllNumbersFinite(item)) return false;
    }
  }
  return true;
}

inline std::string Describe(const RunResult& r) {
  return "exit " + std::to_string(r.exit_code) + "\nstdout:\n" + r.out + "\nstderr:\n" + r.err;
}

/// Runs `rigfit simulate --out OUT ARGS...`: "" when it succeeded, else what it printed.
inline std::string Simulate(const fs::path& out, const std::vector<std::string>& args,
                            const fs::path& scratch) {
  std::vector<std::string> command = {"simulate", "--out", out.string()};
  command.insert(command.end(), args.begin(), args.end());
  const RunResult sim = RunRigfit(command, scratch);
  return sim.exit_code == 0 ? "" : Describe(sim);
}

/// The folder of the rig `rigfit simulate ARGS...` in `rigs`, named after the arguments, simulated
/// there by the first process that asks for it while the others wait on its lock file. Sets
/// *error to the simulation's failure (empty when the rig is there).
inline fs::path SharedRig(const fs::path& rigs, const std::vector<std::string>& args,
                          const fs::path& scratch, std::string* error) {
  std::string name = "rig";
  for (const std::string& arg : args) {
    name += '_';
    for (char c : arg) name += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
  }
  const fs::path rig = rigs / name;
  fs::create_directories(rigs);
  const int lock = ::open((rigs / (name + ".lock")).c_str(), O_CREAT | O_RDWR, 0644);
  ::flock(lock, LOCK_EX);
  error->clear();
  if (!fs::exists(rig / "complete")) {
    fs::remove_all(rig);
    *error = Simulate(rig, args, scratch);
    if (error->empty()) std::ofstream(rig / "complete");
  }
  ::flock(lock, LOCK_UN);
  ::close(lock);
  return rig;
}

/// A suite that reads one rig written by `rigfit simulate ARGS...` and writes its own files in a
/// temporary folder ROOT named after the suite (removed after it); each test fails at once if the
/// simulation did. gtest_discover_tests runs every test in a process of its own, so a rig
/// simulated in SetUpTestSuite would be simulated again for every test: under ctest
/// (tests/CMakeLists.txt, SHARED_RIGS) the rigs live in RIGFIT_TEST_RIGS, emptied by the fixture
/// test clear_test_rigs at the start of the run, and each is simulated once for every suite of
/// the same ARGS (SharedRig). Run by hand, the suite simulates its rig into ROOT. Suite is the
/// derived class, so that each suite has its own folder and state.
template <class Suite>
class SimulatedRigSuite : public ::testing::Test {
 protected:
  static void SimulateRig(const std::string& name, const std::vector<std::string>& args) {
    root_ = fs::temp_directory_path() / (name + "_" + std::to_string(::getpid()));
    fs::remove_all(root_);
    fs::create_directories(root_);
    const char* rigs = std::getenv("RIGFIT_TEST_RIGS");
    if (rigs != nullptr && *rigs != '\0') {
      rig_ = SharedRig(rigs, args, root_, &simulate_error_);
      return;
    }
    rig_ = root_ / "rig";
    simulate_error_ = Simulate(rig_, args, root_);
  }
  static void TearDownTestSuite() { fs::remove_all(root_); }

  void SetUp() override { ASSERT_EQ(simulate_error_, "") << "rigfit simulate failed"; }

  /// A file of the rig (capture.h5, init.json, gt.json): read it, never write it.
  static std::string Rig(const std::string& name) { return (rig_ / name).string(); }
  static std::string Scratch(const std::string& name) { return (root_ / name).string(); }

  static inline fs::path root_;
  static inline fs::path rig_;
  static inline std::string simulate_error_;
};

}  // namespace rigfit::cli_test

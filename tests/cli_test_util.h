// Running the built rigfit executable (RIGFIT_CLI_PATH) as a subprocess, for the CLI tests.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace rigfit::cli_test {

namespace fs = std::filesystem;

struct RunResult {
  int exit_code = -1;
  std::string out;  ///< stdout
  std::string err;  ///< stderr
};

inline std::string ReadText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// Single-quoted for /bin/sh.
inline std::string ShellQuote(const std::string& s) {
  std::string quoted = "'";
  for (char c : s) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

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

/// A suite that runs `rigfit simulate --out ROOT/rig ARGS...` once, in a temporary folder
/// ROOT named after the suite (removed after it), and fails each test at once if the simulation
/// did. Suite is the derived class, so that each suite has its own folder and state.
template <class Suite>
class SimulatedRigSuite : public ::testing::Test {
 protected:
  static void SimulateRig(const std::string& name, const std::vector<std::string>& args) {
    root_ = fs::temp_directory_path() / (name + "_" + std::to_string(::getpid()));
    fs::remove_all(root_);
    fs::create_directories(root_);
    std::vector<std::string> command = {"simulate", "--out", (root_ / "rig").string()};
    command.insert(command.end(), args.begin(), args.end());
    const RunResult sim = RunRigfit(command, root_);
    simulate_error_ = sim.exit_code == 0 ? "" : Describe(sim);
  }
  static void TearDownTestSuite() { fs::remove_all(root_); }

  void SetUp() override { ASSERT_EQ(simulate_error_, "") << "rigfit simulate failed"; }

  static std::string Rig(const std::string& name) { return (root_ / "rig" / name).string(); }
  static std::string Scratch(const std::string& name) { return (root_ / name).string(); }

  static inline fs::path root_;
  static inline std::string simulate_error_;
};

}  // namespace rigfit::cli_test

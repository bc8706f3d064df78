// Issue 7, fuzzing: every seed of fuzz/corpus/<target>/ and every input the fuzzers found
// (fuzz/regressions/<target>/) goes through its loader again here, so the findings stay fixed
// in CI without clang or libFuzzer (and under ASan + UBSan in the sanitizer suite). A loader
// must return or throw InputError: another exception fails the test, a crash fails the
// executable. docs/reliability.md lists the findings.
#include <gtest/gtest.h>

#include <algorithm>
#include <exception>
#include <filesystem>
#include <string>
#include <vector>

#include "core/errors.h"
#include "io/capture_h5.h"
#include "io/config_yaml.h"
#include "io/extrinsics_json.h"
#include "io_test_util.h"

#if defined(__SANITIZE_ADDRESS__)
// libhdf5 trusts sizes read from the file and may ask malloc for exabytes; it checks for NULL
// and fails cleanly, which is what a normal process gets. ASan would abort on such a request
// instead, so in this executable (and only here) it returns NULL like malloc does.
extern "C" const char* __asan_default_options() { return "allocator_may_return_null=1"; }
#endif

namespace rigfit {
namespace {

namespace fs = std::filesystem;

/// Files of fuzz/corpus/<target> and fuzz/regressions/<target>, sorted.
std::vector<fs::path> Inputs(const std::string& target) {
  std::vector<fs::path> files;
  for (const char* kind : {"corpus", "regressions"}) {
    const fs::path dir = fs::path(RIGFIT_SOURCE_DIR) / "fuzz" / kind / target;
    if (!fs::is_directory(dir)) continue;
    for (const auto& entry : fs::directory_iterator(dir)) files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

/// Runs load on the bytes of every input of target: returning and InputError are both fine.
template <typename Load>
void LoadEvery(const std::string& target, Load load) {
  const std::vector<fs::path> inputs = Inputs(target);
  EXPECT_FALSE(inputs.empty()) << "no seeds for " << target;
  for (const fs::path& input : inputs) {
    SCOPED_TRACE(input.string());
    const std::string bytes = io_test::ReadText(input.string());
    try {
      load(bytes, input.filename().string());
    } catch (const InputError&) {
    } catch (const std::exception& e) {
      ADD_FAILURE() << "not an InputError: " << e.what();
    }
  }
}

TEST(FuzzRegression, ConfigYaml) {
  LoadEvery("config_yaml",
            [](const std::string& bytes, const std::string& name) { ParseConfig(bytes, name); });
}

TEST(FuzzRegression, ExtrinsicsJson) {
  LoadEvery("extrinsics_json", [](const std::string& bytes, const std::string& name) {
    ParseExtrinsics(bytes, name);
  });
}

TEST(FuzzRegression, CaptureH5) {
  LoadEvery("capture_h5", [](const std::string& bytes, const std::string& name) {
    ReadCaptureFromMemory(bytes.data(), bytes.size(), name);
  });
}

}  // namespace
}  // namespace rigfit

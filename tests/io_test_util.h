// Helpers shared by the io_* tests: a temporary directory per test and file utilities.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "core/errors.h"
#include "core/types.h"

namespace rigfit::io_test {

/// A fresh directory under the system temp dir, removed with everything in it at the end.
class TempDirTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string pattern =
        (std::filesystem::temp_directory_path() / "rigfit_io_test_XXXXXX").string();
    ASSERT_NE(::mkdtemp(pattern.data()), nullptr);
    dir_ = pattern;
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  /// Path of a file in the temporary directory.
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }

  /// Names of the files in the temporary directory, sorted.
  std::vector<std::string> Listing() const {
    std::vector<std::string> names;
    for (const auto& entry : std::filesystem::directory_iterator(dir_)) {
      names.push_back(entry.path().filename().string());
    }
    std::sort(names.begin(), names.end());
    return names;
  }

  std::filesystem::path dir_;
};

/// The path of a file of ../shared/data (RIGFIT_SHARED_DATA_DIR). A test that reads one
/// starts with RIGFIT_NEED_SHARED_DATA(path).
inline std::string SharedDataPath(const std::string& relative) {
  return std::string(RIGFIT_SHARED_DATA_DIR) + "/" + relative;
}

/// Under CI (the environment variable CI is "true" or "1", as .ci/run sets it).
inline bool InCi() {
  const char* ci = std::getenv("CI");
  return ci != nullptr && (std::strcmp(ci, "true") == 0 || std::strcmp(ci, "1") == 0);
}

}  // namespace rigfit::io_test

/// Skips the calling test when `path` (SharedDataPath) is absent, saying so, in a bare local
/// clone; fails it under CI (io_test::InCi), where a missing data set must not pass unnoticed.
#define RIGFIT_NEED_SHARED_DATA(path)                                                       \
  do {                                                                                      \
    if (!std::filesystem::exists(path)) {                                                   \
      if (::rigfit::io_test::InCi()) FAIL() << (path) << " is absent (CI=true: fails)";     \
      GTEST_SKIP() << (path) << " is absent: the real data of ../shared/data (outside CI)"; \
    }                                                                                       \
  } while (0)

namespace rigfit::io_test {

inline void WriteText(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

inline std::string ReadText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// The message of the InputError that f throws; a test failure (and "") if it throws none.
template <typename F>
std::string InputErrorMessage(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected an InputError";
  return "";
}

/// Every field of a camera equal, depth bit for bit (NaN included).
inline void ExpectSameCamera(const CameraCapture& a, const CameraCapture& e) {
  SCOPED_TRACE(e.serial);
  EXPECT_EQ(a.serial, e.serial);
  EXPECT_EQ(a.width, e.width);
  EXPECT_EQ(a.height, e.height);
  ASSERT_EQ(a.depth_m.size(), e.depth_m.size());
  for (size_t k = 0; k < e.depth_m.size(); ++k) {
    EXPECT_EQ(std::memcmp(&a.depth_m[k], &e.depth_m[k], sizeof(float)), 0) << k;
  }
  EXPECT_EQ(a.intrinsics.fx, e.intrinsics.fx);
  EXPECT_EQ(a.intrinsics.fy, e.intrinsics.fy);
  EXPECT_EQ(a.intrinsics.cx, e.intrinsics.cx);
  EXPECT_EQ(a.intrinsics.cy, e.intrinsics.cy);
  EXPECT_EQ(a.baseline_m, e.baseline_m);
  EXPECT_EQ(a.confidence, e.confidence);
  EXPECT_EQ(a.color, e.color);
  EXPECT_EQ(a.points, e.points);
  EXPECT_EQ(a.normals, e.normals);
  EXPECT_EQ(a.glitch_depth_samples, e.glitch_depth_samples);
}

/// Every field of every camera equal (ExpectSameCamera).
inline void ExpectSameCapture(const RigCapture& actual, const RigCapture& expected) {
  ASSERT_EQ(actual.cameras.size(), expected.cameras.size());
  for (size_t i = 0; i < expected.cameras.size(); ++i) {
    ExpectSameCamera(actual.cameras[i], expected.cameras[i]);
  }
}

}  // namespace rigfit::io_test

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <stdexcept>

#include "core/errors.h"
#include "io/atomic_file.h"
#include "io_test_util.h"

namespace rigfit {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

class AtomicFileTest : public io_test::TempDirTest {};

TEST_F(AtomicFileTest, WritesThroughATemporaryInTheSameDirectory) {
  const std::string path = Path("out.txt");
  std::string seen_tmp;
  WriteFileAtomically(path, [&](const std::string& tmp) {
    seen_tmp = tmp;
    EXPECT_EQ(std::filesystem::path(tmp).parent_path(), dir_);
    EXPECT_FALSE(std::filesystem::exists(path));  // not visible before the rename
    io_test::WriteText(tmp, "new");
  });
  EXPECT_EQ(io_test::ReadText(path), "new");
  EXPECT_FALSE(std::filesystem::exists(seen_tmp));
  EXPECT_THAT(Listing(), ElementsAre("out.txt"));
}

TEST_F(AtomicFileTest, ReplacesAnExistingFile) {
  const std::string path = Path("out.txt");
  io_test::WriteText(path, "old");
  WriteFileAtomically(path, [](const std::string& tmp) { io_test::WriteText(tmp, "new"); });
  EXPECT_EQ(io_test::ReadText(path), "new");
  EXPECT_THAT(Listing(), ElementsAre("out.txt"));
}

TEST_F(AtomicFileTest, FailingWriterKeepsThePreviousFileAndLeavesNoTemporary) {
  const std::string path = Path("out.txt");
  io_test::WriteText(path, "previous");
  EXPECT_THROW(WriteFileAtomically(path,
                                   [](const std::string& tmp) {
                                     io_test::WriteText(tmp, "half writ");
                                     throw std::runtime_error("disk full");
                                   }),
               std::runtime_error);
  EXPECT_EQ(io_test::ReadText(path), "previous");
  EXPECT_THAT(Listing(), ElementsAre("out.txt"));
}

TEST_F(AtomicFileTest, MissingDirectoryIsAnInputError) {
  const std::string path = Path("no_such_dir/out.txt");
  try {
    WriteFileAtomically(path, [](const std::string&) { FAIL() << "writer must not run"; });
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("no_such_dir"));
    EXPECT_THAT(e.what(), HasSubstr("does not exist"));
  }
}

TEST_F(AtomicFileTest, RefusesToOverwriteAnInputByAnyName) {
  const std::string input = Path("in.json");
  io_test::WriteText(input, "{}");
  std::filesystem::create_symlink(input, Path("link.json"));
  const std::string dotted = (dir_ / "." / "in.json").string();
  for (const std::string& target : {input, Path("link.json"), dotted}) {
    try {
      RefuseToOverwriteInputs(target, {Path("other.json"), input}, "extrinsics");
      FAIL() << "expected InputError for " << target;
    } catch (const InputError& e) {
      EXPECT_THAT(e.what(), HasSubstr("extrinsics: refusing to write " + target));
      EXPECT_THAT(e.what(), HasSubstr("it is an input file"));
    }
  }
  EXPECT_NO_THROW(RefuseToOverwriteInputs(Path("new.json"), {input}, "extrinsics"));
  io_test::WriteText(Path("other.json"), "{}");
  EXPECT_NO_THROW(RefuseToOverwriteInputs(Path("other.json"), {input}, "extrinsics"));
}

}  // namespace
}  // namespace rigfit

// SettingError (core/setting_error.h): one message, spelled by each front end its own way.
#include "core/setting_error.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace rigfit {
namespace {

using ::testing::StrEq;

TEST(SettingError, SpellsItsSettingsAsKeysFlagsOrAnythingElse) {
  const SettingError e("noise_corr_share", "> 0 needs {noise_corr_px} > 0");
  EXPECT_EQ(e.key(), "noise_corr_share");
  EXPECT_THAT(e.what(), StrEq("noise_corr_share > 0 needs noise_corr_px > 0"));
  EXPECT_EQ(e.Spelled(SettingError::Flag), "--noise-corr-share > 0 needs --noise-corr-px > 0");
  EXPECT_EQ(e.Spelled([](std::string_view key) { return "<" + std::string(key) + ">"; }),
            "<noise_corr_share> > 0 needs <noise_corr_px> > 0");
}

TEST(SettingError, AWordedMessageAndAUsersBracesKeepTheirWords) {
  const SettingError worded =
      SettingError::Worded("min_depth", "need 0 <= {min_depth} < {max_depth}");
  EXPECT_EQ(worded.Spelled(SettingError::Flag), "need 0 <= --min-depth < --max-depth");
  // A value the user gave is not a key: "{Fast}" and "{ }" stay as they are.
  const SettingError value("prior", "must be constant-velocity or identity, got {Fast}{ }");
  EXPECT_EQ(value.Spelled(SettingError::Flag),
            "--prior must be constant-velocity or identity, got {Fast}{ }");
  EXPECT_THAT(value.what(), StrEq("prior must be constant-velocity or identity, got {Fast}{ }"));
}

}  // namespace
}  // namespace rigfit

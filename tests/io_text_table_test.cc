// TextTable (io/text_table.h): columns padded to their width and alignment, headings over
// spans of columns, no trailing spaces.
#include <gtest/gtest.h>

#include "io/text_table.h"

namespace rigfit {
namespace {

TEST(TextTableTest, PadsCellsToTheirColumnsAndSeparatesThemByTheirGaps) {
  TextTable table({{6, Align::kLeft, ""}, {5}, {4, Align::kRight, " | "}, {0, Align::kLeft, "  "}});
  table.AddRow({"name", "1.5", "-", "note"});
  table.AddRow({"longer name", "123456", "2"});
  EXPECT_EQ(table.text(),
            "name     1.5 |    -  note\n"
            "longer name 123456 |    2\n");
}

TEST(TextTableTest, SpansCoverTheirColumnsAndTheGapsBetweenThem) {
  TextTable table({{4, Align::kLeft, ""}, {3}, {3}, {5, Align::kRight, " | "}, {5}});
  table.AddSpans({{"", 1}, {"left", 2}, {"mid", 2, Align::kCentre}});
  table.AddSpans({{"", 1}, {"", 2}, {"", 2}});
  table.AddRow({"row", "a", "b", "c", "d"});
  EXPECT_EQ(table.text(),
            "     left    |     mid\n"
            "             |\n"
            "row    a   b |     c     d\n");
}

TEST(TextTableTest, FixedOrDashShowsTheNumberOnlyWhenItIsShown) {
  EXPECT_EQ(FixedOrDash(true, 1.23456, 3), "1.235");
  EXPECT_EQ(FixedOrDash(false, 1.23456, 3), "-");
}

}  // namespace
}  // namespace rigfit

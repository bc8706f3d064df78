// Text tables, read and printed. Reading: whitespace-separated text files of numbers and
// names, one record per line (TUM trajectories, TUM and ICL-NUIM image lists, 7-Scenes poses):
// the line iteration and the number parsing their readers share, so that every one names the
// file and the line the same way. Printing: the fixed-width tables of the commands' summaries
// (TextTable), laid out one way for all of them.
#pragma once

#include <string>
#include <vector>

namespace rigfit {

/// One data line of a text file: its number (from 1) and its whitespace-separated fields.
struct TextRow {
  int line = 0;
  std::vector<std::string> fields;
};

/// The data lines of a text file, in order: blank lines and lines whose first non-blank
/// character is '#' are skipped. Throws InputError("<path>: cannot open: <reason>").
std::vector<TextRow> ReadTextRows(const std::string& path);

/// "<path>: line <n>", the prefix of every message about a line.
std::string LineWhere(const std::string& path, int line);

/// Fails unless `row` has `count` fields: InputError("<path>: line <n>: expected <what>, got
/// <k> fields").
void ExpectFields(const TextRow& row, size_t count, const std::string& what,
                  const std::string& path);

/// The whole token as a finite number. Throws InputError("<where>: '<token>' is not a number")
/// or ("<where>: '<token>' is not finite").
double ParseFiniteNumber(const std::string& token, const std::string& where);

/// Where a cell stands in its width.
enum class Align { kLeft, kRight, kCentre };

/// One column of a printed table.
struct TextColumn {
  size_t width = 0;  ///< cells are padded to it; a longer one overflows (0: free text)
  Align align = Align::kRight;
  std::string gap = " ";  ///< what stands between the previous column and this one
};

/// A heading over `span` adjacent columns, laid out in their width and the gaps between them.
struct TextSpan {
  std::string text;
  int span = 1;
  Align align = Align::kLeft;
};

/// A number's cell: `value` with `digits` decimals, or "-" when it is not shown (not measured,
/// not defined).
std::string FixedOrDash(bool shown, double value, int digits);

/// A table printed in fixed-width columns, one line a row. Every line ends in '\n' and
/// without trailing spaces.
class TextTable {
 public:
  explicit TextTable(std::vector<TextColumn> columns);

  /// A row of cells, one per column from the first on; fewer cells leave the last columns out.
  void AddRow(const std::vector<std::string>& cells);

  /// A row of headings, each over its span of columns, from the first column on.
  void AddSpans(const std::vector<TextSpan>& spans);

  /// The lines so far.
  const std::string& text() const { return text_; }

 private:
  std::vector<TextColumn> columns_;
  std::string text_;
};

}  // namespace rigfit

#include "io/text_table.h"

#include <cassert>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "core/errors.h"
#include "core/format.h"
#include "io/read_file.h"

namespace rigfit {

std::vector<TextRow> ReadTextRows(const std::string& path) {
  std::istringstream text(ReadWholeFile(path));
  std::vector<TextRow> rows;
  std::string line;
  for (int number = 1; std::getline(text, line); ++number) {
    const size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    TextRow row;
    row.line = number;
    std::istringstream fields(line);
    for (std::string field; fields >> field;) row.fields.push_back(field);
    rows.push_back(std::move(row));
  }
  return rows;
}

std::string LineWhere(const std::string& path, int line) {
  return path + ": line " + std::to_string(line);
}

void ExpectFields(const TextRow& row, size_t count, const std::string& what,
                  const std::string& path) {
  if (row.fields.size() != count) {
    throw InputError(LineWhere(path, row.line) + ": expected " + what + ", got " +
                     std::to_string(row.fields.size()) + " fields");
  }
}

double ParseFiniteNumber(const std::string& token, const std::string& where) {
  double value = 0.0;
  try {
    size_t used = 0;
    value = std::stod(token, &used);
    if (used != token.size()) throw std::invalid_argument(token);
  } catch (const std::exception&) {
    throw InputError(where + ": '" + token + "' is not a number");
  }
  if (!std::isfinite(value)) throw InputError(where + ": '" + token + "' is not finite");
  return value;
}

namespace {

/// `text` padded with spaces to `width` as `align` says.
std::string Pad(const std::string& text, size_t width, Align align) {
  if (text.size() >= width) return text;
  const size_t space = width - text.size();
  const size_t left = align == Align::kRight ? space : align == Align::kCentre ? space / 2 : 0;
  return std::string(left, ' ') + text + std::string(space - left, ' ');
}

/// Ends a line: its trailing spaces removed, a '\n' added.
void AppendLine(std::string line, std::string* text) {
  line.erase(line.find_last_not_of(' ') + 1);
  *text += line + '\n';
}

}  // namespace

std::string FixedOrDash(bool shown, double value, int digits) {
  return shown ? Fixed(value, digits) : "-";
}

TextTable::TextTable(std::vector<TextColumn> columns) : columns_(std::move(columns)) {}

void TextTable::AddRow(const std::vector<std::string>& cells) {
  assert(cells.size() <= columns_.size());
  std::string line;
  for (size_t i = 0; i < cells.size(); ++i) {
    const TextColumn& column = columns_[i];
    line += (i > 0 ? column.gap : "") + Pad(cells[i], column.width, column.align);
  }
  AppendLine(std::move(line), &text_);
}

void TextTable::AddSpans(const std::vector<TextSpan>& spans) {
  std::string line;
  size_t column = 0;
  for (const TextSpan& span : spans) {
    assert(span.span >= 1 && column + span.span <= columns_.size());
    size_t width = columns_[column].width;
    for (int k = 1; k < span.span; ++k) {
      width += columns_[column + k].gap.size() + columns_[column + k].width;
    }
    line += (column > 0 ? columns_[column].gap : "") + Pad(span.text, width, span.align);
    column += span.span;
  }
  AppendLine(std::move(line), &text_);
}

}  // namespace rigfit

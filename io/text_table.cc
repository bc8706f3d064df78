#include "io/text_table.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "core/errors.h"
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

}  // namespace rigfit

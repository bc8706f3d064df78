// Whitespace-separated text files of numbers and names, one record per line (TUM trajectories,
// TUM and ICL-NUIM image lists, 7-Scenes poses): the line iteration and the number parsing
// their readers share, so that every one names the file and the line the same way.
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

}  // namespace rigfit

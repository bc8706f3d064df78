// Progress and warnings from the solvers, without tying them to a terminal: the CLI sends
// them to stderr according to --quiet / --verbose, tests collect them.
#pragma once

#include <functional>
#include <string>

namespace rigfit {

enum class LogLevel { kDebug, kInfo, kWarning };

/// Where solver messages go. A default-constructed Log drops everything.
struct Log {
  std::function<void(LogLevel, const std::string&)> sink;

  void Debug(const std::string& message) const { Emit(LogLevel::kDebug, message); }
  void Info(const std::string& message) const { Emit(LogLevel::kInfo, message); }
  void Warning(const std::string& message) const { Emit(LogLevel::kWarning, message); }

 private:
  void Emit(LogLevel level, const std::string& message) const {
    if (sink) sink(level, message);
  }
};

}  // namespace rigfit

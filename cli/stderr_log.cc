#include "cli/stderr_log.h"

#include <cstdio>

namespace rigfit::cli {

Log StderrLog(const std::string& prefix, Verbosity verbosity) {
  Log log;
  log.sink = [prefix, verbosity](LogLevel level, const std::string& message) {
    switch (level) {
      case LogLevel::kWarning:
        std::fprintf(stderr, "%swarning: %s\n", prefix.c_str(), message.c_str());
        break;
      case LogLevel::kInfo:
        if (verbosity != Verbosity::kQuiet) {
          std::fprintf(stderr, "%s%s\n", prefix.c_str(), message.c_str());
        }
        break;
      case LogLevel::kDebug:
        if (verbosity == Verbosity::kVerbose) {
          std::fprintf(stderr, "%sdebug: %s\n", prefix.c_str(), message.c_str());
        }
        break;
    }
  };
  return log;
}

}  // namespace rigfit::cli

// The solvers' progress and warnings on stderr, one way for every command.
#pragma once

#include <string>

#include "core/log.h"

namespace rigfit::cli {

enum class Verbosity { kQuiet, kNormal, kVerbose };

/// A Log printing "<prefix>warning: ..." always, "<prefix>..." unless quiet, and
/// "<prefix>debug: ..." when verbose.
Log StderrLog(const std::string& prefix, Verbosity verbosity);

}  // namespace rigfit::cli

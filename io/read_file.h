// Whole-file reads shared by the io/ readers.
#pragma once

#include <string>

namespace rigfit {

/// The bytes of a file. Throws InputError("<path>: cannot open: <reason>") if it cannot be
/// read (missing, a directory, no permission).
std::string ReadWholeFile(const std::string& path);

}  // namespace rigfit

// Safe output files: every file rigfit writes appears whole or not at all, and never
// replaces one of the run's own inputs.
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace rigfit {

/// Calls write(tmp_path) for a new temporary file in path's directory, flushes it to disk and
/// renames it onto path, so readers see either the previous file or the complete new one.
/// The temporary is removed if write (or the rename) throws, and the exception propagates.
/// Throws InputError if path's directory does not exist or the file cannot be created.
void WriteFileAtomically(const std::string& path,
                         const std::function<void(const std::string& tmp_path)>& write);

/// WriteFileAtomically of `text` as the whole file (binary, as given); InputError naming path
/// on a write error.
void WriteTextFileAtomically(const std::string& path, const std::string& text);

/// Throws InputError("<what>: refusing to write <path>: it is an input file") when path names
/// the same file (same inode, through any link or relative path) as any of inputs.
void RefuseToOverwriteInputs(const std::string& path, const std::vector<std::string>& inputs,
                             const std::string& what);

/// The checks of an output file before any work: RefuseToOverwriteInputs, then InputError
/// ("<what> <path> ...") when path is a directory, exists and `force` is false ("use --force
/// to replace it"), or its directory does not exist.
void CheckOutputFile(const std::string& path, const std::vector<std::string>& inputs, bool force,
                     const std::string& what);

}  // namespace rigfit

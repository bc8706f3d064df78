#include "io/atomic_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "core/errors.h"

namespace rigfit {
namespace {

namespace fs = std::filesystem;

std::string ErrnoText() { return std::strerror(errno); }

/// Creates a new, empty, uniquely named file ".<name>.tmp-<pid>-<n>" next to target.
std::string CreateTemporaryBeside(const fs::path& target) {
  static std::atomic<unsigned> counter{0};
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  for (int attempt = 0; attempt < 100; ++attempt) {
    const fs::path tmp = dir / ("." + target.filename().string() + ".tmp-" +
                                std::to_string(::getpid()) + "-" + std::to_string(counter++));
    const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd >= 0) {
      ::close(fd);
      return tmp.string();
    }
    if (errno != EEXIST) {
      throw InputError(target.string() + ": cannot create a temporary file in '" + dir.string() +
                       "': " + ErrnoText());
    }
  }
  throw InputError(target.string() + ": cannot create a unique temporary file in '" + dir.string() +
                   "'");
}

/// fsync of the finished temporary, so that the rename never publishes a file whose data is
/// not yet on disk.
void SyncFile(const std::string& tmp, const std::string& target) {
  const int fd = ::open(tmp.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw InputError(target + ": cannot reopen '" + tmp + "': " + ErrnoText());
  const int rc = ::fsync(fd);
  const std::string error = rc == 0 ? "" : ErrnoText();
  ::close(fd);
  if (rc != 0) throw InputError(target + ": cannot flush '" + tmp + "' to disk: " + error);
}

/// fsync of the directory so the rename itself is durable. Best effort: the new file is
/// already complete and in place, and some file systems do not sync directories.
void SyncDirectory(const fs::path& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

}  // namespace

void WriteFileAtomically(const std::string& path,
                         const std::function<void(const std::string& tmp_path)>& write) {
  const fs::path target(path);
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    throw InputError(path + ": cannot write: directory '" + dir.string() + "' does not exist");
  }
  if (fs::is_directory(target, ec)) {
    throw InputError(path + ": cannot write: it is a directory");
  }
  const std::string tmp = CreateTemporaryBeside(target);
  try {
    write(tmp);
    SyncFile(tmp, path);
    if (std::rename(tmp.c_str(), path.c_str()) != 0) {
      throw InputError(path + ": cannot replace with '" + tmp + "': " + ErrnoText());
    }
  } catch (...) {
    std::remove(tmp.c_str());
    throw;
  }
  SyncDirectory(dir);
}

void RefuseToOverwriteInputs(const std::string& path, const std::vector<std::string>& inputs,
                             const std::string& what) {
  std::error_code ec;
  if (!fs::exists(path, ec)) return;  // a file that does not exist yet is nobody's input
  for (const std::string& input : inputs) {
    if (fs::equivalent(path, input, ec) && !ec) {
      throw InputError(what + ": refusing to write " + path + ": it is an input file");
    }
  }
}

void CheckOutputFile(const std::string& path, const std::vector<std::string>& inputs, bool force,
                     const std::string& what) {
  RefuseToOverwriteInputs(path, inputs, what);
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    throw InputError(what + " " + path + " is a directory, expected a file name");
  }
  if (!force && fs::exists(path, ec)) {
    throw InputError(what + " " + path + " exists (use --force to replace it)");
  }
  const fs::path out(path);
  const fs::path dir = out.has_parent_path() ? out.parent_path() : fs::path(".");
  if (!fs::is_directory(dir, ec)) {
    throw InputError(what + " " + path + ": directory " + dir.string() + " does not exist");
  }
}

void WriteTextFileAtomically(const std::string& path, const std::string& text) {
  WriteFileAtomically(path, [&](const std::string& tmp_path) {
    std::ofstream out(tmp_path, std::ios::binary | std::ios::trunc);
    out << text;
    out.close();
    if (!out) throw InputError(path + ": write error");
  });
}

}  // namespace rigfit

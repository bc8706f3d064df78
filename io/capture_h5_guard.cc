// The guarded capture read (ReadCaptureGuarded, io/capture_h5.h): the file read in a forked
// child, the capture sent back through a pipe, a crash or a hang of the HDF5 library turned
// into an InputError.
#include <fcntl.h>
#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/errors.h"
#include "io/capture_bytes.h"
#include "io/capture_h5.h"

namespace rigfit {
namespace {

/// Writes all of `bytes` to fd (blocking), after its length as a uint64; false on an error.
bool WriteAll(int fd, const std::string& bytes) {
  const std::uint64_t length = bytes.size();
  const std::string framed(reinterpret_cast<const char*>(&length), sizeof(length));
  for (const std::string* part : {&framed, &bytes}) {
    for (std::size_t done = 0; done < part->size();) {
      const ssize_t n = write(fd, part->data() + done, part->size() - done);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) return false;
      done += static_cast<std::size_t>(n);
    }
  }
  return true;
}

/// waitpid, again after a signal; its result.
pid_t Reap(pid_t pid, int* status) {
  pid_t done = 0;
  while ((done = waitpid(pid, status, 0)) < 0 && errno == EINTR) {
  }
  return done;
}

/// The guarded read's child process and the read end of its pipe: on every way out of the
/// parent (an exception too), the pipe is closed and a child still running is killed and
/// reaped.
struct ReadingChild {
  pid_t pid = -1;
  int fd = -1;

  ReadingChild(pid_t p, int f) : pid(p), fd(f) {}
  ReadingChild(const ReadingChild&) = delete;
  ReadingChild& operator=(const ReadingChild&) = delete;
  ~ReadingChild() { Stop(); }

  void ClosePipe() {
    if (fd >= 0) close(fd);
    fd = -1;
  }
  void Stop() {
    ClosePipe();
    if (pid > 0) {
      kill(pid, SIGKILL);
      Reap(pid, nullptr);
    }
    pid = -1;
  }
};

}  // namespace

namespace {

/// The forked child's work: the read, its result sent through fd. _exit: no atexit handlers,
/// no destructors of the parent's objects. Exit code 0 sends the capture's bytes, 2 and 3 an
/// error message, each after its length; 4: they could not be sent.
[[noreturn]] void ReadInChild(const std::string& path, int fd) {
  int code = 0;
  std::string bytes;
  try {
    bytes = EncodeCapture(ReadCapture(path));
  } catch (const InputError& e) {
    code = 2;
    bytes = e.what();
  } catch (const std::exception& e) {
    code = 3;
    bytes = e.what();
  }
  if (!WriteAll(fd, bytes)) code = 4;
  _exit(code);
}

/// What came through the pipe: the bytes after their length, and whether they all came.
struct Received {
  bool ok = true;  ///< false: the pipe could not be read (no guard)
  bool complete = false;
  std::string payload;
};

/// Reads until the child closes its end (it exits); throws InputError at the deadline.
Received ReceiveFramed(ReadingChild* child, const std::string& path, double timeout_s) {
  std::vector<char> chunk(1 << 20);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  std::string bytes;
  std::uint64_t length = 0;  // of the payload, once its 8 bytes are in
  bool have_length = false;
  for (;;) {
    const double left =
        std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
    if (left <= 0.0) {
      child->Stop();
      throw InputError(path + ": reading it did not finish in " +
                       std::to_string(static_cast<long long>(timeout_s)) +
                       " s (a loop inside the HDF5 library?): damaged file?");
    }
    pollfd wait_for = {child->fd, POLLIN, 0};
    const int ready = poll(&wait_for, 1, static_cast<int>(std::min(left * 1000.0 + 1.0, 1e9)));
    if (ready == 0 || (ready < 0 && errno == EINTR)) continue;
    const ssize_t got = ready < 0 ? -1 : read(child->fd, chunk.data(), chunk.size());
    if (got < 0 && (errno == EINTR || errno == EAGAIN)) continue;
    if (got < 0) return {false, false, {}};
    if (got == 0) break;  // end of file: the child is done
    bytes.append(chunk.data(), static_cast<std::size_t>(got));
    if (!have_length && bytes.size() >= sizeof(length)) {
      std::memcpy(&length, bytes.data(), sizeof(length));
      bytes.reserve(sizeof(length) + std::min<std::uint64_t>(length, std::uint64_t{1} << 36));
      have_length = true;
    }
  }
  Received out;
  out.complete = have_length && length == bytes.size() - sizeof(length);
  out.payload = std::move(bytes);
  out.payload.erase(0, std::min(out.payload.size(), sizeof(length)));
  return out;
}

/// The capture from the child's exit status and what it sent; throws InputError when the
/// read crashed or failed. Exit code 4 (sent nothing): read again here.
RigCapture FromChild(const std::string& path, int status, Received received) {
  if (WIFSIGNALED(status)) {
    throw InputError(path + ": the HDF5 library crashed reading it (" +
                     strsignal(WTERMSIG(status)) + "): damaged file?");
  }
  const int code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  if (code == 4) return ReadCapture(path);  // the child read the file but could not send it
  const std::string& payload = received.payload;
  if (code == 0) {
    try {
      if (received.complete) return DecodeCapture(std::move(received.payload));
    } catch (const std::runtime_error&) {
    }
    throw InputError(path + ": reading it failed (the capture came back incomplete)");
  }
  if (code == 2 && !payload.empty()) throw InputError(payload);
  throw InputError(path + ": reading it failed" +
                   (payload.empty() || code != 3 ? " (exit code " + std::to_string(code) + ")"
                                                 : ": " + payload) +
                   ": damaged file?");
}

}  // namespace

RigCapture ReadCaptureGuarded(const std::string& path, double timeout_s) {
  if (std::isnan(timeout_s)) throw std::invalid_argument("ReadCaptureGuarded: timeout is NaN");
  timeout_s = std::clamp(timeout_s, 0.0, 1e9);  // 1e9 s: no deadline
  int channel[2];
  // Close-on-exec: a process another thread starts must not hold the write end open.
  if (pipe2(channel, O_CLOEXEC) != 0) return ReadCapture(path);  // no pipe, no guard
  // A wider pipe than the 64 KiB default: fewer switches between writer and reader.
  fcntl(channel[1], F_SETPIPE_SZ, 1 << 20);
  const pid_t pid = fork();
  if (pid < 0) {
    close(channel[0]);
    close(channel[1]);
    return ReadCapture(path);
  }
  if (pid == 0) {
    close(channel[0]);
    ReadInChild(path, channel[1]);
  }
  close(channel[1]);
  ReadingChild child(pid, channel[0]);
  Received received = ReceiveFramed(&child, path, timeout_s);
  if (!received.ok) {  // cannot wait for the child: no guard, read as usual
    child.Stop();
    return ReadCapture(path);
  }
  child.ClosePipe();
  int status = 0;
  const pid_t done = Reap(pid, &status);
  child.pid = -1;
  if (done != pid) return ReadCapture(path);  // the child was reaped elsewhere: no verdict
  return FromChild(path, status, std::move(received));
}

}  // namespace rigfit

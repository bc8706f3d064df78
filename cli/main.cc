// rigfit command line: one subcommand per job. Exit codes (docs/usage.md):
//   0 done; 1 internal error; 2 bad input or usage (nothing written);
//   3 ran, but the refinement was not applied (output written, success false).
#include <malloc.h>

#include <CLI/CLI.hpp>
#include <exception>
#include <iostream>

#include "cli/commands.h"
#include "core/errors.h"

namespace {

/// Large buffers (merged clouds, per-point covariance scores, kd-trees) are allocated and freed
/// in every round of a refinement. By default glibc maps each from the kernel and returns it
/// on free, so every round pays the page faults of zeroed fresh memory again (a third of
/// `rigfit refine`'s CPU time in system time on a 4-camera rig). Taken from the heap and kept
/// there up to 256 MB free: `rigfit refine` of 4 cameras 640x360 1.91 -> 1.55 s, 8 cameras
/// 5.2-5.8 -> 4.4-5.1 s, peak memory +3-16 %; `rigfit slam` unchanged (docs/benchmarks.md).
void KeepFreedMemoryInTheHeap() {
  mallopt(M_MMAP_MAX, 0);
  mallopt(M_TRIM_THRESHOLD, 256 << 20);
}

}  // namespace

int main(int argc, char** argv) {
  KeepFreedMemoryInTheHeap();
  CLI::App app{
      "rigfit: refines the extrinsics of a rig of fixed depth cameras, and tracks moving RGB-D "
      "cameras"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "rigfit 0.1.0");
  rigfit::cli::RegisterCommands(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : rigfit::cli::kExitBadInput;
  }
  try {
    return rigfit::cli::RunSelected(app);
  } catch (const rigfit::InputError& e) {
    std::cerr << "rigfit: error: " << e.what() << "\n";
    return rigfit::cli::kExitBadInput;
  } catch (const std::exception& e) {
    std::cerr << "rigfit: internal error: " << e.what() << "\n";
    return rigfit::cli::kExitInternal;
  }
}

// The subcommands of the rigfit executable. Each lives in its own <name>_command.cc and
// registers itself here; main.cc only parses and maps errors to exit codes.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <vector>

namespace rigfit::cli {

inline constexpr int kExitOk = 0;
inline constexpr int kExitInternal = 1;
inline constexpr int kExitBadInput = 2;
inline constexpr int kExitNotApplied = 3;

/// A registered subcommand: its CLI11 app and what runs when it is chosen.
struct Command {
  CLI::App* app = nullptr;
  std::function<int()> run;
};

/// `rigfit simulate`: writes an example rig (capture, true and perturbed extrinsics).
Command AddSimulateCommand(CLI::App& app);
/// `rigfit simulate-sequence`: a synthetic RGB-D sequence with ground truth (TUM layout).
Command AddSimulateSequenceCommand(CLI::App& app);
/// `rigfit refine`: capture + initial extrinsics -> refined extrinsics (docs/usage.md).
Command AddRefineCommand(CLI::App& app);
/// `rigfit evaluate`: gauge-free errors of estimated extrinsics against ground truth.
Command AddEvaluateCommand(CLI::App& app);
/// `rigfit evaluate-trajectory`: ATE and RPE of a camera trajectory against ground truth.
Command AddEvaluateTrajectoryCommand(CLI::App& app);
/// `rigfit track`: frame-to-frame dense RGB-D odometry over a sequence (docs/rgbd.md).
Command AddTrackCommand(CLI::App& app);

/// `rigfit import-ply`: a rig capture (points layout) from one PLY cloud per camera.
Command AddImportPlyCommand(CLI::App& app);

/// `rigfit compare`: the pairwise and the joint mode side by side on one capture.
Command AddCompareCommand(CLI::App& app);
/// `rigfit export-ply`: every camera's points in the world, coloured per camera (PLY).
Command AddExportPlyCommand(CLI::App& app);

/// `rigfit fuse`: every depth camera of a capture fused into one surfel map (PLY).
Command AddFuseCommand(CLI::App& app);
/// `rigfit slam`: frame-to-model dense RGB-D SLAM over a sequence (docs/rgbd.md).
Command AddSlamCommand(CLI::App& app);

/// Adds every subcommand to app.
void RegisterCommands(CLI::App& app);
/// Runs the subcommand that was parsed; returns its exit code. A SettingError of its checks
/// becomes an InputError "<subcommand>: <message>", the settings spelled as flags.
int RunSelected(const CLI::App& app);

}  // namespace rigfit::cli

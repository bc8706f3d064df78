// `rigfit slam SEQUENCE --out traj.txt [--map map.ply] [--report DIR]`: frame-to-model dense
// RGB-D SLAM (rgbd/slam.h): each frame tracked against the surfel map rendered at its predicted
// pose, then fused into it; the trajectory in the TUM format, the map as a PLY with normals (and
// colours when the sequence has registered colour) and as a picture from above
// (report/map_view.h).
#include <algorithm>
#include <cstdio>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/map_ply.h"
#include "cli/rgbd_common.h"
#include "core/format.h"
#include "core/setting_error.h"
#include "io/atomic_file.h"
#include "io/rgbd_sequence.h"
#include "io/trajectory_tum.h"
#include "report/map_view.h"
#include "report/palette.h"
#include "report/refine_report.h"
#include "report/trajectory_report.h"
#include "rgbd/loop_closure.h"
#include "rgbd/slam.h"
#include "rgbd/slam_options.h"
#include "rgbd/tracking_options.h"

namespace rigfit::cli {
namespace {

struct SlamArgs : TrackingArgs {
  std::string halve = "auto";  ///< auto or a count
  std::string map_path;
  std::string report_dir;  ///< empty: no report
  bool force = false;
  SlamOptions slam;
};
/// The report's overlays: the sequence's ground truth over the run's time span (when it has
/// one), then the estimated trajectory.
std::vector<MapOverlay> TrajectoryOverlays(const RgbdSequence& sequence,
                                           const Trajectory& estimate) {
  constexpr double kMaxDt = 0.02;  // s, as --evaluate matches poses
  std::vector<MapOverlay> overlays;
  const Trajectory gt = sequence.GroundTruth();
  MapOverlay truth{"ground truth", kGroundTruthColor, kGroundTruthWidth, {}, false};
  for (size_t i = 0; i < gt.poses.size() && !estimate.timestamps.empty(); ++i) {
    if (gt.timestamps[i] >= estimate.timestamps.front() - kMaxDt &&
        gt.timestamps[i] <= estimate.timestamps.back() + kMaxDt) {
      truth.poses.push_back(gt.poses[i]);
    }
  }
  if (!truth.poses.empty()) overlays.push_back(std::move(truth));
  overlays.push_back({"estimate", CameraColor(0), kEstimateWidth, estimate.poses, false});
  return overlays;
}

/// --halve: unset for auto, else the count (CheckSlamSettings checks its range).
std::optional<int> HalvingsOf(const std::string& text) {
  if (text == "auto") return std::nullopt;
  std::size_t used = 0;
  int count = 0;
  try {
    count = std::stoi(text, &used);
  } catch (const std::logic_error&) {
    used = 0;
  }
  if (used == 0 || used != text.size()) {
    throw SettingError("halve", "must be auto or a whole number, not \"" + text + "\"");
  }
  return count;
}

int RunSlamCommand(SlamArgs a) {
  if (!a.map_path.empty()) {
    CheckOutputFile(a.map_path, {a.sequence_path, a.out_path}, a.force, "slam: --map");
  }
  if (!a.report_dir.empty()) CheckReportDirectory(a.report_dir, "slam: --report");
  ApplyTrackingArgs(&a, &a.slam);
  a.slam.halvings = HalvingsOf(a.halve);
  CheckSlamSettings(a.slam);

  const Log log = TrackingLog("slam: ", a);
  const std::unique_ptr<RgbdSequence> sequence =
      OpenSequenceLogged(a.sequence_path, a.sequence, log);
  int last_percent = -1;
  const auto progress = [&](int done, int total, const SlamFrame& frame) {
    const int percent = 100 * done / total;
    if (a.quiet || (percent / 10 == last_percent / 10 && done != total)) return;
    last_percent = percent;
    std::fprintf(stderr, "slam: %d/%d frames, map %d points\n", done, total, frame.map_size);
  };
  SlamResult result = RunSlam(*sequence, a.slam, log, progress);
  const Trajectory unclosed = result.trajectory;
  std::optional<LoopClosureResult> closed;
  if (a.loop_closure) closed = CloseSlamLoops(*sequence, a.slam, &result, log);
  const int frames = static_cast<int>(result.frames.size());
  int largest = 0;
  double matched = 0.0;
  const GuardCounts counts = GuardCountsOf(result);
  for (const SlamFrame& frame : result.frames) {
    largest = std::max(largest, frame.map_size);
    matched += frame.track.matched_ratio;
  }
  std::vector<std::string> metadata = GuardMetadata("slam", counts);
  if (closed) metadata.push_back(LoopClosureMetadata(*closed));
  WriteTumTrajectory(a.out_path, result.trajectory, metadata);
  if (!a.map_path.empty()) WritePly(a.map_path, SurfelMapToPly(result.map));

  std::string summary;
  const std::string halved = result.halvings == 0 ? ""
                             : result.halvings == 1
                                 ? ", halved once"
                                 : ", halved " + std::to_string(result.halvings) + " times";
  Appendf(&summary, "tracked and fused %d frames (%d failed, %d restarts%s%s) -> %s\n", frames,
          result.failures, result.restarts, halved.c_str(),
          result.without_color > 0
              ? (", " + std::to_string(result.without_color) + " without colour not fused").c_str()
              : "",
          a.out_path.c_str());
  Appendf(&summary, "map %d points (largest %d, compression %.2f%s)%s%s\n", result.map.size(),
          largest, result.map.CompressionRatio(), result.map.has_color() ? ", with colours" : "",
          a.map_path.empty() ? "" : " -> ", a.map_path.c_str());
  const double mean_matched = frames > 1 ? matched / (frames - 1) : 0.0;
  if (frames > 1) WarnLowMatchedShare(mean_matched, a.slam, log);
  Appendf(&summary,
          "mean matched share %.2f; time (s): waiting for frames %.2f, rendering %.2f, tracking "
          "%.2f, fusion %.2f, all %.2f (%.1f frames/s with loading, %.1f without); "
          "preprocessing %.2f while the frame before was tracked\n",
          mean_matched, result.load_s, result.render_s, result.track_s, result.fuse_s,
          result.loop_s, FramesPerSecond(frames, result.loop_s),
          FramesPerSecond(frames, result.loop_s - result.load_s), result.preprocess_s);
  summary += ColorTrackingSummaryText(a.slam, result, frames);
  summary += GuardSummaryText(counts, log);
  if (closed) summary += LoopClosureSummaryText(*closed);
  if (a.evaluate && closed && closed->applied) {
    summary += UnclosedEvaluationText(*sequence, unclosed, log);
  }
  if (a.evaluate) summary += TrajectoryEvaluationText(*sequence, result.trajectory, log);
  std::fputs(summary.c_str(), stdout);
  if (!a.report_dir.empty()) {
    const SurfelMap& map = result.map;
    const MapPoints points{map.positions(), map.normals(), map.colors(), map.radii()};
    for (const std::string& file : WriteMapReport(
             a.report_dir, "rigfit slam report", points,
             TrajectoryOverlays(*sequence, result.trajectory),
             EstimateMapViewAxes(map.positions(), map.normals(), result.trajectory.poses),
             summary)) {
      std::printf("report: %s\n", file.c_str());
    }
  }
  return kExitOk;
}

}  // namespace

Command AddSlamCommand(CLI::App& app) {
  auto args = std::make_shared<SlamArgs>();
  SlamArgs& a = *args;
  CLI::App* sub = app.add_subcommand(
      "slam",
      "Frame-to-model dense RGB-D SLAM: each depth frame of SEQUENCE (a TUM RGB-D or ICL-NUIM "
      "folder, a 7-Scenes folder, or a rig capture's burst) is tracked by projective "
      "point-to-plane ICP against the surfel map rendered at its predicted pose, then fused "
      "into the map (docs/rgbd.md); the trajectory is written in the TUM format, the map as a "
      "PLY with normals (and colours) and, with --report, as a picture from above. Exit codes: 0 "
      "done (failed frames are warned and "
      "counted); 2 bad input or usage (nothing written).");
  AddSequenceArguments(sub, &a);
  sub->add_option("--map", a.map_path,
                  "Surfel map to write (PLY with normals and colours); its directory must "
                  "exist, and it must not be an input file");
  sub->add_flag("--force", a.force, "Replace --map if it exists");
  sub->add_option("--report", a.report_dir,
                  "Also write the map seen from above with the trajectory (map_top.png) and a "
                  "page showing it with the summary (index.html), and an interactive 3-D view of "
                  "the map and trajectories (view3d.html, opens offline) into this directory "
                  "(created; its parent must exist)");
  AddFrameSelectionFlags(sub, &a, &a.slam);
  sub->add_option("--halve", a.halve,
                  "Halve the frames' resolution this many times first (depth averaged over 2x2 "
                  "blocks without crossing a depth jump); auto: until they are at most 480 "
                  "pixels wide (640x480 runs at 320x240)")
      ->capture_default_str();
  AddFrameStartFlags(sub, &a);
  AddDepthAndPairFlags(sub, &a.slam);
  sub->add_option("--fuse-distance", a.slam.fusion.max_distance_m,
                  "Fusion: merge a pixel into a map point only within this distance (metres)")
      ->capture_default_str();
  sub->add_option("--fuse-angle", a.slam.fusion.max_normal_angle_deg,
                  "Fusion: ... and when their normals are within this angle (degrees)")
      ->capture_default_str();
  sub->add_option("--dormant-frames", a.slam.fusion.dormant_frames,
                  "Remove points unseen for this many frames whose weight is below "
                  "--min-stable-weight (0 = keep every point)")
      ->capture_default_str();
  sub->add_option("--cover-radius", a.slam.fusion.cover_radius_scale,
                  "Do not add a pixel that lies on the disc (radius x this) of a point a "
                  "neighbouring pixel merged into (0 = add every unmerged pixel)")
      ->capture_default_str();
  sub->add_flag("--fold,!--no-fold", a.slam.fusion.fold_overlapping,
                "Fold map points that overlap the point their pixel merged into (off by default)");
  sub->add_option("--min-stable-weight", a.slam.fusion.min_stable_weight,
                  "Weight from which a point is never removed as dormant")
      ->capture_default_str();
  sub->add_option("--model-weight", a.slam.render.min_weight,
                  "Render only map points of at least this weight as the model (1 = all)")
      ->capture_default_str();
  sub->add_option("--model-recent", a.slam.render.recent_frames,
                  "... and also those seen in the last N frames")
      ->capture_default_str();
  sub->add_flag(
      "--splat,!--no-splat", a.slam.render.splat,
      "Render each map point over its surfel disc, or on its nearest pixel only (default)");
  sub->add_flag("--color,!--no-color", a.slam.color,
                "Fuse the sequence's registered colour when it has one (default)");
  AddRunFlags(sub, &a, &a.slam);
  return {sub, [args] { return RunSlamCommand(*args); }};
}

}  // namespace rigfit::cli

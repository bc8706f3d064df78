#include "report/refine_report.h"

#include <cmath>
#include <filesystem>

#include "core/errors.h"
#include "core/format.h"
#include "core/geometry.h"
#include "io/png.h"
#include "report/html.h"
#include "report/palette.h"
#include "report/plots.h"
#include "report/view3d_scenes.h"
#include "rig/diagnostics.h"

namespace rigfit {
namespace {

namespace fs = std::filesystem;

/// Histogram bins over [-d, d], d the finest correspondence distance.
constexpr int kResidualBins = 56;

std::vector<TopDownCamera> TopDownCameras(const DiagnosticRig& rig, const PoseMap& poses) {
  std::vector<TopDownCamera> cameras;
  for (size_t i = 0; i < rig.serials.size(); ++i) {
    const Pose& T_world_camera = poses.at(rig.serials[i]);
    cameras.push_back({rig.serials[i], CameraColor(static_cast<int>(i)),
                       Transform(T_world_camera, rig.bands[i].levels.front().points),
                       T_world_camera});
  }
  return cameras;
}

/// The poses of the capture's cameras, in capture order.
std::vector<Pose> CapturePoses(const RigCapture& capture, const PoseMap& poses) {
  std::vector<Pose> out;
  for (const CameraCapture& camera : capture.cameras) out.push_back(poses.at(camera.serial));
  return out;
}

/// Every residual of every pair, in millimetres, with a legend text.
HistogramSeries Residuals(const std::vector<PairDiagnostics>& pairs, const std::string& label,
                          const Rgb& color) {
  HistogramSeries series{label, color, {}};
  double sum_squares = 0.0;
  for (const PairDiagnostics& pair : pairs) {
    for (double r : pair.residuals_m) {
      series.values.push_back(r * 1e3);
      sum_squares += r * r * 1e6;
    }
  }
  const size_t n = series.values.size();
  series.label += "\n" + std::to_string(n) + " correspondences";
  series.label += "\nRMS " + (n > 0 ? Fixed(std::sqrt(sum_squares / n), 2) : "-") + " mm";
  return series;
}

}  // namespace

void CheckReportDirectory(const std::string& dir, const std::string& what) {
  const fs::path path(dir);
  std::error_code ec;
  if (fs::exists(path, ec)) {
    if (!fs::is_directory(path, ec)) throw InputError(what + " " + dir + " is not a directory");
    return;
  }
  const fs::path parent = path.has_parent_path() ? path.parent_path() : fs::path(".");
  if (!fs::is_directory(parent, ec)) {
    throw InputError(what + " " + dir + ": directory " + parent.string() + " does not exist");
  }
}

void CreateReportDirectory(const std::string& dir) {
  CheckReportDirectory(dir, "report:");
  std::error_code ec;
  fs::create_directory(dir, ec);
  if (ec) throw InputError("report: cannot create directory " + dir + ": " + ec.message());
}

std::vector<std::string> WriteRefineReport(const std::string& dir, const RigCapture& capture,
                                           const RefineResult& result, const PoseMap& after,
                                           const RefineOptions& options,
                                           const std::string& summary) {
  CreateReportDirectory(dir);
  const int num_threads = options.threads;

  const DiagnosticRig rig = PrepareDiagnostics(capture, result, options, num_threads);
  const double voxel_m = options.icp.scales.back() * options.icp.voxel_size;
  const std::string subtitle =
      std::to_string(rig.serials.size()) + " cameras, near-floor band (y from " +
      Fixed(-options.region.band_below, 2) + " to " + Fixed(options.region.band_height, 2) +
      " m) at " + Fixed(voxel_m * 100.0, 1) + " cm voxels, seen from above; +Y toward you";
  const std::vector<TopDownCamera> before_view = TopDownCameras(rig, result.leveled);
  const std::vector<TopDownCamera> after_view = TopDownCameras(rig, after);
  const GroundWindow window = FitGroundWindow({&before_view, &after_view});
  ReportDirectory report(dir);
  const std::string before_title = "Before registration (leveled poses)";
  report.AddPicture(kTopDownBeforeFile,
                    DrawTopDown(before_view, window, voxel_m, before_title, subtitle),
                    before_title + ": " + subtitle);
  const std::string after_title = "After registration";
  report.AddPicture(kTopDownAfterFile,
                    DrawTopDown(after_view, window, voxel_m, after_title, subtitle),
                    after_title + ": " + subtitle);

  const double half_range_mm = options.icp.max_correspondence_distance_factor * voxel_m * 1e3;
  const std::vector<HistogramSeries> series = {
      Residuals(Diagnose(rig, result.leveled, options.icp, num_threads), "before registration",
                Rgb{150, 150, 150}),
      Residuals(Diagnose(rig, after, options.icp, num_threads), "after registration",
                CameraColor(0))};
  const std::string residuals_title =
      "Correspondence residuals, all " + std::to_string(rig.pairs.size()) + " camera pairs";
  report.AddPicture(
      kResidualsFile,
      DrawHistogram(series, half_range_mm, 2.0 * half_range_mm / kResidualBins, residuals_title,
                    "point-to-plane residual at the finest scale (mm)", "correspondences"),
      residuals_title + ", before and after registration");
  View3dScene scene = RigView3dScene(capture, rig, {{"before", &result.leveled}, {"after", &after}},
                                     options.icp, num_threads);
  scene.title = "rigfit refine report";
  // The surface bundle's planes (kept with icp.keep_surface_diagnostics), where its pixels lie
  // at the refined poses.
  scene.planes = SurfacePlanes(result.surface, CapturePoses(capture, result.refined));
  report.AddView3d(scene);
  return report.Finish(scene.title, summary);
}

std::vector<std::string> WriteCompareReport(const std::string& dir, const RigCapture& capture,
                                            const CompareResult& result,
                                            const RefineOptions& options,
                                            const std::string& summary) {
  CreateReportDirectory(dir);
  RefineOptions leveling_only = options;
  leveling_only.run_registration = false;
  const RefineResult leveling = Refine(capture, result.initial, leveling_only);
  const int num_threads = options.threads;
  const DiagnosticRig rig = PrepareDiagnostics(capture, leveling, options, num_threads);
  std::vector<NamedPoses> pose_sets = {{"initial", &result.initial},
                                       {"before (leveled)", &result.leveled}};
  for (const CompareRun& run : result.runs) pose_sets.push_back({run.name, &run.output});
  View3dScene scene = RigView3dScene(capture, rig, pose_sets, options.icp, num_threads);
  scene.title = "rigfit compare report";
  for (const CompareRun& run : result.runs) {  // the surface_bundle run's planes, when kept
    if (run.success && run.surface.ran) {
      scene.planes = SurfacePlanes(run.surface, CapturePoses(capture, run.output));
    }
  }
  ReportDirectory report(dir);
  report.AddView3d(scene);
  return report.Finish(scene.title, summary);
}

}  // namespace rigfit

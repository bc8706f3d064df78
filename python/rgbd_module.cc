// The RGB-D half of rigfit._rigfit (docs/python.md): sequences read by io/rgbd_sequence.h,
// frame-to-frame tracking (rgbd/odometry.h, as `rigfit track`), frame-to-model SLAM
// (rgbd/slam.h, as `rigfit slam`), TUM trajectories and their errors (core/trajectory.h, as
// `rigfit evaluate-trajectory`). rigfit/__init__.py wraps the plain values in typed objects.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "core/errors.h"
#include "core/rgbd.h"
#include "core/trajectory.h"
#include "io/capture_h5.h"
#include "io/rgbd_sequence.h"
#include "io/trajectory_tum.h"
#include "python/convert.h"
#include "rgbd/odometry.h"
#include "rgbd/slam.h"
#include "rgbd/slam_options.h"
#include "rgbd/surfel_map.h"
#include "rgbd/tracking_options.h"

namespace rigfit::python {
namespace {

/// A sequence opened from files (OpenRgbdSequence), as rigfit.Sequence holds it.
class FileSequence {
 public:
  explicit FileSequence(std::unique_ptr<RgbdSequence> sequence) : sequence_(std::move(sequence)) {}
  const RgbdSequence& get() const { return *sequence_; }

 private:
  std::unique_ptr<RgbdSequence> sequence_;
};

/// A frame as a dict: {"index", "timestamp", "source", "depth" (H, W) float32 (the frame's own
/// buffer, no copy), "K", "color" (H, W, 3) uint8 or None, "T_world_camera" (4, 4) or None}.
py::dict FrameToDict(RgbdFrame&& frame) {
  py::dict d;
  d["index"] = frame.index;
  d["timestamp"] = frame.timestamp;
  d["source"] = frame.source;
  const py::ssize_t h = frame.height;
  const py::ssize_t w = frame.width;
  d["depth"] = VectorToNumpy(std::move(frame.depth_m), {h, w});
  d["K"] = IntrinsicsToK(frame.intrinsics);
  d["color"] = frame.color.empty() ? py::object(py::none())
                                   : py::object(VectorToNumpy(std::move(frame.color), {h, w, 3}));
  d["T_world_camera"] = frame.T_world_camera_gt
                            ? py::object(MatrixToNumpy(frame.T_world_camera_gt->matrix()))
                            : py::object(py::none());
  return d;
}

/// (timestamps (N,), poses (N, 4, 4)).
py::tuple TrajectoryToTuple(const Trajectory& trajectory) {
  std::vector<double> timestamps = trajectory.timestamps;
  const auto n = static_cast<py::ssize_t>(timestamps.size());
  return py::make_tuple(VectorToNumpy(std::move(timestamps), {n}), PosesToNumpy(trajectory.poses));
}

/// A trajectory from Python: timestamps (N,) finite and increasing, poses (N, 4, 4) each
/// checked as an extrinsics pose (PoseOf). `name` names it in messages.
Trajectory TrajectoryOf(const py::handle& timestamps, const py::handle& poses,
                        const std::string& name) {
  const DoubleArray t = DoubleArray::ensure(timestamps);
  if (!t || t.ndim() != 1) {
    Fail(name + ": timestamps",
         "expected a 1-D array (N,)" + (t ? ", got " + Shape(t) : std::string()));
  }
  const DoubleArray p = DoubleArray::ensure(poses);
  if (!p || p.ndim() != 3 || p.shape(0) != t.shape(0) || p.shape(1) != 4 || p.shape(2) != 4) {
    Fail(name + ": poses", "expected shape (" + std::to_string(t.shape(0)) + ", 4, 4), got " +
                               (p ? Shape(p) : std::string("no array")));
  }
  Trajectory out;
  const auto tt = t.unchecked<1>();
  const double* matrices = p.data();
  for (py::ssize_t i = 0; i < t.shape(0); ++i) {
    const double time = tt(i);
    if (!std::isfinite(time)) Fail(name + ": timestamps", "entries must be finite");
    if (i > 0 && !(time > out.timestamps.back())) {
      Fail(name + ": timestamps", "must increase (entry " + std::to_string(i) + ")");
    }
    out.timestamps.push_back(time);
    out.poses.push_back(CheckedPose(
        Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(matrices + 16 * i),
        name + ": poses[" + std::to_string(i) + "]"));
  }
  return out;
}

/// Frames handed in from Python as dicts ({"depth", "K", ["depth_scale", "timestamp",
/// "T_world_camera"]}), checked when the sequence is made; Frame() reads a frame's depth (one
/// copy, DepthView) without touching Python, so that tracking runs without the GIL. Timestamps
/// are the dicts' (every frame or none; increasing) or index / kUnstampedFrameRateHz.
class ArraySequence : public RgbdSequence {
 public:
  explicit ArraySequence(const py::sequence& frames) {
    static const std::set<std::string> kKeys = {"depth", "K", "depth_scale", "timestamp",
                                                "T_world_camera"};
    if (py::len(frames) == 0) throw InputError("frames: no frames");
    int stamped = 0;
    for (size_t i = 0; i < py::len(frames); ++i) {
      const std::string where = "frames[" + std::to_string(i) + "]";
      const py::handle item = frames[i];
      if (!py::isinstance<py::dict>(item)) Fail(where, "expected a dict or a rigfit.Frame");
      const auto d = py::reinterpret_borrow<py::dict>(item);
      for (const auto& entry : d) {
        const std::string key = py::cast<std::string>(py::str(entry.first));
        if (kKeys.count(key) == 0) {
          Fail(where, "unknown key \"" + key +
                          "\" (expected depth, K, depth_scale, timestamp, T_world_camera)");
        }
      }
      if (!d.contains("depth")) Fail(where, "a frame needs \"depth\"");
      if (!d.contains("K")) Fail(where, "a frame needs \"K\" (3x3 intrinsics)");
      Entry entry{DepthView(d, where), {}, 0.0, std::nullopt};
      // The data contract of a capture's K (CheckDepthCamera; no depth: only K is checked).
      CameraCapture camera;
      camera.width = entry.depth.width();
      camera.height = entry.depth.height();
      const DoubleArray K = Matrix(d["K"], 3, 3, where + ": K");
      CheckDepthCamera(
          &camera, Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(K.data()), where);
      entry.intrinsics = camera.intrinsics;
      if (d.contains("timestamp") && !d["timestamp"].is_none()) {
        entry.timestamp = py::cast<double>(d["timestamp"]);
        if (!std::isfinite(entry.timestamp)) Fail(where + ": timestamp", "must be finite");
        if (stamped > 0 && !(entry.timestamp > entries_.back().timestamp)) {
          Fail(where + ": timestamp", "must increase from frame to frame");
        }
        ++stamped;
      } else {
        entry.timestamp = static_cast<double>(i) / kUnstampedFrameRateHz;
      }
      if (d.contains("T_world_camera") && !d["T_world_camera"].is_none()) {
        entry.T_world_camera = PoseOf(d["T_world_camera"], where + ": T_world_camera");
      }
      entries_.push_back(std::move(entry));
    }
    if (stamped != 0 && stamped != static_cast<int>(entries_.size())) {
      throw InputError("frames: " + std::to_string(stamped) + " of " +
                       std::to_string(entries_.size()) +
                       " frames have a timestamp: give every frame one, or none");
    }
  }

  int size() const override { return static_cast<int>(entries_.size()); }

  RgbdFrame Frame(int index) const override {
    const Entry& e = entries_.at(static_cast<size_t>(index));
    RgbdFrame frame;
    frame.index = index;
    frame.timestamp = e.timestamp;
    frame.source = "frames[" + std::to_string(index) + "]";
    frame.width = e.depth.width();
    frame.height = e.depth.height();
    frame.intrinsics = e.intrinsics;
    frame.depth_m = e.depth.Read();
    frame.T_world_camera_gt = e.T_world_camera;
    return frame;
  }

  Trajectory GroundTruth() const override {
    Trajectory gt;
    for (const Entry& e : entries_) {
      if (!e.T_world_camera) continue;
      gt.timestamps.push_back(e.timestamp);
      gt.poses.push_back(*e.T_world_camera);
    }
    return gt;
  }

  std::string Describe() const override {
    return "frames from Python arrays: " + std::to_string(entries_.size()) + " frames";
  }

 private:
  struct Entry {
    DepthView depth;
    PinholeIntrinsics intrinsics;
    double timestamp;
    std::optional<Pose> T_world_camera;
  };
  std::vector<Entry> entries_;
};

FileSequence OpenSequence(const std::string& path, const std::string& camera,
                          const std::string& tum_camera, const std::vector<double>& intrinsics,
                          const std::optional<double>& depth_scale, double max_time_difference_s,
                          int stride, int max_frames, const py::object& logger) {
  SequenceOptions options;
  options.serial = camera;
  options.tum_camera = tum_camera;
  SetSequenceIntrinsics(intrinsics, "open_sequence", OptionSpelling::kKeyword, &options);
  options.depth_scale = depth_scale;
  options.max_time_difference_s = max_time_difference_s;
  options.stride = stride;
  options.max_frames = max_frames;
  std::vector<std::string> warnings;
  std::unique_ptr<RgbdSequence> sequence;
  {
    py::gil_scoped_release release;
    sequence = OpenRgbdSequence(path, options, &warnings);
  }
  const Log log = PythonLog(logger);
  for (const std::string& w : warnings) log.Warning(w);
  return FileSequence(std::move(sequence));
}

py::dict SequenceFrame(const FileSequence& sequence, int index) {
  const int n = sequence.get().size();
  if (index < 0) index += n;
  if (index < 0 || index >= n) throw py::index_error("frame index out of range");
  RgbdFrame frame;
  {
    py::gil_scoped_release release;
    frame = sequence.get().Frame(index);
  }
  return FrameToDict(std::move(frame));
}

py::object SequenceGroundTruth(const FileSequence& sequence) {
  const Trajectory gt = sequence.get().GroundTruth();
  if (gt.poses.empty()) return py::none();
  return TrajectoryToTuple(gt);
}

/// The defaults of SequenceOptions that rigfit.open_sequence takes as keywords.
py::dict SequenceDefaults() {
  const SequenceOptions o;
  py::dict d;
  d["max_time_difference_s"] = o.max_time_difference_s;
  d["stride"] = o.stride;
  d["max_frames"] = o.max_frames;
  return d;
}

/// The frames `source` holds: a rigfit.Sequence's, or a list of frames read into *arrays.
const RgbdSequence& SequenceOf(const py::object& source, const std::string& command,
                               std::unique_ptr<ArraySequence>* arrays) {
  if (py::isinstance<FileSequence>(source)) return source.cast<const FileSequence&>().get();
  if (py::isinstance<py::sequence>(source) && !py::isinstance<py::str>(source)) {
    *arrays = std::make_unique<ArraySequence>(source.cast<py::sequence>());
    return **arrays;
  }
  throw InputError(command + ": expected a rigfit.Sequence or a list of frames, got " +
                   std::string(py::str(py::type::of(source).attr("__name__"))));
}

/// True when `done` of `total` frames is worth a progress line, as the CLI prints them: every
/// tenth of the way, and at the end.
bool IsProgressStep(int done, int total, int* last_percent) {
  const int percent = 100 * done / total;
  if (percent / 10 == *last_percent / 10 && done != total) return false;
  *last_percent = percent;
  return true;
}

/// A frame's index, timestamp and tracking outcome as rigfit.track and rigfit.slam report
/// them (TrackedFrame, SlamFrame); the callers add their own fields.
py::dict TrackedFrameDict(int index, double timestamp, const TrackResult& track) {
  py::dict d;
  d["index"] = index;
  d["timestamp"] = timestamp;
  d["success"] = track.success;
  d["message"] = track.message;
  d["iterations"] = track.iterations;
  d["correspondences"] = track.correspondences;
  d["matched_ratio"] = track.matched_ratio;
  d["rmse_m"] = track.rmse_m;
  d["weak_directions"] = track.weak_directions;
  py::list weak;
  for (const Vec6& direction : track.weak) weak.append(WeakDirectionName(direction));
  d["weak_direction_names"] = weak;
  return d;
}

/// The defaults of `rigfit track`'s flags, from the library's option structs: rigfit.track's
/// keyword defaults.
py::dict TrackDefaults() {
  const OdometryOptions o;
  py::dict d;
  d["first"] = o.first_frame;
  d["max_frames"] = o.max_frames;
  d["stride"] = o.stride;
  d["iterations"] = o.icp.iterations;
  d["prior"] = MotionPriorName(o.prior);
  d["keyframes"] = o.keyframes;
  d["min_depth"] = o.frame.min_depth_m;
  d["max_depth"] = o.frame.max_depth_m;
  d["bilateral"] = o.frame.bilateral;
  d["max_distance"] = o.icp.association.max_distance_m;
  d["max_angle"] = o.icp.association.max_normal_angle_deg;
  d["depth_weights"] = o.icp.weighting.depth_noise;
  d["huber"] = o.icp.weighting.huber_delta_m;
  d["min_step"] = o.icp.converged_translation_m;
  d["guard"] = o.guard.enabled;
  d["weak_ratio"] = o.icp.weak_direction_ratio;
  d["threads"] = o.threads;
  return d;
}

py::dict Track(const py::object& source, int first, int max_frames, int stride,
               const std::vector<int>& iterations, const std::string& prior, bool keyframes,
               double min_depth, double max_depth, bool bilateral, double max_distance,
               double max_angle, bool depth_weights, double huber, double min_step, bool guard,
               double weak_ratio, int threads, const py::object& logger) {
  OdometryOptions options;
  options.first_frame = first;
  options.max_frames = max_frames;
  options.stride = stride;
  options.keyframes = keyframes;
  options.frame.min_depth_m = min_depth;
  options.frame.max_depth_m = max_depth;
  options.frame.bilateral = bilateral;
  options.icp.association.max_distance_m = max_distance;
  options.icp.association.max_normal_angle_deg = max_angle;
  options.icp.weighting.depth_noise = depth_weights;
  options.icp.weighting.huber_delta_m = huber;
  options.threads = threads;
  ApplyTrackingSettings("track", OptionSpelling::kKeyword, prior, iterations, threads, max_frames,
                        &options.prior, &options.frame, &options.icp);
  ApplyMinStep("track", OptionSpelling::kKeyword, min_step, &options.icp);
  ApplyWeakRatio("track", OptionSpelling::kKeyword, weak_ratio, &options.icp);
  options.guard.enabled = guard;

  std::unique_ptr<ArraySequence> arrays;
  const RgbdSequence& sequence = SequenceOf(source, "track", &arrays);
  const Log log = PythonLog(logger);
  int last_percent = -1;
  const auto progress = [&](int done, int total) {
    if (!IsProgressStep(done, total, &last_percent)) return;
    log.Info("track: " + std::to_string(done) + "/" + std::to_string(total) + " frames");
  };
  OdometryResult result;
  {
    py::gil_scoped_release release;
    result = RunOdometry(sequence, options, log, progress);
  }
  py::list frames;
  for (size_t k = 0; k < result.frames.size(); ++k) {
    const OdometryFrame& f = result.frames[k];
    py::dict d = TrackedFrameDict(f.index, result.trajectory.timestamps[k], f.track);
    d["keyframe"] = f.keyframe;
    d["recovered"] = f.recovered;
    d["diverged"] = f.diverged;
    frames.append(d);
  }
  py::dict out;
  const py::tuple trajectory = TrajectoryToTuple(result.trajectory);
  out["timestamps"] = trajectory[0];
  out["poses"] = trajectory[1];
  out["frames"] = frames;
  out["failures"] = result.failures;
  out["restarts"] = result.restarts;
  out["recovered"] = result.recovered;
  out["diverged"] = result.diverged;
  out["weak_frames"] = result.weak_frames;
  py::dict timings;
  timings["load_s"] = result.load_s;
  timings["preprocess_s"] = result.preprocess_s;
  timings["track_s"] = result.track_s;
  out["timings"] = timings;
  return out;
}

/// The defaults of `rigfit slam`'s flags beyond open_sequence's, from the library's option
/// structs: rigfit.slam's keyword defaults.
py::dict SlamDefaults() {
  const SlamOptions o;
  py::dict d;
  d["first"] = o.first_frame;
  d["max_frames"] = o.max_frames;
  d["stride"] = o.stride;
  d["halve"] = o.halvings;
  d["iterations"] = o.icp.iterations;
  d["prior"] = MotionPriorName(o.prior);
  d["min_depth"] = o.frame.min_depth_m;
  d["max_depth"] = o.frame.max_depth_m;
  d["max_distance"] = o.icp.association.max_distance_m;
  d["max_angle"] = o.icp.association.max_normal_angle_deg;
  d["fuse_distance"] = o.fusion.max_distance_m;
  d["fuse_angle"] = o.fusion.max_normal_angle_deg;
  d["dormant_frames"] = o.fusion.dormant_frames;
  d["cover_radius"] = o.fusion.cover_radius_scale;
  d["fold"] = o.fusion.fold_overlapping;
  d["min_stable_weight"] = o.fusion.min_stable_weight;
  d["model_weight"] = o.render.min_weight;
  d["model_recent"] = o.render.recent_frames;
  d["splat"] = o.render.splat;
  d["color"] = o.color;
  d["guard"] = o.guard.enabled;
  d["weak_ratio"] = o.icp.weak_direction_ratio;
  d["threads"] = o.threads;
  return d;
}

/// The map as numpy arrays without a copy: the map is moved into a capsule that every array
/// holds as its base. {"points" (N, 3) float32 world metres, "normals" (N, 3) float32,
/// "colors" (N, 3) float32 RGB in [0, 255] or None, "confidence" (N,) float32 (the weight: 1 +
/// the merges), "radii" (N,) float32 metres, "input_points"}.
py::dict SurfelMapToDict(SurfelMap&& map) {
  static_assert(sizeof(Vec3f) == 3 * sizeof(float), "a Vec3f must be three packed floats");
  auto* owner = new SurfelMap(std::move(map));
  const py::capsule base(owner, [](void* p) { delete static_cast<SurfelMap*>(p); });
  const py::ssize_t n = owner->size();
  const auto rows = [&](const std::vector<Vec3f>& values) {
    return py::array_t<float>({n, py::ssize_t{3}}, reinterpret_cast<const float*>(values.data()),
                              base);
  };
  const auto column = [&](const std::vector<float>& values) {
    return py::array_t<float>({n}, values.data(), base);
  };
  py::dict d;
  d["points"] = rows(owner->positions());
  d["normals"] = rows(owner->normals());
  d["colors"] = owner->has_color() ? py::object(rows(owner->colors())) : py::object(py::none());
  d["confidence"] = column(owner->weights());
  d["radii"] = column(owner->radii());
  d["input_points"] = owner->input_points();
  return d;
}

py::dict Slam(const py::object& source, int first, int max_frames, int stride, int halve,
              const std::vector<int>& iterations, const std::string& prior, double min_depth,
              double max_depth, double max_distance, double max_angle, double fuse_distance,
              double fuse_angle, int dormant_frames, double cover_radius, bool fold,
              double min_stable_weight, float model_weight, int model_recent, bool splat,
              bool color, bool guard, double weak_ratio, int threads, const py::object& logger) {
  SlamOptions options;
  options.first_frame = first;
  options.max_frames = max_frames;
  options.stride = stride;
  options.halvings = halve;
  options.frame.min_depth_m = min_depth;
  options.frame.max_depth_m = max_depth;
  options.icp.association.max_distance_m = max_distance;
  options.icp.association.max_normal_angle_deg = max_angle;
  options.fusion.max_distance_m = fuse_distance;
  options.fusion.max_normal_angle_deg = fuse_angle;
  options.fusion.dormant_frames = dormant_frames;
  options.fusion.cover_radius_scale = cover_radius;
  options.fusion.fold_overlapping = fold;
  options.fusion.min_stable_weight = min_stable_weight;
  options.render.min_weight = model_weight;
  options.render.recent_frames = model_recent;
  options.render.splat = splat;
  options.color = color;
  options.threads = threads;
  ApplyTrackingSettings("slam", OptionSpelling::kKeyword, prior, iterations, threads, max_frames,
                        &options.prior, &options.frame, &options.icp);
  CheckSlamSettings("slam", OptionSpelling::kKeyword, options);
  ApplyWeakRatio("slam", OptionSpelling::kKeyword, weak_ratio, &options.icp);
  options.guard.enabled = guard;

  std::unique_ptr<ArraySequence> arrays;
  const RgbdSequence& sequence = SequenceOf(source, "slam", &arrays);
  const Log log = PythonLog(logger);
  int last_percent = -1;
  const auto progress = [&](int done, int total, const SlamFrame& frame) {
    if (!IsProgressStep(done, total, &last_percent)) return;
    log.Info("slam: " + std::to_string(done) + "/" + std::to_string(total) + " frames, map " +
             std::to_string(frame.map_size) + " points");
  };
  SlamResult result;
  {
    py::gil_scoped_release release;
    result = RunSlam(sequence, options, log, progress);
  }
  py::list frames;
  std::vector<int> map_sizes;
  for (size_t k = 0; k < result.frames.size(); ++k) {
    const SlamFrame& f = result.frames[k];
    py::dict d = TrackedFrameDict(f.index, result.trajectory.timestamps[k], f.track);
    d["model_pixels"] = f.model_pixels;
    d["input_points"] = f.fusion.input_points;
    d["merged"] = f.fusion.merged;
    d["added"] = f.fusion.added;
    d["covered"] = f.fusion.covered;
    d["folded"] = f.fusion.folded;
    d["removed"] = f.fusion.removed;
    d["map_size"] = f.map_size;
    d["recovered"] = f.recovered;
    d["diverged"] = f.diverged;
    frames.append(d);
    map_sizes.push_back(f.map_size);
  }
  py::dict out;
  const py::tuple trajectory = TrajectoryToTuple(result.trajectory);
  out["timestamps"] = trajectory[0];
  out["poses"] = trajectory[1];
  out["frames"] = frames;
  const auto n = static_cast<py::ssize_t>(map_sizes.size());
  out["map_sizes"] = VectorToNumpy(std::move(map_sizes), {n});
  out["failures"] = result.failures;
  out["restarts"] = result.restarts;
  out["recovered"] = result.recovered;
  out["diverged"] = result.diverged;
  out["weak_frames"] = result.weak_frames;
  py::dict timings;
  timings["load_s"] = result.load_s;
  timings["preprocess_s"] = result.preprocess_s;
  timings["render_s"] = result.render_s;
  timings["track_s"] = result.track_s;
  timings["fuse_s"] = result.fuse_s;
  out["timings"] = timings;
  out["map"] = SurfelMapToDict(std::move(result.map));
  return out;
}

/// The fields of TrajectoryErrors, as `rigfit evaluate-trajectory` prints them (SI units).
py::dict EvaluateTrajectoryErrors(const py::handle& est_timestamps, const py::handle& est_poses,
                                  const py::handle& gt_timestamps, const py::handle& gt_poses,
                                  double max_dt, int delta) {
  CheckTrajectoryEvaluationSettings("evaluate_trajectory", OptionSpelling::kKeyword, max_dt, delta);
  const Trajectory est = TrajectoryOf(est_timestamps, est_poses, "estimated");
  const Trajectory gt = TrajectoryOf(gt_timestamps, gt_poses, "ground_truth");
  TrajectoryErrors e;
  try {
    e = EvaluateTrajectory(est, gt, max_dt, delta);
  } catch (const std::invalid_argument& error) {
    throw InputError(std::string("evaluate_trajectory: estimated against ground_truth: ") +
                     error.what());
  }
  py::dict d;
  d["pairs"] = e.pairs;
  d["T_gt_est"] = MatrixToNumpy(e.T_gt_est.matrix());
  d["ate_rmse_m"] = e.ate_rmse_m;
  d["ate_mean_m"] = e.ate_mean_m;
  d["ate_median_m"] = e.ate_median_m;
  d["ate_max_m"] = e.ate_max_m;
  const auto n = static_cast<py::ssize_t>(e.ate_m.size());
  d["ate_m"] = VectorToNumpy(std::move(e.ate_m), {n});
  d["rpe_pairs"] = e.rpe_pairs;
  d["rpe_translation_rmse_m"] = e.rpe_translation_rmse_m;
  d["rpe_rotation_rmse_rad"] = e.rpe_rotation_rmse_rad;
  return d;
}

py::tuple LoadTrajectory(const std::string& path) {
  return TrajectoryToTuple(ReadTumTrajectory(path));
}

void SaveTrajectory(const std::string& path, const py::handle& timestamps,
                    const py::handle& poses) {
  WriteTumTrajectory(path, TrajectoryOf(timestamps, poses, path));
}

}  // namespace

void AddRgbdFunctions(py::module_& m) {
  py::class_<FileSequence>(m, "Sequence")
      .def("__len__", [](const FileSequence& s) { return s.get().size(); })
      .def("frame", &SequenceFrame, py::arg("index"))
      .def("ground_truth", &SequenceGroundTruth)
      .def("describe", [](const FileSequence& s) { return s.get().Describe(); });
  m.def("open_sequence", &OpenSequence, py::arg("path"), py::arg("camera"), py::arg("tum_camera"),
        py::arg("intrinsics"), py::arg("depth_scale"), py::arg("max_time_difference_s"),
        py::arg("stride"), py::arg("max_frames"), py::arg("logger"));
  m.def("sequence_defaults", &SequenceDefaults);
  m.def("track_defaults", &TrackDefaults);
  m.def("track", &Track, py::arg("source"), py::arg("first"), py::arg("max_frames"),
        py::arg("stride"), py::arg("iterations"), py::arg("prior"), py::arg("keyframes"),
        py::arg("min_depth"), py::arg("max_depth"), py::arg("bilateral"), py::arg("max_distance"),
        py::arg("max_angle"), py::arg("depth_weights"), py::arg("huber"), py::arg("min_step"),
        py::arg("guard"), py::arg("weak_ratio"), py::arg("threads"), py::arg("logger"));
  m.def("slam_defaults", &SlamDefaults);
  m.def("slam", &Slam, py::arg("source"), py::arg("first"), py::arg("max_frames"),
        py::arg("stride"), py::arg("halve"), py::arg("iterations"), py::arg("prior"),
        py::arg("min_depth"), py::arg("max_depth"), py::arg("max_distance"), py::arg("max_angle"),
        py::arg("fuse_distance"), py::arg("fuse_angle"), py::arg("dormant_frames"),
        py::arg("cover_radius"), py::arg("fold"), py::arg("min_stable_weight"),
        py::arg("model_weight"), py::arg("model_recent"), py::arg("splat"), py::arg("color"),
        py::arg("guard"), py::arg("weak_ratio"), py::arg("threads"), py::arg("logger"));
  m.def("evaluate_trajectory", &EvaluateTrajectoryErrors, py::arg("est_timestamps"),
        py::arg("est_poses"), py::arg("gt_timestamps"), py::arg("gt_poses"), py::arg("max_dt"),
        py::arg("delta"));
  m.def("load_trajectory", &LoadTrajectory, py::arg("path"));
  m.def("save_trajectory", &SaveTrajectory, py::arg("path"), py::arg("timestamps"),
        py::arg("poses"));
}

}  // namespace rigfit::python

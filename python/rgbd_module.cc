// The RGB-D half of rigfit._rigfit (docs/python.md): sequences read by io/rgbd_sequence.h,
// tracking against keyframes (rgbd/odometry.h, as `rigfit track`), frame-to-model SLAM
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
#include "python/keywords.h"
#include "rgbd/loop_closure.h"
#include "rgbd/motion_guard.h"
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

/// rigfit.open_sequence's keywords: `--camera`, `--tum-camera` and `--intrinsics` of `rigfit
/// track`, and the rest of SequenceOptions.
struct SequenceKeywords {
  SequenceOptions sequence;
  std::vector<double> intrinsics;  ///< fx, fy, cx, cy; empty: the format's
};

const KeywordTable<SequenceKeywords>& SequenceTable() {
  using K = SequenceKeywords;
  static const KeywordTable<K> table =
      KeywordTable<K>("open_sequence")
          .Add("camera", [](K& k) { return &k.sequence.serial; })
          .Add("tum_camera", [](K& k) { return &k.sequence.tum_camera; })
          .Add("intrinsics", [](K& k) { return &k.intrinsics; })
          .Add("depth_scale", [](K& k) { return &k.sequence.depth_scale; })
          .Add("max_time_difference_s", [](K& k) { return &k.sequence.max_time_difference_s; })
          .Add("stride", [](K& k) { return &k.sequence.stride; })
          .Add("max_frames", [](K& k) { return &k.sequence.max_frames; });
  return table;
}

FileSequence OpenSequence(const std::string& path, const py::dict& keywords,
                          const py::object& logger) {
  SequenceKeywords k = SequenceTable().Apply(keywords);
  CheckKeywords("open_sequence", [&] { SetSequenceIntrinsics(k.intrinsics, &k.sequence); });
  std::vector<std::string> warnings;
  std::unique_ptr<RgbdSequence> sequence;
  {
    py::gil_scoped_release release;
    sequence = OpenRgbdSequence(path, k.sequence, &warnings);
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

/// The timestamps (N,) and poses (N, 4, 4) of a run (OdometryResult or SlamResult), its
/// failures, restarts and what the motion guard did.
template <typename Result>
py::dict RunToDict(const Result& result) {
  const py::tuple arrays = TrajectoryToTuple(result.trajectory);
  py::dict out;
  out["timestamps"] = arrays[0];
  out["poses"] = arrays[1];
  out["failures"] = result.failures;
  out["restarts"] = result.restarts;
  out["recovered"] = result.recovered;
  out["diverged"] = result.diverged;
  out["weak_frames"] = result.weak_frames;
  out["relocalised"] = result.relocalised;
  out["color_aligned"] = result.color_aligned;
  out["color_tracked"] = result.color_tracked;
  out["color_rescued"] = result.color_rescued;
  out["color_alone"] = result.color_alone;
  return out;
}

/// rigfit.track's keywords: `rigfit track`'s flags (but the sequence's, which open_sequence
/// takes), read into the options and the settings ApplyTrackingSettings checks.
struct TrackKeywords {
  OdometryOptions odometry;
  std::vector<int> iterations = OdometryOptions{}.icp.iterations;
  std::string prior = MotionPriorName(OdometryOptions{}.prior);
  double min_step = OdometryOptions{}.icp.converged_translation_m;
  double weak_ratio = OdometryOptions{}.icp.weak_direction_ratio;
  bool loop_closure = LoopClosureOptions{}.enabled;
  std::string color_tracking = ColorTrackingName(OdometryOptions{}.color_tracking);
};

const KeywordTable<TrackKeywords>& TrackTable() {
  using K = TrackKeywords;
  static const KeywordTable<K> table =
      KeywordTable<K>("track")
          .Add("first", [](K& k) { return &k.odometry.first_frame; })
          .Add("max_frames", [](K& k) { return &k.odometry.max_frames; })
          .Add("stride", [](K& k) { return &k.odometry.stride; })
          .Add("iterations", [](K& k) { return &k.iterations; })
          .Add("prior", [](K& k) { return &k.prior; })
          .Add("keyframes", [](K& k) { return &k.odometry.keyframes; })
          .Add("min_depth", [](K& k) { return &k.odometry.frame.min_depth_m; })
          .Add("max_depth", [](K& k) { return &k.odometry.frame.max_depth_m; })
          .Add("bilateral", [](K& k) { return &k.odometry.frame.bilateral; })
          .Add("bilateral_range_grows",
               [](K& k) { return &k.odometry.frame.bilateral_range_grows; })
          .Add("max_distance", [](K& k) { return &k.odometry.icp.association.max_distance_m; })
          .Add("max_angle", [](K& k) { return &k.odometry.icp.association.max_normal_angle_deg; })
          .Add("depth_weights", [](K& k) { return &k.odometry.icp.weighting.depth_noise; })
          .Add("huber", [](K& k) { return &k.odometry.icp.weighting.huber_delta_m; })
          .Add("noise_floor_depth",
               [](K& k) { return &k.odometry.icp.weighting.noise_floor_depth_m; })
          .Add("min_step", [](K& k) { return &k.min_step; })
          .Add("guard", [](K& k) { return &k.odometry.guard.enabled; })
          .Add("color_align", [](K& k) { return &k.odometry.photometric.enabled; })
          .Add("color_tracking", [](K& k) { return &k.color_tracking; })
          .Add("weak_ratio", [](K& k) { return &k.weak_ratio; })
          .Add("loop_closure", [](K& k) { return &k.loop_closure; })
          .Add("threads", [](K& k) { return &k.odometry.threads; });
  return table;
}

/// rigfit.track's keywords, checked as `rigfit track` checks its flags.
TrackKeywords TrackOptionsOf(const py::dict& keywords) {
  TrackKeywords k = TrackTable().Apply(keywords);
  OdometryOptions& o = k.odometry;
  CheckKeywords("track", [&] {
    ApplyTrackingSettings(k.prior, k.iterations, &o);
    ApplyMinStep(k.min_step, &o.icp);
    ApplyWeakRatio(k.weak_ratio, &o.icp);
    ApplyColorTracking(k.color_tracking, &o);
  });
  return k;
}

/// The counts of a loop closure for a run's dict (None when it was not asked for).
void AddLoopClosure(const std::optional<LoopClosureResult>& closed, py::dict* out) {
  if (!closed) {
    (*out)["loop_closure"] = py::none();
    return;
  }
  py::dict d;
  d["keyframes"] = closed->keyframes.size();
  d["candidates"] = closed->candidates;
  d["accepted"] = closed->accepted;
  d["accepted_across_stretch"] = closed->accepted_across;
  d["accepted_by_color"] = closed->accepted_by_color;
  d["rejected_after_solve"] = closed->rejected_after_solve;
  d["applied"] = closed->applied;
  d["message"] = closed->message;
  d["seconds"] = closed->seconds;
  (*out)["loop_closure"] = d;
}

py::dict Track(const py::object& source, const py::dict& keywords, const py::object& logger) {
  const TrackKeywords k = TrackOptionsOf(keywords);
  const OdometryOptions& options = k.odometry;
  std::unique_ptr<ArraySequence> arrays;
  const RgbdSequence& sequence = SequenceOf(source, "track", &arrays);
  const Log log = PythonLog(logger);
  int last_percent = -1;
  const auto progress = [&](int done, int total) {
    if (!IsProgressStep(done, total, &last_percent)) return;
    log.Info("track: " + std::to_string(done) + "/" + std::to_string(total) + " frames");
  };
  OdometryResult result;
  std::optional<LoopClosureResult> closed;
  {
    py::gil_scoped_release release;
    result = RunOdometry(sequence, options, log, progress);
    if (k.loop_closure) closed = CloseOdometryLoops(sequence, options, &result, log);
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
  py::dict out = RunToDict(result);
  out["frames"] = frames;
  py::dict timings;
  timings["loop_s"] = result.loop_s;
  timings["load_s"] = result.load_s;
  timings["preprocess_s"] = result.preprocess_s;
  timings["track_s"] = result.track_s;
  out["timings"] = timings;
  AddLoopClosure(closed, &out);
  return out;
}

/// rigfit.slam's keywords: `rigfit slam`'s flags (but the sequence's and the files'), read into
/// the options and the settings ApplyTrackingSettings checks.
struct SlamKeywords {
  SlamOptions slam;
  std::vector<int> iterations = SlamOptions{}.icp.iterations;
  std::string prior = MotionPriorName(SlamOptions{}.prior);
  double weak_ratio = SlamOptions{}.icp.weak_direction_ratio;
  bool loop_closure = LoopClosureOptions{}.enabled;
  std::string color_tracking = ColorTrackingName(SlamOptions{}.color_tracking);
};

const KeywordTable<SlamKeywords>& SlamTable() {
  using K = SlamKeywords;
  static const KeywordTable<K> table =
      KeywordTable<K>("slam")
          .Add("first", [](K& k) { return &k.slam.first_frame; })
          .Add("max_frames", [](K& k) { return &k.slam.max_frames; })
          .Add("stride", [](K& k) { return &k.slam.stride; })
          .Add("halve", [](K& k) { return &k.slam.halvings; })
          .Add("iterations", [](K& k) { return &k.iterations; })
          .Add("prior", [](K& k) { return &k.prior; })
          .Add("min_depth", [](K& k) { return &k.slam.frame.min_depth_m; })
          .Add("max_depth", [](K& k) { return &k.slam.frame.max_depth_m; })
          .Add("max_distance", [](K& k) { return &k.slam.icp.association.max_distance_m; })
          .Add("max_angle", [](K& k) { return &k.slam.icp.association.max_normal_angle_deg; })
          .Add("bilateral", [](K& k) { return &k.slam.frame.bilateral; })
          .Add("bilateral_range_grows", [](K& k) { return &k.slam.frame.bilateral_range_grows; })
          .Add("depth_weights", [](K& k) { return &k.slam.icp.weighting.depth_noise; })
          .Add("huber", [](K& k) { return &k.slam.icp.weighting.huber_delta_m; })
          .Add("noise_floor_depth", [](K& k) { return &k.slam.icp.weighting.noise_floor_depth_m; })
          .Add("fuse_distance", [](K& k) { return &k.slam.fusion.max_distance_m; })
          .Add("fuse_angle", [](K& k) { return &k.slam.fusion.max_normal_angle_deg; })
          .Add("dormant_frames", [](K& k) { return &k.slam.fusion.dormant_frames; })
          .Add("cover_radius", [](K& k) { return &k.slam.fusion.cover_radius_scale; })
          .Add("fold", [](K& k) { return &k.slam.fusion.fold_overlapping; })
          .Add("min_stable_weight", [](K& k) { return &k.slam.fusion.min_stable_weight; })
          .Add("model_weight", [](K& k) { return &k.slam.render.min_weight; })
          .Add("model_recent", [](K& k) { return &k.slam.render.recent_frames; })
          .Add("splat", [](K& k) { return &k.slam.render.splat; })
          .Add("color", [](K& k) { return &k.slam.color; })
          .Add("guard", [](K& k) { return &k.slam.guard.enabled; })
          .Add("color_align", [](K& k) { return &k.slam.photometric.enabled; })
          .Add("color_tracking", [](K& k) { return &k.color_tracking; })
          .Add("weak_ratio", [](K& k) { return &k.weak_ratio; })
          .Add("loop_closure", [](K& k) { return &k.loop_closure; })
          .Add("threads", [](K& k) { return &k.slam.threads; });
  return table;
}

/// rigfit.slam's keywords, checked as `rigfit slam` checks its flags.
SlamKeywords SlamOptionsOf(const py::dict& keywords) {
  SlamKeywords k = SlamTable().Apply(keywords);
  SlamOptions& o = k.slam;
  CheckKeywords("slam", [&] {
    ApplyTrackingSettings(k.prior, k.iterations, &o);
    CheckSlamSettings(o);
    ApplyWeakRatio(k.weak_ratio, &o.icp);
    ApplyColorTracking(k.color_tracking, &o);
  });
  return k;
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

py::dict Slam(const py::object& source, const py::dict& keywords, const py::object& logger) {
  const SlamKeywords k = SlamOptionsOf(keywords);
  const SlamOptions& options = k.slam;
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
  std::optional<LoopClosureResult> closed;
  {
    py::gil_scoped_release release;
    result = RunSlam(sequence, options, log, progress);
    if (k.loop_closure) closed = CloseSlamLoops(sequence, options, &result, log);
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
  py::dict out = RunToDict(result);
  out["frames"] = frames;
  const auto n = static_cast<py::ssize_t>(map_sizes.size());
  out["map_sizes"] = VectorToNumpy(std::move(map_sizes), {n});
  py::dict timings;
  timings["loop_s"] = result.loop_s;
  timings["load_s"] = result.load_s;
  timings["preprocess_s"] = result.preprocess_s;
  timings["render_s"] = result.render_s;
  timings["track_s"] = result.track_s;
  timings["fuse_s"] = result.fuse_s;
  out["timings"] = timings;
  out["halvings"] = result.halvings;
  AddLoopClosure(closed, &out);
  out["map"] = SurfelMapToDict(std::move(result.map));
  return out;
}

/// rigfit.evaluate_trajectory's keywords: `rigfit evaluate-trajectory`'s flags.
struct EvaluateTrajectoryKeywords {
  double max_dt = 0.02;
  int delta = 1;
};

const KeywordTable<EvaluateTrajectoryKeywords>& EvaluateTrajectoryTable() {
  using K = EvaluateTrajectoryKeywords;
  static const KeywordTable<K> table = KeywordTable<K>("evaluate_trajectory")
                                           .Add("max_dt", [](K& k) { return &k.max_dt; })
                                           .Add("delta", [](K& k) { return &k.delta; });
  return table;
}

/// The fields of TrajectoryErrors, as `rigfit evaluate-trajectory` prints them (SI units).
py::dict EvaluateTrajectoryErrors(const py::handle& est_timestamps, const py::handle& est_poses,
                                  const py::handle& gt_timestamps, const py::handle& gt_poses,
                                  const py::dict& keywords) {
  const auto [max_dt, delta] = EvaluateTrajectoryTable().Apply(keywords);
  CheckKeywords("evaluate_trajectory", [&] { CheckTrajectoryEvaluationSettings(max_dt, delta); });
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

py::tuple PyReadTrajectory(const std::string& path) {
  return TrajectoryToTuple(ReadTumTrajectory(path));
}

void PyWriteTrajectory(const std::string& path, const py::handle& timestamps,
                       const py::handle& poses) {
  WriteTumTrajectory(path, TrajectoryOf(timestamps, poses, path));
}

}  // namespace

void AddRgbdFunctions(py::module_& m) {
  py::dict defaults = m.attr("keyword_defaults");
  defaults["open_sequence"] = SequenceTable().Defaults();
  defaults["track"] = TrackTable().Defaults();
  defaults["slam"] = SlamTable().Defaults();
  defaults["evaluate_trajectory"] = EvaluateTrajectoryTable().Defaults();
  py::class_<FileSequence>(m, "Sequence")
      .def("__len__", [](const FileSequence& s) { return s.get().size(); })
      .def("frame", &SequenceFrame, py::arg("index"))
      .def("ground_truth", &SequenceGroundTruth)
      .def("describe", [](const FileSequence& s) { return s.get().Describe(); });
  m.def("open_sequence", &OpenSequence, py::arg("path"), py::arg("keywords"), py::arg("logger"));
  m.def("track", &Track, py::arg("source"), py::arg("keywords"), py::arg("logger"));
  m.def("slam", &Slam, py::arg("source"), py::arg("keywords"), py::arg("logger"));
  m.def("evaluate_trajectory", &EvaluateTrajectoryErrors, py::arg("est_timestamps"),
        py::arg("est_poses"), py::arg("gt_timestamps"), py::arg("gt_poses"), py::arg("keywords"));
  m.def("read_trajectory", &PyReadTrajectory, py::arg("path"));
  m.def("write_trajectory", &PyWriteTrajectory, py::arg("path"), py::arg("timestamps"),
        py::arg("poses"));
}

}  // namespace rigfit::python

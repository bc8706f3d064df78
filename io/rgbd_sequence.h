// RGB-D sequences from files (docs/sequences.md): TUM RGB-D folders, ICL-NUIM's TUM-format
// release, 7-Scenes folders and the depth bursts of rig captures, read into core/rgbd.h's
// RgbdSequence (depth in metres, NaN invalid, OpenCV camera axes).
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/rgbd.h"
#include "core/setting_error.h"

namespace rigfit {

/// How to read a sequence; every default is the format's own convention.
struct SequenceOptions {
  /// Intrinsics of the depth image instead of the format's default (folders; a rig capture
  /// has its own). A negative fy is a y-up image, converted as ICL-NUIM's (docs/sequences.md).
  std::optional<PinholeIntrinsics> intrinsics;
  /// TUM RGB-D camera: "fr1", "fr2", "fr3" or "default" (525, 525, 319.5, 239.5). Empty: from
  /// the folder name or the header of depth.txt ("rgbd_dataset_freiburg1_..."), else "default".
  std::string tum_camera;
  /// Largest difference of timestamps, seconds, for associating a colour image or a
  /// ground-truth pose with a depth image (0.02 s: the TUM tools' default).
  double max_time_difference_s = 0.02;
  /// Metres per unit of a 16-bit depth image instead of the format's (TUM and ICL-NUIM
  /// 1/5000, 7-Scenes 1/1000). Not used by rig captures (their depth_scale is in the file).
  std::optional<double> depth_scale;
  /// Every stride-th frame of the files (>= 1).
  int stride = 1;
  /// At most this many frames (after stride); 0: all.
  int max_frames = 0;
  /// The camera of a rig capture; empty: the first by serial.
  std::string serial;
};

/// Sets options->intrinsics from [fx, fy, cx, cy] (`--intrinsics fx,fy,cx,cy`, rigfit's
/// open_sequence(intrinsics=...)); nothing when `values` is empty. Throws SettingError
/// "{intrinsics} takes fx,fy,cx,cy" on another count (OpenRgbdSequence checks the values).
void SetSequenceIntrinsics(const std::vector<double>& values, SequenceOptions* options);

/// Frames per second of sequences that have no clock (7-Scenes, ICL-NUIM, rig-capture
/// bursts): frame k is at k / kUnstampedFrameRateHz seconds (7-Scenes at its file's number).
inline constexpr double kUnstampedFrameRateHz = 30.0;

/// Opens the sequence at `path`, detecting the format (docs/sequences.md):
/// - a file: a rig capture (HDF5); the frames of one camera's depth [F, H, W];
/// - a folder with a `*.gt.freiburg` file (or `associations.txt` but no `rgb.txt`): ICL-NUIM;
/// - a folder with `depth.txt` and `rgb.txt`: TUM RGB-D;
/// - a folder (or its `frames/` subfolder) with `frame-XXXXXX.depth.png` files: 7-Scenes.
/// Reads the lists and poses now and the images on demand (RgbdSequence::Frame). Throws
/// InputError naming the file (and the line) for a missing folder or file, a line of a list
/// that is not `timestamp filename`, a timestamp that does not increase, a malformed pose, a
/// folder of no known format, and options out of range; Frame throws it for an unreadable
/// image or one of the wrong bit depth. Notes for people (e.g. 7-Scenes rotations
/// re-orthonormalised) are appended to `warnings` when given.
std::unique_ptr<RgbdSequence> OpenRgbdSequence(const std::string& path,
                                               const SequenceOptions& options = {},
                                               std::vector<std::string>* warnings = nullptr);

/// The intrinsics of a TUM RGB-D camera by name: "fr1", "fr2", "fr3" (the benchmark's
/// calibrations of the colour camera, to which depth is registered) or "default" (the ROS
/// default of unrectified Kinect images). Throws InputError for another name.
PinholeIntrinsics TumIntrinsics(const std::string& camera);

}  // namespace rigfit

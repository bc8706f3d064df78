// Plain types of the dense RGB-D pipeline: the frames of one moving depth camera and the
// sequence they come in. No file formats here: io/rgbd_sequence.h reads TUM RGB-D, ICL-NUIM,
// 7-Scenes folders and rig-capture bursts into these.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/trajectory.h"
#include "core/types.h"

namespace rigfit {

/// One RGB-D frame: depth in metres (row-major [height, width], NaN where invalid), with the
/// pinhole intrinsics of the depth image (OpenCV axes: x right, y down, z forward).
struct RgbdFrame {
  int index = 0;           ///< position in its sequence, from 0
  double timestamp = 0.0;  ///< seconds (the sequence's clock; frame index / rate where none)
  std::string source;      ///< the file (or dataset) the depth came from, for messages
  int width = 0;
  int height = 0;
  PinholeIntrinsics intrinsics;
  std::vector<float> depth_m;
  /// Optional [height, width, 3] RGB registered to the depth image; empty when the sequence
  /// has no colour or its colour is not registered to depth (7-Scenes).
  std::vector<std::uint8_t> color;
  /// Ground-truth T_world_camera of this frame, when the sequence has one for it.
  std::optional<Pose> T_world_camera_gt;

  float Depth(int u, int v) const { return depth_m[static_cast<std::size_t>(v) * width + u]; }
};

/// Frames of one camera in time order, read on demand (a sequence of 640x480 frames holds
/// 1.2 MB of depth per frame: a loader keeps the list of files, not the images).
class RgbdSequence {
 public:
  virtual ~RgbdSequence() = default;
  /// Number of frames.
  virtual int size() const = 0;
  /// Frame `index` (0 <= index < size()). Throws InputError naming the file on a missing or
  /// unreadable image.
  virtual RgbdFrame Frame(int index) const = 0;
  /// The ground-truth trajectory as the dataset gives it (for TUM the 100 Hz motion capture,
  /// to associate by timestamp; elsewhere one pose per frame at the frames' timestamps);
  /// empty when the sequence has none.
  virtual Trajectory GroundTruth() const = 0;
  /// One line for people: the format, the folder or file, the frame count.
  virtual std::string Describe() const = 0;
};

}  // namespace rigfit

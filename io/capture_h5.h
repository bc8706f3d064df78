// Rig captures (HDF5), the layout of ../shared/docs/formats.md; rigfit's reading rules are in
// docs/formats.md.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "core/types.h"

namespace rigfit {

/// What ReadCapture checks and does to a depth camera once its depth is in metres (NaN where
/// invalid), for a camera that comes from elsewhere (the Python binding's arrays): the image in
/// another unit (median valid depth beyond 100 m) is refused, finite depths beyond 1000 m become
/// invalid and are counted in glitch_depth_samples, and K must satisfy the data contract
/// (docs/formats.md); camera->intrinsics is then set from K. `source` names the input in
/// messages. Throws InputError.
void CheckDepthCamera(CameraCapture* camera, const Mat3& K, const std::string& source);

/// Sets a stereo camera's baseline as ReadCapture reads it, for a camera that comes from
/// elsewhere (the Python binding's dicts): finite and > 0, else InputError with ReadCapture's
/// message ("SOURCE: baseline_m: must be finite and > 0, got ...").
void SetBaseline(CameraCapture* camera, double baseline_m, const std::string& source);

/// Reads a rig capture. Depth becomes float metres with NaN for every invalid sample (NaN,
/// +-inf, <= 0, 0 for uint16); a burst [F, H, W] becomes the per-pixel median of its valid
/// samples (NaN if none). Cameras are sorted by serial. Throws InputError naming the file,
/// the camera and the dataset (e.g. "capture.h5: camera 31002234: depth: expected rank 2 or 3,
/// got 1") for anything off the contract: not HDF5, wrong or missing root attributes,
/// missing or empty /cameras, a camera with neither or both of depth and points, wrong rank,
/// shape, dtype or size, depth_scale missing or not > 0, intrinsics invalid or not matching
/// the image size, non-finite points/normals/confidence, and depth whose median valid sample
/// is beyond 100 m (another unit: millimetres as metres, a wrong depth_scale). A few finite
/// depths beyond 1000 m in an otherwise sound image are sensor glitches: they become invalid
/// and are counted in CameraCapture::glitch_depth_samples (CaptureWarnings says so).
RigCapture ReadCapture(const std::string& path);

/// One depth camera of a rig capture with every frame of its depth.
struct CameraBurst {
  /// The camera as ReadCapture returns it (a burst's depth_m is its per-pixel median).
  CameraCapture camera;
  /// Number of frames: F of a depth [F, H, W], 1 for [H, W].
  int num_frames = 0;
  /// Every frame, [F, H, W] metres with NaN where invalid (ReadCapture's rules, glitches
  /// included).
  std::vector<float> frames_depth_m;
};

/// Reads the camera `serial` of a capture (empty: the first by serial) with every frame of its
/// depth, under exactly ReadCapture's rules and messages for the root attributes, /cameras and
/// that camera (the other cameras are not read). Also throws InputError naming the file for an
/// unknown serial (listing the cameras) and for a camera of points.
CameraBurst ReadCaptureBurst(const std::string& path, const std::string& serial = "");

/// One warning per camera with glitch depth samples read as invalid, naming the file
/// (`path`), the camera and the count; empty when there are none.
std::vector<std::string> CaptureWarnings(const RigCapture& capture, const std::string& path);

/// ReadCapture for the command line: the file is read in a forked child process, so that a
/// crash or a hang inside the HDF5 library on a damaged file (libhdf5 1.10.8 has both,
/// docs/reliability.md) becomes an InputError naming the file instead of killing or stalling
/// rigfit; the child's own InputError message is passed on unchanged. The child sends the
/// capture it read back through a pipe; the file is read once. A child still busy after
/// timeout_s seconds (infinity: no deadline; NaN throws std::invalid_argument) is killed.
/// Where no guard can be had (no pipe or fork, a failing poll or read, the child reaped
/// elsewhere, or a child that read the file but could not send it) the file is read here,
/// as ReadCapture does. Call it before starting threads (fork).
RigCapture ReadCaptureGuarded(const std::string& path, double timeout_s = 300.0);

/// ReadCapture from an in-memory image of an HDF5 file (HDF5 core driver, nothing touches the
/// disk); name stands for the file name in messages.
RigCapture ReadCaptureFromMemory(const void* data, std::size_t size, const std::string& name);

struct CaptureWriteOptions {
  /// Store depth as uint16 with a depth_scale attribute instead of float32 metres. Invalid
  /// (NaN) depth becomes 0; depths that round to 0 become invalid.
  bool depth_as_uint16 = false;
  /// Metres per uint16 unit (> 0).
  double depth_scale = 0.001;
};

/// Writes exactly the contract: root attributes format = "rig-capture", version = 1; per camera
/// depth [H, W] (float32, or uint16 + depth_scale) and intrinsics float64 [3, 3], or points
/// (+ normals) float32 [N, 3]; confidence float32 and color uint8 [H, W, 3] when present.
/// Datasets are chunked and compressed (shuffle + deflate level 1) when the library supports
/// it. Atomic (temporary file + rename). Throws InputError naming the file and camera if the
/// capture is not writable as the contract (sizes, serials, depth beyond the uint16 range) or
/// would not read back (depths or points beyond 1 km, points or normals not finite).
void WriteCapture(const std::string& path, const RigCapture& capture,
                  const CaptureWriteOptions& options = {});

}  // namespace rigfit

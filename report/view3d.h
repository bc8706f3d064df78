// The interactive 3-D view of a report directory (docs/usage.md, "The 3-D view"): a page,
// view3d.html, drawn with three.js from Debian's libjs-three, which the writer copies beside
// it so that the folder works offline from file:// (no network, no server). The scene is
// written as a script beside the page, view3d_data.js, its arrays in base64: positions as
// int16 steps of at most a millimetre around a centre, colours and residuals as uint8. The
// rig's whole views, the bulk of the data and off when the page opens, are a script of their
// own, view3d_whole.js, which the page loads when they are switched on, so that it opens fast.
// Planes (the surface bundle's) are a few corners each, drawn as translucent patches.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/geometry.h"
#include "core/pose.h"
#include "core/types.h"
#include "report/image.h"

namespace rigfit {

/// The view's files in a report directory.
inline constexpr const char* kView3dFile = "view3d.html";
inline constexpr const char* kView3dDataFile = "view3d_data.js";
inline constexpr const char* kView3dWholeFile = "view3d_whole.js";
inline constexpr const char* kThreeJsFile = "three.min.js";
inline constexpr const char* kOrbitControlsFile = "OrbitControls.js";

/// Where the writer finds three.js: Debian's libjs-three, the folder CMake found it in.
const char* ThreeJsDirectory();

/// The switches a cloud is shown under in the page.
inline constexpr const char* kBandLayer = "band";     ///< a rig's near-floor band
inline constexpr const char* kWholeLayer = "whole";   ///< every point a camera saw
inline constexpr const char* kMapLayer = "map";       ///< a fused map
inline constexpr const char* kPlaneLayer = "planes";  ///< the surface bundle's planes

/// A point cloud of the view: in the frame of one of the scene's cameras (moved by the pose
/// set shown) or in the world.
struct ViewCloud {
  std::string layer = kMapLayer;
  int camera = -1;  ///< index into View3dScene::cameras; -1: world points
  std::vector<Vec3f> points;
  std::vector<std::uint8_t> rgb;  ///< 3 per point (RGB), or empty: no colour of its own
  /// Per pose set, |residual| (metres) of each point there, NaN where it has none; empty:
  /// not measured.
  std::vector<std::vector<float>> residuals_m;
};

/// A camera drawn as a frustum, labelled with its serial.
struct ViewCamera {
  std::string serial;
  Rgb color;
  PinholeIntrinsics intrinsics;
  int width = 0;  ///< pixels; 0: no image (a points camera), drawn with a 60 degree frustum
  int height = 0;
};

/// One set of camera poses (T_world_camera, one per camera of the scene) the page can show:
/// e.g. "before" (leveled) and "after" (refined).
struct ViewPoseSet {
  std::string name;
  std::vector<Pose> T_world_camera;
};

/// A path through world positions (a trajectory).
struct ViewPath {
  std::string label;
  Rgb color;
  std::vector<Vec3> positions;
};

/// A plane drawn as a translucent patch: a convex polygon in the world (its corners in order
/// around it), e.g. the surface bundle's plane over the pixels on it.
struct ViewPlane {
  Rgb color;
  bool floor = false;
  std::vector<Vec3> corners;
};

/// Everything the page shows.
struct View3dScene {
  std::string title;
  Vec3 up = kWorldUp;    ///< the world direction shown up (+Y of the page)
  double floor_m = 0.0;  ///< height along `up` of the floor grid
  std::vector<ViewCamera> cameras;
  std::vector<ViewPoseSet> pose_sets;  ///< the page opens on the last one
  std::vector<ViewCloud> clouds;
  std::vector<ViewPath> paths;
  std::vector<ViewPlane> planes;  ///< shown under kPlaneLayer
  /// Residual colour scale: from 0 to this (metres), larger residuals at its top colour.
  double residual_range_m = 0.01;
};

/// The page (kView3dFile) of a scene whose data is in kView3dDataFile beside it.
std::string View3dHtml(const std::string& title);

/// The scene but its kWholeLayer clouds as the script kView3dDataFile (sets the global
/// RIGFIT_VIEW; its "deferred" names kView3dWholeFile when there are such clouds).
std::string View3dDataScript(const View3dScene& scene);

/// The scene's kWholeLayer clouds as the script kView3dWholeFile (sets the global
/// RIGFIT_VIEW_WHOLE, an array of clouds).
std::string View3dWholeScript(const View3dScene& scene);

/// Writes kView3dFile, kView3dDataFile, kView3dWholeFile (when the scene has kWholeLayer
/// clouds) and copies three.js (kThreeJsFile, kOrbitControlsFile
/// from ThreeJsDirectory()) into dir, which must exist. Returns the paths written. Throws
/// InputError when three.js is missing (naming the file and the package libjs-three) or a
/// file cannot be written.
std::vector<std::string> WriteView3d(const std::string& dir, const View3dScene& scene);

}  // namespace rigfit

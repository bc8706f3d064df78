// Faces found in each depth camera's image (issue 33 point 3). A plane's inverse depth is affine
// in the image, w = 1 / z = p0 + p1 x + p2 y (x, y the normalised pixel coordinates), and with
// sigma_z = k z^2 every pixel's w has the same noise k: so each camera's faces (after the leveled
// floor, whose pixels its plane y = 0 predicts) are grown in its image from planar seed windows,
// a neighbour joining a face when its w lies within gate_sigmas k of the face's affine model
// (refitted as the face grows); where two faces meet, each pixel goes to the face on whose side
// of their planes' intersection it lies (the faces refitted until no pixel changes). The faces of
// all cameras are then associated by overlap: a camera's face seen from another camera at the
// given poses falls on that camera's face: one face, one world plane.
// Used by the surface bundle (IcpOptions::surface_faces "image") and scored by the face oracle
// (analysis/face_finder.h).
#pragma once

#include <vector>

#include "core/pose.h"
#include "core/types.h"

namespace rigfit {

struct ImageFacesOptions {
  double gate_sigmas = 2.5;  ///< a pixel joins a face within this many k of its model
  int seed_radius = 1;       ///< seed windows of (2 r + 1)^2 pixels
  double seed_sigmas = 1.5;  ///< a seed window's RMS residual is at most this many k
  int min_pixels = 12;       ///< a camera's smaller faces are dropped
  /// Two cameras' faces are one face when this share of one's points that the other camera
  /// sees (its measured depth there agrees) fall on the other's face, and their normals lie
  /// within merge_angle_deg.
  double min_overlap = 0.25;
  double merge_angle_deg = 20.0;
  double pose_tolerance_m = 0.03;  ///< the poses' error, along a ray, in that agreement
  /// A camera's face whose points lie farther (RMS) from the plane of the face it was
  /// associated with than this many times their scatter about their camera's model of it (at
  /// least k) is a face of its own (a wrong association); the worst first, the plane refitted
  /// after each. Not the leveled floor's.
  double max_scatter_ratio = 3.0;
  /// Where two faces of a camera meet (their planes' predictions within gate_sigmas k of each
  /// other), a pixel goes to the face on whose side of the planes' intersection it lies.
  bool crease_sides = true;
  /// The world is leveled (the floor y = 0): each camera's points within the gate (and
  /// pose_tolerance_m) of the floor are its first face, before any face grows, and the floors of
  /// all cameras one face.
  bool leveled_floor = true;
};

/// The smallest depth noise k (1/m) the gates use (noise-free captures).
constexpr double kMinImageFaceNoise = 1e-4;

/// One depth camera: its points (camera frame, at most one per pixel, as the camera
/// unprojected them), its image and pose.
struct ImageFaceCamera {
  const PointCloud* points = nullptr;  ///< nullptr: no depth (no faces)
  PinholeIntrinsics intrinsics;
  int width = 0;
  int height = 0;
  Pose T_world_camera = Pose::Identity();
  double depth_noise = 0.0;  ///< k of sigma_z = k z^2
};

/// One camera's faces.
struct CameraImageFaces {
  std::vector<int> label;               ///< per point: its camera face (-1: none)
  std::vector<Eigen::Vector2i> pixels;  ///< per point: its pixel
  std::vector<PlanarFace> planes;       ///< per camera face: its plane, camera frame
  std::vector<int> face;                ///< per camera face: its face (ImageFaces::faces)
};

struct ImageFaces {
  std::vector<CameraImageFaces> cameras;  ///< per camera, in the order given
  std::vector<PlanarFace> faces;          ///< world (least squares on their points); the floor +Y
  int camera_faces = 0;                   ///< faces found in the cameras' images
};

/// The faces of `cameras` at their poses, each camera's image on up to num_threads threads.
ImageFaces FindImageFaces(const std::vector<ImageFaceCamera>& cameras,
                          const ImageFacesOptions& options, int num_threads);

}  // namespace rigfit

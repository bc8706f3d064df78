// A face finder in each camera's image (issue 33 point 3), scored by the face oracle
// (analysis/face_oracle.h: its labels in place of the true ones). A plane's inverse depth is
// affine in the image, w = 1 / z = p0 + p1 x + p2 y (x, y the normalised pixel coordinates), and
// with sigma_z = k z^2 every pixel's w has the same noise k: so each camera's faces (after the
// leveled floor, whose pixels its plane y = 0 predicts) are grown in its image from planar seed
// windows, a neighbour joining a face when its w lies within gate_sigmas k of the face's affine
// model (refitted as the face grows); where two faces meet, each pixel goes to the face on whose
// side of their planes' intersection it lies. The faces of all cameras are then associated by
// overlap: a camera's face seen from another camera at the start poses falls on that camera's
// face: one plane.
// Band pixels are kept by where their face's plane puts them (their ray meets it inside the
// band), not by their measured height, which their noise moves.
#pragma once

#include <vector>

#include "analysis/crlb.h"
#include "core/pose.h"
#include "core/types.h"
#include "options/refine_options.h"

namespace rigfit {

struct FaceFinderOptions {
  double depth_noise = 0.0025;  ///< k of sigma_z = k z^2: the noise of every pixel's w (1/m)
  double gate_sigmas = 2.5;     ///< a pixel joins a face within this many k of its model
  int seed_radius = 1;          ///< seed windows of (2 r + 1)^2 pixels
  double seed_sigmas = 1.5;     ///< a seed window's RMS residual is at most this many k
  int min_pixels = 12;          ///< a camera's smaller faces are dropped
  /// Two cameras' faces are one face when this share of one's points that the other camera
  /// sees (its measured depth there agrees) fall on the other's face, and their normals lie
  /// within merge_angle_deg.
  double min_overlap = 0.25;
  double merge_angle_deg = 20.0;
  double pose_tolerance_m = 0.03;  ///< the start poses' error, along a ray, in that agreement
  double margin_m = 0.15;          ///< the band widened by this while finding the faces
  /// Where two faces of a camera meet (their planes' predictions within gate_sigmas k of each
  /// other), a pixel goes to the face on whose side of the planes' intersection it lies.
  bool crease_sides = true;
  /// The world is leveled (the floor y = 0): each camera's points within the gate (and
  /// pose_tolerance_m) of the floor are its first face, before any face grows, and the floors of
  /// all cameras one face.
  bool leveled_floor = true;
};

struct FoundFaces {
  /// Per camera of the capture: its band pixels (at the start pose) labelled with their face
  /// (-1: none); points are where the pixel's ray meets its face's plane (camera frame).
  std::vector<FacePixels> cameras;
  std::vector<PlanarFace> faces;  ///< world, at the start poses; the floor +Y
  int camera_faces = 0;           ///< faces found in the cameras' images, before association
};

/// The faces of `capture`'s depth cameras at `start` (every camera's pose), near the floor
/// band of `region`.
FoundFaces FindFaces(const RigCapture& capture, const PoseMap& start, const RegionOptions& region,
                     const FaceFinderOptions& options);

}  // namespace rigfit

// The image face finder (registration/image_faces.h, the surface bundle's with
// IcpOptions::surface_faces "image") on a capture's band at given poses, for the face oracle
// (analysis/face_oracle.h: its labels in place of the true ones). Band pixels are kept by where
// their face's plane puts them (their ray meets it inside the band), not by their measured
// height, which their noise moves.
#pragma once

#include <vector>

#include "analysis/crlb.h"
#include "core/pose.h"
#include "core/types.h"
#include "options/refine_options.h"
#include "registration/image_faces.h"

namespace rigfit {

/// The image face finder's options (registration/image_faces.h) with one depth noise for every
/// camera and the band widened while the faces are found.
struct FaceFinderOptions : ImageFacesOptions {
  double depth_noise = 0.0025;  ///< k of sigma_z = k z^2: the noise of every pixel's w (1/m)
  double margin_m = 0.15;       ///< the band widened by this while finding the faces
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

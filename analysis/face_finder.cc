#include "analysis/face_finder.h"

#include "core/geometry.h"
#include "prepare/region.h"
#include "registration/image_faces.h"
#include "rig/refine.h"

namespace rigfit {
namespace {

/// A camera's band pixels with their faces, kept where their ray meets their camera face's
/// plane inside the band; the points are those meeting points.
FacePixels BandPixels(const std::string& serial, const PointCloud& points, const Pose& T,
                      const CameraImageFaces& found, const RegionOptions& region) {
  FacePixels kept;
  kept.serial = serial;
  for (size_t i = 0; i < points.size(); ++i) {
    if (found.label[i] < 0) continue;
    const PlanarFace& local = found.planes[found.label[i]];
    const Vec3 ray = points[i] / points[i].z();
    const Vec3 p = RayPlaneDepth(Vec3::Zero(), ray, local.normal, local.offset) * ray;
    const double height = (T * p).y();
    if (region.band_height > 0.0 && (height < -region.band_below || height > region.band_height)) {
      continue;
    }
    kept.points.push_back(p);
    kept.faces.push_back(found.face[found.label[i]]);
    kept.pixels.push_back(found.pixels[i]);
  }
  return kept;
}

}  // namespace

FoundFaces FindFaces(const RigCapture& capture, const PoseMap& start, const RegionOptions& region,
                     const FaceFinderOptions& options) {
  RegionOptions wide = region;
  wide.pixel_stride = 1;
  if (wide.band_height > 0.0) {
    wide.band_below += options.margin_m;
    wide.band_height += options.margin_m;
  }
  const size_t n = capture.cameras.size();
  std::vector<PointCloud> points(n);
  std::vector<ImageFaceCamera> cameras(n);
  for (size_t c = 0; c < n; ++c) {
    const CameraCapture& camera = capture.cameras[c];
    if (!camera.HasDepth() || !start.count(camera.serial)) continue;
    const Pose& T = start.at(camera.serial);
    points[c] = NearFloorBand(RegistrationPoints(camera, wide), T, wide);
    cameras[c] = {&points[c], camera.intrinsics,  camera.width, camera.height,
                  T,          options.depth_noise};
  }
  const ImageFaces found = FindImageFaces(cameras, options, 1);
  FoundFaces out;
  out.faces = found.faces;
  out.camera_faces = found.camera_faces;
  for (size_t c = 0; c < n; ++c) {
    out.cameras.push_back(BandPixels(capture.cameras[c].serial, points[c],
                                     cameras[c].T_world_camera, found.cameras[c], region));
  }
  return out;
}

}  // namespace rigfit

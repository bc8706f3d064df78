// Rendered depth frames of a simulated room, shared by the dense RGB-D tests.
#pragma once

#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "core/pose.h"
#include "core/rgbd.h"
#include "core/trajectory.h"
#include "rgbd/frame.h"
#include "sim/random.h"
#include "sim/scene.h"

namespace rigfit::rgbd_test {

inline constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// A room of 6 x 5 m with 2.5 m walls, two boxes and a slanted block: enough structure to fix
// every direction of a camera looking into it.
inline Scene TestRoom() {
  Scene scene;
  scene.size_x_m = 6.0;
  scene.size_z_m = 5.0;
  scene.wall_height_m = 2.5;
  const auto add = [&](const Vec3& center, const Vec3& size, double yaw, SurfaceKind kind) {
    OrientedBox box;
    box.center = center;
    box.R_world_box = ExpSO3(Vec3(0.0, yaw, 0.0));
    box.half_extents = 0.5 * size;
    box.kind = kind;
    scene.boxes.push_back(box);
  };
  add(Vec3(0, -0.1, 0), Vec3(6.4, 0.2, 5.4), 0.0, SurfaceKind::kFloor);
  add(Vec3(-3.1, 1.25, 0), Vec3(0.2, 2.5, 5.4), 0.0, SurfaceKind::kWall);
  add(Vec3(3.1, 1.25, 0), Vec3(0.2, 2.5, 5.4), 0.0, SurfaceKind::kWall);
  add(Vec3(0, 1.25, -2.6), Vec3(6.4, 2.5, 0.2), 0.0, SurfaceKind::kWall);
  add(Vec3(0, 1.25, 2.6), Vec3(6.4, 2.5, 0.2), 0.0, SurfaceKind::kWall);
  add(Vec3(-1.0, 0.4, -1.2), Vec3(0.8, 0.8, 0.6), 0.5, SurfaceKind::kFurniture);
  add(Vec3(1.2, 0.6, -1.5), Vec3(0.5, 1.2, 0.5), -0.3, SurfaceKind::kFurniture);
  add(Vec3(0.3, 0.25, -0.5), Vec3(1.0, 0.5, 0.4), 1.1, SurfaceKind::kFurniture);
  return scene;
}

// T_world_camera of a camera at `eye` looking at `target` (OpenCV axes: y down, +Y world up).
inline Pose LookAt(const Vec3& eye, const Vec3& target) {
  const Vec3 z = (target - eye).normalized();
  const Vec3 up = Vec3::UnitY();
  const Vec3 y = -(up - up.dot(z) * z).normalized();
  Pose T = Pose::Identity();
  T.linear().col(0) = y.cross(z);
  T.linear().col(1) = y;
  T.linear().col(2) = z;
  T.translation() = eye;
  return T;
}

inline PinholeIntrinsics Intrinsics(int width, int height) {
  const double f = 525.0 * width / 640.0;
  return {f, f, (width - 1) / 2.0, (height - 1) / 2.0};
}

// The depth image the camera sees, with N(0, (noise z^2)^2) added when noise > 0.
inline RgbdFrame Render(const Scene& scene, const Pose& T_world_camera, int width, int height,
                        double noise = 0.0, std::uint64_t seed = 0) {
  RgbdFrame frame;
  frame.width = width;
  frame.height = height;
  frame.intrinsics = Intrinsics(width, height);
  frame.source = "rendered";
  frame.depth_m.assign(static_cast<std::size_t>(width) * height, kNaN);
  frame.T_world_camera_gt = T_world_camera;
  SimRng rng(seed, 7);
  const PinholeIntrinsics& K = frame.intrinsics;
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const Vec3 ray((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);
      const auto hit = scene.Raycast(T_world_camera.translation(), T_world_camera.linear() * ray);
      if (!hit) continue;
      const double z = hit->t;
      frame.depth_m[static_cast<std::size_t>(v) * width + u] =
          static_cast<float>(z + (noise > 0.0 ? noise * z * z * rng.Normal() : 0.0));
    }
  }
  return frame;
}

// A level with one valid pixel in the middle of a 5x5 image at depth z, normal -z (facing the
// camera), and everything else invalid.
inline FrameLevel SinglePixelLevel(float z) {
  FrameLevel level;
  level.width = 5;
  level.height = 5;
  level.intrinsics = {10.0, 10.0, 2.0, 2.0};
  level.depth_m.assign(25, kNaN);
  level.vertices.assign(25, Vec3f::Constant(kNaN));
  level.normals.assign(25, Vec3f::Constant(kNaN));
  level.depth_m[12] = z;
  level.vertices[12] = Vec3f(0, 0, z);
  level.normals[12] = Vec3f(0, 0, -1);
  level.valid_pixels = {12};
  return level;
}

// An in-memory sequence of rendered frames.
class RenderedSequence final : public RgbdSequence {
 public:
  RenderedSequence(const Scene& scene, std::vector<Pose> poses, int width, int height, double noise)
      : scene_(scene), poses_(std::move(poses)), width_(width), height_(height), noise_(noise) {}
  int size() const override { return static_cast<int>(poses_.size()); }
  RgbdFrame Frame(int index) const override {
    RgbdFrame frame = Render(scene_, poses_[index], width_, height_, noise_, index);
    frame.index = index;
    frame.timestamp = index / 30.0;
    return frame;
  }
  Trajectory GroundTruth() const override {
    Trajectory gt;
    for (int i = 0; i < size(); ++i) {
      gt.timestamps.push_back(i / 30.0);
      gt.poses.push_back(poses_[i]);
    }
    return gt;
  }
  std::string Describe() const override { return "rendered"; }

 private:
  const Scene& scene_;
  std::vector<Pose> poses_;
  int width_, height_;
  double noise_;
};

// `base` with every frame passed through `edit` (its index, the frame) on its way out: a
// sequence where some frames go wrong.
class EditedSequence final : public RgbdSequence {
 public:
  using Edit = std::function<void(int index, RgbdFrame* frame)>;
  EditedSequence(const RgbdSequence& base, Edit edit, std::string description)
      : base_(base), edit_(std::move(edit)), description_(std::move(description)) {}
  int size() const override { return base_.size(); }
  RgbdFrame Frame(int index) const override {
    RgbdFrame frame = base_.Frame(index);
    edit_(index, &frame);
    return frame;
  }
  Trajectory GroundTruth() const override { return base_.GroundTruth(); }
  std::string Describe() const override { return description_; }

 private:
  const RgbdSequence& base_;
  Edit edit_;
  std::string description_;
};

// A walk of 2 cm per frame through the test room, looking at the far wall.
inline std::vector<Pose> Walk(int frames) {
  std::vector<Pose> poses;
  for (int i = 0; i < frames; ++i) {
    const double s = i / 30.0;  // seconds
    const Vec3 eye(0.6 * std::sin(0.8 * s), 1.4 + 0.05 * std::sin(2.0 * s), 1.5 - 0.2 * s);
    const Vec3 target(0.3 * std::sin(0.5 * s), 0.6, -1.8);
    poses.push_back(LookAt(eye, target));
  }
  return poses;
}

}  // namespace rigfit::rgbd_test

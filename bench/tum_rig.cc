// Real data nobody on the team made: frames of TUM RGB-D fr1/xyz taken as the fixed cameras
// of a rig (real Kinect v1 depth, motion-capture ground truth), refined from a perturbed
// start without ground leveling, with the whole cloud (band_height 0) and no gravity prior
// (the motion-capture world is not gravity-aligned). Prints the gauge-free errors against
// the motion capture before and after, per mode. Usage: tum_rig --help.
#include <png.h>

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "bench/bench_util.h"
#include "core/evaluate.h"
#include "rig/refine.h"

namespace {

using namespace rigfit;

/// TUM depth PNGs: metres = value / 5000, 0 = no measurement.
constexpr double kTumDepthScale = 1.0 / 5000.0;

/// A 16-bit grayscale PNG as depth in metres (NaN where 0).
CameraCapture ReadTumDepth(const std::string& path) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&image, path.c_str())) {
    throw std::runtime_error(path + ": " + image.message);
  }
  image.format = PNG_FORMAT_LINEAR_Y;  // 16-bit linear gray, values as stored
  std::vector<png_uint_16> pixels(PNG_IMAGE_SIZE(image) / sizeof(png_uint_16));
  if (!png_image_finish_read(&image, nullptr, pixels.data(), 0, nullptr)) {
    throw std::runtime_error(path + ": " + image.message);
  }
  CameraCapture camera;
  camera.width = static_cast<int>(image.width);
  camera.height = static_cast<int>(image.height);
  camera.depth_m.resize(pixels.size());
  for (size_t i = 0; i < pixels.size(); ++i) {
    camera.depth_m[i] = pixels[i] == 0 ? NAN : static_cast<float>(pixels[i] * kTumDepthScale);
  }
  return camera;
}

/// Lines "timestamp rest..." of a TUM list file, comments skipped.
std::vector<std::pair<double, std::string>> ReadList(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::vector<std::pair<double, std::string>> rows;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream s(line);
    double t = 0.0;
    s >> t;
    std::string rest;
    std::getline(s, rest);
    rows.emplace_back(t, rest);
  }
  return rows;
}

/// Motion-capture pose (camera to world) nearest in time.
Pose GroundTruthAt(const std::vector<std::pair<double, std::string>>& gt, double t) {
  const auto* best = &gt.front();
  for (const auto& row : gt) {
    if (std::abs(row.first - t) < std::abs(best->first - t)) best = &row;
  }
  std::istringstream s(best->second);
  double tx, ty, tz, qx, qy, qz, qw;
  s >> tx >> ty >> tz >> qx >> qy >> qz >> qw;
  Pose T = Pose::Identity();
  T.linear() = Eigen::Quaterniond(qw, qx, qy, qz).normalized().toRotationMatrix();
  T.translation() = Vec3(tx, ty, tz);
  return T;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"TUM fr1/xyz frames as a fixed rig: joint and pairwise against motion capture"};
  std::string dir = std::string(RIGFIT_SHARED_DATA_DIR) + "/tum_fr1_xyz_subset";
  std::vector<int> frames = {0, 9, 18, 27, 36};
  double rotation_deg = 1.0, translation_m = 0.03, depth_noise = 0.0;
  int seeds = 5;
  std::vector<double> intrinsics = {517.3, 516.5, 318.6, 255.3};  // fr1, shared/data/README.md
  app.add_option("--intrinsics", intrinsics, "fx fy cx cy")->expected(4);
  app.add_option("--dir", dir, "the TUM folder");
  app.add_option("--frames", frames, "depth frame indices used as cameras");
  app.add_option("--perturb-deg", rotation_deg, "rotation of each start pose, degrees");
  app.add_option("--perturb-m", translation_m, "translation of each start pose, metres");
  app.add_option("--seeds", seeds, "perturbations tried");
  app.add_option("--depth-noise", depth_noise, "icp.depth_noise (k of sigma_z = k z^2); 0: none");
  CLI11_PARSE(app, argc, argv);

  const auto depth_list = ReadList(dir + "/depth.txt");
  const auto gt_list = ReadList(dir + "/groundtruth.txt");
  RigCapture capture;
  PoseMap gt;
  for (int f : frames) {
    std::istringstream s(depth_list.at(f).second);
    std::string file;
    s >> file;
    CameraCapture camera = ReadTumDepth(dir + "/" + file);
    char serial[16];
    std::snprintf(serial, sizeof(serial), "frame%02d", f);
    camera.serial = serial;
    camera.intrinsics = {intrinsics[0], intrinsics[1], intrinsics[2], intrinsics[3]};
    gt[camera.serial] = GroundTruthAt(gt_list, depth_list.at(f).first);
    capture.cameras.push_back(std::move(camera));
  }

  RefineOptions options;
  options.ground.enabled = false;
  options.region.band_height = 0.0;
  options.icp.gravity_weight = 0.0;
  options.icp.depth_noise = depth_noise;
  std::printf("TUM fr1/xyz frames as %zu cameras, start perturbed by %.2f deg and %.3f m\n\n",
              frames.size(), rotation_deg, translation_m);
  std::printf(
      "| seed | start deg | start mm | start max mm | joint deg | joint mm | joint max mm | "
      "pairwise deg | pairwise mm | pairwise max mm |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
  bench::ErrorSummary summary[3];
  for (int seed = 0; seed < seeds; ++seed) {
    const PoseMap init = bench::PerturbRig(gt, rotation_deg, translation_m, seed);
    RigErrors errors[3] = {EvaluateRig(init, gt)};
    for (int m = 0; m < 2; ++m) {
      options.icp.mode = m == 0 ? RefineMode::kJoint : RefineMode::kPairwise;
      errors[m + 1] = EvaluateRig(Refine(capture, init, options, true, 2, {}).refined, gt);
    }
    for (int k = 0; k < 3; ++k) summary[k].Add(errors[k]);
    std::printf("| %d | %s | %s | %s |\n", seed, bench::ErrorCells(errors[0]).c_str(),
                bench::ErrorCells(errors[1]).c_str(), bench::ErrorCells(errors[2]).c_str());
  }
  std::printf("| RMS (max) | %s | %s | %s |\n", summary[0].Cells().c_str(),
              summary[1].Cells().c_str(), summary[2].Cells().c_str());
  return 0;
}

// Real data without a floor: the Stanford bunny's 10 range scans (Cyberware 3030MS) as the
// points cameras of a rig, imported with `rigfit import-ply` (each scan's points in its own
// frame), registered jointly and pairwise from perturbed starts, and measured against the
// poses of bun.conf with the gauge-free errors of core/evaluate.h. --check-gt first measures
// how well the scans overlap at the bun.conf poses under both readings of its quaternions.
// Usage: bunny_rig --help; docs/benchmarks.md has the commands and results.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "bench/bench_util.h"
#include "core/stopwatch.h"
#include "io/capture_h5.h"
#include "io/config_yaml.h"
#include "prepare/preprocess.h"
#include "rig/refine.h"
#include "search/knn.h"

namespace {

using namespace rigfit;

/// How a bun.conf line "bmesh <file> tx ty tz qx qy qz qw" maps scan points to the world.
enum class Convention {
  kTransposed,  ///< p_world = R(q)^T p_scan + t (shared/data/README.md)
  kDirect,      ///< p_world = R(q) p_scan + t (the usual reading, for comparison)
};

/// T_world_scan per scan, keyed by the file name without ".ply" (the serial import-ply was
/// given by bench/run.sh).
PoseMap ReadBunConf(const std::string& path, Convention convention) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path);
  PoseMap poses;
  for (std::string line; std::getline(in, line);) {
    std::istringstream s(line);
    std::string kind, file;
    double tx, ty, tz, qx, qy, qz, qw;
    if (!(s >> kind) || kind != "bmesh") continue;  // the "camera" line is a viewer's pose
    if (!(s >> file >> tx >> ty >> tz >> qx >> qy >> qz >> qw)) {
      throw std::runtime_error(path + ": malformed line '" + line + "'");
    }
    const Mat3 R = Eigen::Quaterniond(qw, qx, qy, qz).normalized().toRotationMatrix();
    Pose T = Pose::Identity();
    T.linear() = convention == Convention::kTransposed ? Mat3(R.transpose()) : R;
    T.translation() = Vec3(tx, ty, tz);
    poses[file.substr(0, file.rfind('.'))] = T;
  }
  return poses;
}

/// Each scan against the union of the others, all in the world at `poses`: the fraction of
/// its points with a neighbour within `overlap_m`, and the median and RMS of those distances.
void CheckPoses(const RigCapture& capture, const PoseMap& poses, const std::string& name,
                double overlap_m) {
  std::printf("\n%s\n\n| scan | points | overlap (NN < %.1f mm) | median NN mm | RMS NN mm |\n",
              name.c_str(), overlap_m * 1e3);
  std::printf("|---|---|---|---|---|\n");
  for (const CameraCapture& scan : capture.cameras) {
    PointCloud others;
    for (const CameraCapture& other : capture.cameras) {
      if (other.serial == scan.serial) continue;
      for (const Vec3& p : other.points) others.push_back(poses.at(other.serial) * p);
    }
    const KdTree tree(others);
    std::vector<double> distances;
    for (const Vec3& p : scan.points) {
      int index = 0;
      double d2 = 0.0;
      if (tree.Nearest(poses.at(scan.serial) * p, overlap_m, &index, &d2)) {
        distances.push_back(std::sqrt(d2));
      }
    }
    double sum2 = 0.0;
    for (double d : distances) sum2 += d * d;
    std::sort(distances.begin(), distances.end());
    const bool any = !distances.empty();
    std::printf("| %s | %zu | %.3f | %.3f | %.3f |\n", scan.serial.c_str(), scan.points.size(),
                static_cast<double>(distances.size()) / scan.points.size(),
                any ? distances[distances.size() / 2] * 1e3 : NAN,
                any ? std::sqrt(sum2 / distances.size()) * 1e3 : NAN);
  }
}

/// Every pair's error, joint and pairwise, beside pairwise ICP's report of it (to stderr, so
/// that the table on stdout stays one table).
void PrintPairs(const RigErrors& joint, const RigErrors& pairwise,
                const std::vector<PairReport>& reports) {
  std::fprintf(stderr,
               "| pair | joint deg | joint mm | pairwise deg | pairwise mm | fitness | "
               "RMSE mm | correspondences | accepted |\n|---|---|---|---|---|---|---|---|---|\n");
  for (size_t k = 0; k < joint.pairs.size(); ++k) {
    const PairError& j = joint.pairs[k];
    const PairError& p = pairwise.pairs[k];
    const PairReport* report = nullptr;
    for (const PairReport& r : reports) {
      if ((r.serial_a == j.serial_i && r.serial_b == j.serial_j) ||
          (r.serial_a == j.serial_j && r.serial_b == j.serial_i)) {
        report = &r;
      }
    }
    std::fprintf(stderr, "| %s-%s | %.3f | %.3f | %.3f | %.3f |", j.serial_i.c_str(),
                 j.serial_j.c_str(), j.error.rotation_rad * kRadToDeg, j.error.translation_m * 1e3,
                 p.error.rotation_rad * kRadToDeg, p.error.translation_m * 1e3);
    if (report != nullptr) {
      std::fprintf(stderr, " %.3f | %.3f | %d | %s |\n", report->fitness,
                   report->rmse_after_m * 1e3, report->correspondences,
                   report->accepted ? "yes" : report->message.c_str());
    } else {
      std::fprintf(stderr, " | | | not a candidate |\n");
    }
  }
}

/// The scans' fit at `poses`, free of the truth: over every ordered pair of scans, each point
/// of one matched to its nearest neighbour in the other within `overlap_m`, the RMS of the
/// point-to-plane distance to that neighbour's plane (normals from 10 neighbours in its own
/// scan at full resolution), in mm, and the number of matches.
void PlaneFit(const RigCapture& capture, const PoseMap& poses, const std::string& name,
              double overlap_m) {
  const size_t n = capture.cameras.size();
  std::vector<std::unique_ptr<KdTree>> trees(n);
  std::vector<LocalGeometry> geometry(n);
  for (size_t i = 0; i < n; ++i) {
    trees[i] = std::make_unique<KdTree>(capture.cameras[i].points);
    geometry[i] = EstimateLocalGeometry(capture.cameras[i].points, *trees[i], 10, Vec3::Zero(), 2);
  }
  double sum2 = 0.0;
  size_t count = 0;
  for (size_t s = 0; s < n; ++s) {
    for (size_t t = 0; t < n; ++t) {
      if (s == t) continue;
      const Pose T =
          poses.at(capture.cameras[t].serial).inverse() * poses.at(capture.cameras[s].serial);
      for (const Vec3& p : capture.cameras[s].points) {
        int j = 0;
        double d2 = 0.0;
        const Vec3 q = T * p;
        if (!trees[t]->Nearest(q, overlap_m, &j, &d2) || !geometry[t].IsValid(j)) continue;
        const double r = geometry[t].normals[j].dot(q - capture.cameras[t].points[j]);
        sum2 += r * r;
        ++count;
      }
    }
  }
  std::fprintf(stderr, "%s: point-to-plane RMS %.4f mm over %zu matches within %.1f mm\n",
               name.c_str(), std::sqrt(sum2 / count) * 1e3, count, overlap_m * 1e3);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Stanford bunny scans as a rig of points cameras, against bun.conf"};
  std::string capture_path;
  std::string conf = std::string(RIGFIT_SHARED_DATA_DIR) + "/stanford_bunny/data/bun.conf";
  std::string config = std::string(RIGFIT_SOURCE_DIR) + "/bench/bunny.yaml";
  std::string method = "point_to_plane";
  double rotation_deg = 2.0, translation_m = 0.005, overlap_m = 0.002;
  int seeds = 5, threads = 2;
  bool check_gt = false;
  bool pairs = false;
  app.add_option("--capture", capture_path, "the scans imported by rigfit import-ply")->required();
  app.add_option("--conf", conf, "bun.conf");
  app.add_option("--config", config, "refine options (YAML)");
  app.add_option("--method", method)
      ->check(CLI::IsMember({"point_to_plane", "gicp", "surface_bundle"}));
  app.add_option("--perturb-deg", rotation_deg, "rotation of each start pose, degrees");
  app.add_option("--perturb-m", translation_m, "translation of each start pose, metres");
  app.add_option("--seeds", seeds, "perturbations tried (seeds 0..seeds-1)");
  app.add_option("--threads", threads);
  app.add_flag("--check-gt", check_gt, "only measure the overlap of the scans at bun.conf");
  app.add_option("--overlap-m", overlap_m, "--check-gt, --pairs: overlap distance, metres");
  app.add_flag("--pairs", pairs,
               "also print (stderr) every scan pair's error, joint and pairwise, pairwise ICP's "
               "report, and the truth-free fit of joint, pairwise and bun.conf (point-to-plane "
               "RMS over every ordered pair of scans, matches within --overlap-m)");
  CLI11_PARSE(app, argc, argv);

  const RigCapture capture = ReadCapture(capture_path);
  const PoseMap gt = ReadBunConf(conf, Convention::kTransposed);
  if (check_gt) {
    CheckPoses(capture, gt, "p_world = R(q)^T p + t", overlap_m);
    CheckPoses(capture, ReadBunConf(conf, Convention::kDirect), "p_world = R(q) p + t", overlap_m);
    return 0;
  }

  RefineOptions options = LoadConfig(config);
  bench::SetMethod(method, &options.icp);
  std::printf(
      "%zu scans, method %s, config %s, every start pose perturbed by %.2f deg and %.1f mm "
      "(random axis and direction)\n\n",
      capture.cameras.size(), method.c_str(), config.c_str(), rotation_deg, translation_m * 1e3);
  std::printf(
      "| seed | start deg | start mm | start max mm | joint deg | joint mm | joint max mm | "
      "joint s | pairwise deg | pairwise mm | pairwise max mm | pairwise s |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  bench::ErrorSummary summary[3];
  for (int seed = 0; seed < seeds; ++seed) {
    const PoseMap init = bench::PerturbRig(gt, rotation_deg, translation_m, seed);
    RigErrors errors[3] = {EvaluateRig(init, gt)};
    double seconds[2] = {};
    std::vector<PairReport> reports;
    for (int m = 0; m < 2; ++m) {
      options.icp.mode = m == 0 ? RefineMode::kJoint : RefineMode::kPairwise;
      const auto start = std::chrono::steady_clock::now();
      options.threads = threads;
      const RefineResult result = Refine(capture, init, options);
      errors[m + 1] = EvaluateRig(result.refined, gt);
      seconds[m] = SecondsSince(start);
      if (m == 1) reports = result.pairs;
      if (pairs) PlaneFit(capture, result.refined, m == 0 ? "joint" : "pairwise", overlap_m);
    }
    if (pairs) {
      PlaneFit(capture, gt, "bun.conf", overlap_m);
      PrintPairs(errors[1], errors[2], reports);
    }
    for (int k = 0; k < 3; ++k) summary[k].Add(errors[k]);
    std::printf("| %d | %s | %s | %.1f | %s | %.1f |\n", seed, bench::ErrorCells(errors[0]).c_str(),
                bench::ErrorCells(errors[1]).c_str(), seconds[0],
                bench::ErrorCells(errors[2]).c_str(), seconds[1]);
  }
  std::printf("| RMS (max) | %s | %s | | %s | |\n", summary[0].Cells().c_str(),
              summary[1].Cells().c_str(), summary[2].Cells().c_str());
  return 0;
}

// Accuracy of `rigfit refine` on simulated rigs: per seed (and per draw of the pixel noise,
// --noise-draws), the gauge-free errors (relative poses of every camera pair, tilt of every
// camera) before and after, and the time per stage. Prints a table and a summary; runs in
// process (no file I/O), so the times are the solver's. Usage: rig_accuracy --help.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "analysis/crlb.h"
#include "analysis/face_finder.h"
#include "analysis/face_oracle.h"
#include "bench/bench_util.h"
#include "core/evaluate.h"
#include "core/format.h"
#include "core/geometry.h"
#include "core/stopwatch.h"
#include "io/config_yaml.h"
#include "prepare/region.h"
#include "registration/surface_bundle.h"
#include "rig/refine.h"
#include "sim/scene.h"
#include "sim/simulate_rig.h"

namespace {

/// The pixels of `cameras` (RigFacePixels of `capture`) farther than `px` pixels (a square
/// window) from every band pixel of another face or of none: what a segmentation that does not
/// know where faces meet to the pixel could use. Positions without a band pixel (outside the
/// image or the band, dropped pixels) are not looked at. A camera without pixels is kept whole.
std::vector<rigfit::FacePixels> AwayFromBoundaries(const std::vector<rigfit::FacePixels>& cameras,
                                                   const rigfit::RigCapture& capture, int px) {
  std::vector<rigfit::FacePixels> kept(cameras.size());
  for (size_t c = 0; c < cameras.size(); ++c) {
    const rigfit::CameraCapture& camera = capture.cameras[c];
    const rigfit::FacePixels& in = cameras[c];
    if (in.pixels.size() != in.points.size()) {
      kept[c] = in;
      continue;
    }
    constexpr int kNoPoint = -2;
    std::vector<int> face(static_cast<size_t>(camera.width) * camera.height, kNoPoint);
    for (size_t i = 0; i < in.pixels.size(); ++i) {
      face[static_cast<size_t>(in.pixels[i].y()) * camera.width + in.pixels[i].x()] = in.faces[i];
    }
    kept[c].serial = in.serial;
    for (size_t i = 0; i < in.pixels.size(); ++i) {
      const Eigen::Vector2i& q = in.pixels[i];
      bool inside = true;
      for (int v = q.y() - px; v <= q.y() + px && inside; ++v) {
        for (int u = q.x() - px; u <= q.x() + px && inside; ++u) {
          if (u < 0 || v < 0 || u >= camera.width || v >= camera.height) continue;
          const int f = face[static_cast<size_t>(v) * camera.width + u];
          inside = f == kNoPoint || f == in.faces[i];
        }
      }
      if (!inside) continue;
      kept[c].points.push_back(in.points[i]);
      kept[c].faces.push_back(in.faces[i]);
      kept[c].pixels.push_back(q);
    }
  }
  return kept;
}

/// Over the seeds: a reference's RMS errors (the bound, or the estimator's prediction) and
/// rigfit's errors divided by them.
struct AgainstReference {
  double r2 = 0.0, t2 = 0.0, tilt2 = 0.0, ratio_r2 = 0.0, ratio_t2 = 0.0;
  int seeds = 0;

  void Add(const rigfit::SampledErrors& reference, const rigfit::RigErrors& after) {
    r2 += reference.rotation_rad * reference.rotation_rad;
    t2 += reference.translation_m * reference.translation_m;
    tilt2 += reference.tilt_rad * reference.tilt_rad;
    ratio_r2 += std::pow(after.rms_rotation_rad / reference.rotation_rad, 2);
    ratio_t2 += std::pow(after.rms_translation_m / reference.translation_m, 2);
    ++seeds;
  }
  double RmsRotationDeg() const { return std::sqrt(r2 / seeds) * rigfit::kRadToDeg; }
  double RmsTranslationMm() const { return std::sqrt(t2 / seeds) * 1e3; }
  double RmsTiltDeg() const { return std::sqrt(tilt2 / seeds) * rigfit::kRadToDeg; }
  double RmsRatioRotation() const { return std::sqrt(ratio_r2 / seeds); }
  double RmsRatioTranslation() const { return std::sqrt(ratio_t2 / seeds); }
};

/// RMS over the runs of the face oracle's errors.
struct OracleSums {
  double r2 = 0.0, t2 = 0.0, tilt2 = 0.0;
  int runs = 0;
  void Add(const rigfit::RigErrors& e) {
    r2 += e.rms_rotation_rad * e.rms_rotation_rad;
    t2 += e.rms_translation_m * e.rms_translation_m;
    tilt2 += e.rms_tilt_rad * e.rms_tilt_rad;
    ++runs;
  }
  void Print(const char* what, const char* name) const {
    if (runs == 0) return;
    std::printf(
        "%s, %s: RMS relative rotation %.4f deg, RMS relative translation %.2f mm, "
        "RMS tilt %.4f deg over %d runs\n",
        what, name, std::sqrt(r2 / runs) * rigfit::kRadToDeg, std::sqrt(t2 / runs) * 1e3,
        std::sqrt(tilt2 / runs) * rigfit::kRadToDeg, runs);
  }
};

/// A run's noise-free twin: the same scene, cameras, dropout and noise model, ray-cast and
/// calibrated depth (with several draws, one per draw: their dropout differs), and every band
/// pixel of it (`region`) labelled with its face (analysis/crlb.h RigFacePixels). The bounds
/// (--crlb) and the face oracle (--face-oracle) share it.
struct NoiseFreeTwin {
  rigfit::SimulatedRig truth;
  std::vector<rigfit::PlanarFace> faces;
  std::vector<rigfit::FacePixels> pixels;
};

NoiseFreeTwin MakeNoiseFreeTwin(const rigfit::SimOptions& sim,
                                const rigfit::RegionOptions& region) {
  using namespace rigfit;
  SimOptions clean = sim;
  clean.noise = 0.0;
  clean.depth_model = DepthModel::kGaussian;
  clean.disparity_offset_px = 0.0;
  clean.depth_scale = 1.0;
  NoiseFreeTwin twin{SimulateRig(clean), {}, {}};
  const FaceLabeler labeler = [&](const Pose& T, const PointCloud& p, std::vector<PlanarFace>* f,
                                  std::vector<int>* l) {
    LabelFaces(twin.truth.scene, T, p, f, l);
  };
  twin.pixels = RigFacePixels(twin.truth.capture, twin.truth.gt, region, labeler, &twin.faces);
  return twin;
}

/// The face oracle of one run on `labels` (its twin's, --face-oracle, or a face finder's,
/// --face-finder) and their faces: solved from `start` (the reference at its true pose, the
/// gauge) with independent pixels and, with correlated noise, whitened; a line each, added to
/// the sums.
void RunFaceOracle(const rigfit::SimOptions& sim, const rigfit::SimulatedRig& rig,
                   const std::vector<rigfit::FacePixels>& labels,
                   const std::vector<rigfit::PlanarFace>& faces, const rigfit::PoseMap& start,
                   const std::string& reference, const char* what, OracleSums* white,
                   OracleSums* whitened) {
  using namespace rigfit;
  PoseMap oracle_start = start;
  oracle_start[reference] = rig.gt.at(reference);
  FaceOracleOptions options;
  options.depth_noise = sim.noise;
  const auto run = [&](const char* name, OracleSums* sums) {
    const FaceOracleResult o =
        SolveWithTrueFaces(rig.capture, labels, faces, oracle_start, reference, options);
    const RigErrors e = EvaluateRig(o.poses, rig.gt);
    std::printf("       %s, %s: %.4f deg %.2f mm tilt %.4f deg (%d pixels, %d gated)%s\n", what,
                name, e.rms_rotation_rad * kRadToDeg, e.rms_translation_m * 1e3,
                e.rms_tilt_rad * kRadToDeg, o.pixels, o.gated, o.ok ? "" : " failed");
    sums->Add(e);
  };
  run("independent pixels", white);
  if (sim.noise_corr_share > 0.0) {
    options.correlated = {sim.noise_corr_px, sim.noise_corr_share};
    run("whitened", whitened);
  }
}

/// The true labels of `twin` on the pixels `found` labels (its selection, the truth's labels).
std::vector<rigfit::FacePixels> TruthOnPixels(const NoiseFreeTwin& twin,
                                              const rigfit::FoundFaces& found) {
  std::vector<rigfit::FacePixels> out(twin.pixels.size());
  for (size_t c = 0; c < twin.pixels.size(); ++c) {
    std::set<std::pair<int, int>> chosen;
    for (const Eigen::Vector2i& q : found.cameras[c].pixels) chosen.emplace(q.x(), q.y());
    const rigfit::FacePixels& in = twin.pixels[c];
    out[c].serial = in.serial;
    for (size_t k = 0; k < in.pixels.size(); ++k) {
      if (!chosen.count({in.pixels[k].x(), in.pixels[k].y()})) continue;
      out[c].points.push_back(in.points[k]);
      out[c].faces.push_back(in.faces[k]);
      out[c].pixels.push_back(in.pixels[k]);
    }
  }
  return out;
}

/// `truth` (TruthOnPixels) with each true face split where `found` splits it: a face per
/// (true face, found face) pair, the true plane; `faces` receives them.
std::vector<rigfit::FacePixels> TruthSplitAsFound(std::vector<rigfit::FacePixels> truth,
                                                  const NoiseFreeTwin& twin,
                                                  const rigfit::FoundFaces& found,
                                                  std::vector<rigfit::PlanarFace>* faces) {
  std::map<std::pair<int, int>, int> pair_face;
  for (size_t c = 0; c < truth.size(); ++c) {
    std::map<std::pair<int, int>, int> found_label;
    for (size_t k = 0; k < found.cameras[c].pixels.size(); ++k) {
      const Eigen::Vector2i& q = found.cameras[c].pixels[k];
      found_label[{q.x(), q.y()}] = found.cameras[c].faces[k];
    }
    for (size_t k = 0; k < truth[c].pixels.size(); ++k) {
      int& t = truth[c].faces[k];
      if (t < 0) continue;
      const Eigen::Vector2i& q = truth[c].pixels[k];
      const auto key = std::make_pair(t, found_label.at({q.x(), q.y()}));
      const auto [it, added] = pair_face.emplace(key, static_cast<int>(faces->size()));
      if (added) faces->push_back(twin.faces[t]);
      t = it->second;
    }
  }
  return truth;
}

/// The face oracle's sums of --face-finder: the finder's faces, the truth on its pixels, the
/// truth split as it splits the faces.
struct FinderTally {
  OracleSums found_white, found_whitened, pixels_white, pixels_whitened, split_white,
      split_whitened;
  void Print() const {
    found_white.Print("face finder", "independent pixels");
    found_whitened.Print("face finder", "whitened");
    pixels_white.Print("true faces on the finder's pixels", "independent pixels");
    pixels_whitened.Print("true faces on the finder's pixels", "whitened");
    split_white.Print("true faces split as the finder's", "independent pixels");
    split_whitened.Print("true faces split as the finder's", "whitened");
  }
};

/// The face finder of one run (--face-finder): its faces at the default's result (in the
/// truth's gauge: the reference at its true pose), solved by the face oracle's estimator from
/// there; then, from the same poses, the true faces on the finder's pixels and split as the
/// finder splits them.
void RunFaceFinder(const rigfit::SimOptions& sim, const rigfit::SimulatedRig& rig,
                   const NoiseFreeTwin& twin, const rigfit::RefineResult& r,
                   const rigfit::RegionOptions& region, FinderTally* tally) {
  using namespace rigfit;
  const Pose gauge = rig.gt.at(r.reference) * r.refined.at(r.reference).inverse();
  PoseMap at_result;
  for (const auto& [serial, T] : r.refined) at_result[serial] = gauge * T;
  FaceFinderOptions finder;
  finder.depth_noise = sim.noise;
  const FoundFaces found = FindFaces(rig.capture, at_result, region, finder);
  std::printf("       face finder: %d faces (%d in the cameras' images)\n",
              static_cast<int>(found.faces.size()), found.camera_faces);
  RunFaceOracle(sim, rig, found.cameras, found.faces, at_result, r.reference, "face finder",
                &tally->found_white, &tally->found_whitened);
  const std::vector<FacePixels> truth = TruthOnPixels(twin, found);
  RunFaceOracle(sim, rig, truth, twin.faces, at_result, r.reference,
                "true faces on the finder's pixels", &tally->pixels_white, &tally->pixels_whitened);
  std::vector<PlanarFace> split_faces;
  const std::vector<FacePixels> split = TruthSplitAsFound(truth, twin, found, &split_faces);
  RunFaceOracle(sim, rig, split, split_faces, at_result, r.reference,
                "true faces split as the finder's", &tally->split_white, &tally->split_whitened);
}

/// Bias against variance over draws of the pixel noise: per seed and camera pair, the
/// relative pose errors (RelativeErrorPose, as rotation vector and translation) of every
/// draw. The bias of a pair is the mean error over its draws; its square, less the variance /
/// draws that any finite mean carries, is the bias part of the pair's mean squared error.
/// The shares sum both parts over every seed and pair before dividing.
class BiasSplit {
 public:
  void Add(int seed, const rigfit::PairError& pair, const rigfit::Pose& err) {
    Draws& d = draws_[{seed, pair.serial_i, pair.serial_j}];
    const rigfit::Vec3 r = rigfit::LogSO3(err.linear());
    const rigfit::Vec3& t = err.translation();
    d.r_sum += r;
    d.t_sum += t;
    d.r2 += r.squaredNorm();
    d.t2 += t.squaredNorm();
    ++d.n;
  }

  /// Bias share of the mean squared error over all pairs: {rotation, translation}.
  std::pair<double, double> Shares() const {
    double r_bias = 0, r_mse = 0, t_bias = 0, t_mse = 0;
    for (const auto& [key, d] : draws_) {
      if (d.n < 2) continue;
      const auto bias2 = [&](const rigfit::Vec3& sum, double sum2) {
        const double mean2 = (sum / d.n).squaredNorm();
        const double variance = (sum2 / d.n - mean2) * d.n / (d.n - 1);
        return mean2 - variance / d.n;
      };
      r_bias += bias2(d.r_sum, d.r2);
      t_bias += bias2(d.t_sum, d.t2);
      r_mse += d.r2 / d.n;
      t_mse += d.t2 / d.n;
    }
    return {r_bias / r_mse, t_bias / t_mse};
  }

 private:
  struct Draws {
    rigfit::Vec3 r_sum = rigfit::Vec3::Zero(), t_sum = rigfit::Vec3::Zero();
    double r2 = 0.0, t2 = 0.0;
    int n = 0;
  };
  std::map<std::tuple<int, std::string, std::string>, Draws> draws_;
};

/// The surface bundle's depth models (icp.depth_model) against the simulated miscalibration:
/// a line per camera, and the offsets' error in pixels of disparity over the runs.
class DepthModelTally {
 public:
  void Observe(const rigfit::RefineResult& result, const rigfit::SimulatedRig& rig,
               const rigfit::SimOptions& sim) {
    for (size_t i = 0; i < result.cameras.size(); ++i) {
      const rigfit::DepthModelEstimate& d = result.cameras[i].depth_model;
      if (!(d.offset_prior_sigma > 0.0)) continue;
      const std::vector<int>& wrong = sim.miscalibrated_cameras;
      const bool miscalibrated =
          sim.disparity_offset_px != 0.0 &&
          (wrong.empty() ? i != 0 : std::count(wrong.begin(), wrong.end(), int(i)) > 0);
      const double truth = miscalibrated ? -sim.disparity_offset_px : 0.0;  // the correction
      const double px = rig.capture.cameras[i].intrinsics.fx * sim.stereo_baseline_m;
      std::printf(
          "       depth model %s: %s, scale %.4f, offset %.3f px (1-sigma %.3f, truth "
          "%.3f), correlation with the pose %.2f\n",
          result.cameras[i].serial.c_str(), d.solved ? "solved" : "not observable", d.scale,
          d.offset * px, d.offset_sigma * px, truth, d.pose_correlation);
      (miscalibrated ? wrong_ : right_).Add(d.offset * px - truth);
      unobservable_ += d.solved ? 0 : 1;
    }
  }
  void Print() const {
    if (right_.n + wrong_.n == 0) return;
    std::printf(
        "depth model offsets against the truth, px: miscalibrated cameras mean %.3f RMS "
        "%.3f (%d), the others mean %.3f RMS %.3f (%d); not observable: %d\n",
        wrong_.Mean(), wrong_.Rms(), wrong_.n, right_.Mean(), right_.Rms(), right_.n,
        unobservable_);
  }

 private:
  struct Errors {
    double sum = 0.0, sum2 = 0.0;
    int n = 0;
    void Add(double e) { sum += e, sum2 += e * e, ++n; }
    double Mean() const { return n > 0 ? sum / n : 0.0; }
    double Rms() const { return n > 0 ? std::sqrt(sum2 / n) : 0.0; }
  };
  Errors right_, wrong_;
  int unobservable_ = 0;
};

/// The surface bundle's segmentation against the simulator's truth (--segmentation): which of
/// the bound's pixels (every band pixel at the true pose on a face two cameras see,
/// analysis/crlb.h RigFacePixels) the bundle's last round used, on the right face or not,
/// the bound of the pixels it used and of every pixel of the faces it used, and the missed face
/// that alone would lower the first most.
class SegmentationDiagnostic {
 public:
  /// The bundle's planes and pixels of one Refine (icp.keep_surface_diagnostics) and the
  /// cameras that kept their joint pose.
  rigfit::SurfaceBundleReport bundle;
  std::vector<bool> fallback;
  bool seen = false;

  /// Takes the surface bundle's report of a Refine run with icp.keep_surface_diagnostics.
  void Observe(const rigfit::RefineResult& result) {
    bundle = result.surface;
    fallback.clear();
    for (const rigfit::CameraReport& c : result.cameras) fallback.push_back(c.surface_fallback);
    seen = bundle.ran;
  }

  /// Compares the observed run with the truth and prints a line per camera; returns the
  /// bounds of the used pixels (true faces; and one nuisance plane per bundle plane).
  void Compare(const rigfit::SimulatedRig& truth, const rigfit::RefineOptions& options,
               const std::string& reference, double noise, std::uint64_t seed,
               const rigfit::RigErrors& after, const rigfit::SampledErrors& full) {
    using namespace rigfit;
    if (!seen) {
      std::printf("       segmentation: the surface bundle did not run\n");
      return;
    }
    const size_t n = truth.capture.cameras.size();
    RegionOptions every_pixel = options.region;
    every_pixel.pixel_stride = 1;
    RegionOptions no_band = every_pixel;
    no_band.band_height = 0.0;
    std::vector<PlanarFace> faces;
    // Per camera: pixel key -> (true face, noise-free point), and the bound's band keys.
    std::vector<std::map<long long, std::pair<int, Vec3>>> label(n);
    std::vector<std::set<long long>> band(n);
    std::vector<PinholeIntrinsics> K(n);
    const auto key = [](const PinholeIntrinsics& k, const Vec3& p) {
      const Eigen::Vector2i q = PixelOf(k, p);
      return q.y() * 100000LL + q.x();
    };
    for (size_t c = 0; c < n; ++c) {
      const CameraCapture& camera = truth.capture.cameras[c];
      K[c] = camera.intrinsics;
      const Pose& T = truth.gt.at(camera.serial);
      const PointCloud all = RegistrationPoints(camera, no_band);
      std::vector<int> labels;
      LabelFaces(truth.scene, T, all, &faces, &labels);
      for (size_t i = 0; i < all.size(); ++i) label[c][key(K[c], all[i])] = {labels[i], all[i]};
      for (const Vec3& p :
           NearFloorBand(RegistrationPoints(camera, every_pixel), T, options.region))
        band[c].insert(key(K[c], p));
    }
    // The bound's faces and pixels (BoundFaces, the rule of ComputeSurfaceCramerRaoBound).
    std::vector<FacePixels> band_faces(n);
    for (size_t c = 0; c < n; ++c) {
      for (const long long k : band[c]) band_faces[c].faces.push_back(label[c].at(k).first);
    }
    const BoundFaces bound_faces(band_faces, faces.size());
    const auto in_bound = [&](size_t c, int f) { return bound_faces.Counts(c, f); };
    // The true face of each bundle plane: the most frequent label of its pixels.
    const size_t planes = bundle.plane_list.size();
    std::vector<std::map<int, int>> votes(planes);
    for (const SurfaceTerm& t : bundle.terms) {
      for (const int i : t.pixels) {
        const auto it = label[t.camera].find(key(K[t.camera], bundle.points[t.camera][i]));
        ++votes[t.plane][it == label[t.camera].end() ? -1 : it->second.first];
      }
    }
    std::vector<int> face_of(planes, -1);
    for (size_t j = 0; j < planes; ++j) {
      int best = 0;
      for (const auto& [f, v] : votes[j]) {
        if (v > best) best = v, face_of[j] = f;
      }
    }
    std::vector<long long> bound_px(n, 0), ok(n, 0), wrong(n, 0), outside(n, 0);
    std::vector<long long> face_bound(faces.size(), 0), face_ok(faces.size(), 0);
    for (size_t c = 0; c < n; ++c) {
      for (const long long k : band[c]) {
        const int f = label[c].at(k).first;
        if (in_bound(c, f)) ++bound_px[c], ++face_bound[f];
      }
    }
    std::vector<FacePixels> used_true(n), used_split(n);
    std::vector<long long> wrong_floor(n, 0);
    std::vector<PlanarFace> split_faces(planes);
    for (size_t j = 0; j < planes; ++j) {
      if (face_of[j] >= 0) split_faces[j] = faces[face_of[j]];
    }
    for (size_t c = 0; c < n; ++c) {
      used_true[c].serial = used_split[c].serial = truth.capture.cameras[c].serial;
    }
    for (const SurfaceTerm& t : bundle.terms) {
      const size_t c = t.camera;
      for (const int i : t.pixels) {
        const long long k = key(K[c], bundle.points[c][i]);
        const auto it = label[c].find(k);
        const int f = it == label[c].end() ? -1 : it->second.first;
        if (f < 0 || f != face_of[t.plane]) {
          ++wrong[c];
          if (bundle.plane_list[t.plane].floor) ++wrong_floor[c];
          continue;
        }
        if (band[c].count(k) && in_bound(c, f)) {
          ++ok[c], ++face_ok[f];
        } else {
          ++outside[c];
        }
        used_true[c].points.push_back(it->second.second);
        used_true[c].faces.push_back(f);
        used_split[c].points.push_back(it->second.second);
        used_split[c].faces.push_back(t.plane);
      }
    }
    int fallbacks = 0;
    for (size_t c = 0; c < n; ++c) {
      const bool fell = c < fallback.size() && fallback[c];
      fallbacks += fell ? 1 : 0;
      std::printf(
          "       camera %zu: bound %lld px, used on the right face %lld (%.0f%%), outside "
          "the bound's band %lld, wrong face %lld (on the floor plane %lld)%s\n",
          c, bound_px[c], ok[c], 100.0 * ok[c] / std::max(bound_px[c], 1LL), outside[c], wrong[c],
          wrong_floor[c], fell ? ", FELL BACK" : "");
      total_bound += bound_px[c], total_ok += ok[c], total_wrong += wrong[c];
      total_outside += outside[c];
    }
    int missed = 0, faces_in_bound = 0;
    long long missed_px = 0, floor_bound = 0, floor_ok = 0;
    std::string face_text;
    for (size_t f = 0; f < faces.size(); ++f) {
      if (face_bound[f] == 0) continue;
      ++faces_in_bound;
      if (faces[f].floor) floor_bound += face_bound[f], floor_ok += face_ok[f];
      if (face_ok[f] == 0) ++missed, missed_px += face_bound[f];
      if (!faces[f].floor) {
        char buffer[64];
        std::snprintf(buffer, sizeof buffer, " %lld/%lld", face_ok[f], face_bound[f]);
        face_text += buffer;
      }
    }
    std::printf(
        "       faces: %d in the bound, %d missed (%lld px); floor %lld/%lld used; others "
        "used/bound:%s; %zu bundle planes; %d cameras fell back\n",
        faces_in_bound, missed, missed_px, floor_ok, floor_bound, face_text.c_str(), planes,
        fallbacks);
    total_faces += faces_in_bound, total_missed += missed, total_fallbacks += fallbacks;
    total_floor_bound += floor_bound, total_floor_ok += floor_ok;
    const CramerRaoBound b1 =
        ComputeSurfaceCramerRaoBound(used_true, faces, truth.gt, reference, {noise}, {2000, seed});
    const CramerRaoBound b2 = ComputeSurfaceCramerRaoBound(used_split, split_faces, truth.gt,
                                                           reference, {noise}, {2000, seed});
    const auto show = [&](const char* what, const CramerRaoBound& b, RatioSums* sums) {
      if (!b.ok) {
        std::printf("       bound of %s: not available: %s\n", what, b.message.c_str());
        return;
      }
      std::printf(
          "       bound of %s: %.4f deg %.2f mm tilt %.4f deg (x%.2f x%.2f the full bound); "
          "error / it: %.2f %.2f\n",
          what, b.rms.rotation_rad * kRadToDeg, b.rms.translation_m * 1e3,
          b.rms.tilt_rad * kRadToDeg, b.rms.rotation_rad / full.rotation_rad,
          b.rms.translation_m / full.translation_m, after.rms_rotation_rad / b.rms.rotation_rad,
          after.rms_translation_m / b.rms.translation_m);
      sums->error_rotation2 += std::pow(after.rms_rotation_rad / b.rms.rotation_rad, 2);
      sums->error_translation2 += std::pow(after.rms_translation_m / b.rms.translation_m, 2);
      sums->bound_translation2 += std::pow(b.rms.translation_m / full.translation_m, 2);
      ++sums->runs;
    };
    show("the used pixels (true faces)", b1, &used_true_sums);
    show("the used pixels (a plane per bundle plane)", b2, &used_split_sums);
    // Where the used pixels' bound loses against the full one: every bound pixel of the faces
    // the bundle used (what is left is what the faces it missed cost), and the missed face
    // that alone would lower the used pixels' bound most.
    const auto face_pixels = [&](const auto& take) {
      std::vector<FacePixels> pixels(n);
      for (size_t c = 0; c < n; ++c) {
        pixels[c].serial = truth.capture.cameras[c].serial;
        for (const long long k : band[c]) {
          const auto& [f, p] = label[c].at(k);
          if (in_bound(c, f) && take(f)) {
            pixels[c].points.push_back(p);
            pixels[c].faces.push_back(f);
          }
        }
      }
      return pixels;
    };
    const CramerRaoBound b3 =
        ComputeSurfaceCramerRaoBound(face_pixels([&](int f) { return face_ok[f] > 0; }), faces,
                                     truth.gt, reference, {noise}, {2000, seed});
    show("every pixel of the faces it used", b3, &used_faces_sums);
    int best = -1;
    double best_translation = b1.ok ? b1.rms.translation_m : 0.0;
    for (size_t g = 0; b1.ok && g < faces.size(); ++g) {
      if (face_ok[g] > 0 || faces[g].floor || face_bound[g] == 0) continue;
      std::vector<FacePixels> plus = used_true;
      const std::vector<FacePixels> extra =
          face_pixels([&](int f) { return f == static_cast<int>(g); });
      for (size_t c = 0; c < n; ++c) {
        plus[c].points.insert(plus[c].points.end(), extra[c].points.begin(), extra[c].points.end());
        plus[c].faces.insert(plus[c].faces.end(), extra[c].faces.begin(), extra[c].faces.end());
      }
      const CramerRaoBound b =
          ComputeSurfaceCramerRaoBound(plus, faces, truth.gt, reference, {noise}, {2000, seed});
      if (b.ok && b.rms.translation_m < best_translation) {
        best_translation = b.rms.translation_m;
        best = static_cast<int>(g);
      }
    }
    if (best >= 0) {
      const std::vector<FacePixels> pixels = face_pixels([&](int f) { return f == best; });
      std::string per_camera;
      for (size_t c = 0; c < n; ++c) {
        per_camera += (c ? "/" : "") + std::to_string(pixels[c].points.size());
      }
      const Vec3& normal = faces[best].normal;
      std::printf(
          "       the missed face that would help most: normal (%.2f %.2f %.2f), offset %.3f m, "
          "%s px per camera: the used pixels' bound x%.2f -> x%.2f the full bound\n",
          normal.x(), normal.y(), normal.z(), faces[best].offset, per_camera.c_str(),
          b1.rms.translation_m / full.translation_m, best_translation / full.translation_m);
    }
  }

  void Summary() const {
    if (total_bound == 0) return;
    std::printf(
        "segmentation: the bundle used %.1f%% of the bound's pixels on the right face (floor "
        "%.1f%%, other faces %.1f%%), %.2f%% of its pixels on a wrong face, %lld right-face "
        "pixels outside the bound's band; %d of %d faces missed; %d camera fallbacks\n",
        100.0 * total_ok / total_bound, 100.0 * total_floor_ok / total_floor_bound,
        100.0 * (total_ok - total_floor_ok) / (total_bound - total_floor_bound),
        100.0 * total_wrong / (total_ok + total_wrong + total_outside), total_outside, total_missed,
        total_faces, total_fallbacks);
    const auto line = [](const char* what, const RatioSums& sums) {
      if (sums.runs == 0) return;
      std::printf(
          "bound of %s, over %d runs: RMS bound / full bound %.2f translation, RMS error / it "
          "%.2f rotation %.2f translation\n",
          what, sums.runs, std::sqrt(sums.bound_translation2 / sums.runs),
          std::sqrt(sums.error_rotation2 / sums.runs),
          std::sqrt(sums.error_translation2 / sums.runs));
    };
    line("the used pixels (true faces)", used_true_sums);
    line("the used pixels (a plane per bundle plane)", used_split_sums);
    line("every pixel of the faces it used (what is left to the full bound: the faces it missed)",
         used_faces_sums);
  }

 private:
  /// Sums over the runs of the squared ratios that a bound's line prints.
  struct RatioSums {
    double error_rotation2 = 0.0, error_translation2 = 0.0, bound_translation2 = 0.0;
    int runs = 0;
  };
  long long total_bound = 0, total_ok = 0, total_wrong = 0, total_outside = 0;
  long long total_floor_bound = 0, total_floor_ok = 0;
  int total_faces = 0, total_missed = 0, total_fallbacks = 0;
  RatioSums used_true_sums, used_split_sums, used_faces_sums;
};

}  // namespace

int main(int argc, char** argv) {
  using namespace rigfit;
  CLI::App app{"Accuracy of rigfit refine on simulated rigs"};
  SimOptions sim;
  RefineOptions options;
  int first_seed = 0, seeds = 10, threads = 2;
  std::string mode = "joint", method = "point_to_plane";
  app.add_option("--first-seed", first_seed);
  app.add_option("--seeds", seeds, "number of seeds");
  app.add_option("--cameras", sim.cameras);
  app.add_option("--width", sim.width);
  app.add_option("--height", sim.height);
  app.add_option("--noise", sim.noise);
  app.add_option("--perturb-yaw-deg", sim.perturb_yaw_deg);
  app.add_option("--perturb-xz-m", sim.perturb_xz_m);
  app.add_option("--perturb-tilt-deg", sim.perturb_tilt_deg);
  app.add_flag("--bare", sim.bare);
  app.add_option("--noise-corr-px", sim.noise_corr_px,
                 "correlation length of the noise's smooth share");
  app.add_option("--noise-corr-share", sim.noise_corr_share,
                 "share of the noise variance that is correlated");
  app.add_option("--disparity-quant-px", sim.disparity_quant_px,
                 "disparity quantisation step, pixels");
  std::string depth_model = "gaussian";
  app.add_option("--depth-model", depth_model, "gaussian or stereo (rigfit simulate's)")
      ->check(CLI::IsMember({"gaussian", "stereo"}));
  app.add_option("--stereo-upsample", sim.stereo_upsample, "stereo: matched at this resolution");
  app.add_option("--stereo-baseline-m", sim.stereo_baseline_m);
  app.add_option("--disparity-offset-px", sim.disparity_offset_px, "miscalibration");
  app.add_option("--depth-scale", sim.depth_scale, "miscalibration");
  app.add_option("--miscalibrated-cameras", sim.miscalibrated_cameras,
                 "indices; default every camera but 0")
      ->delimiter(',');
  int edge_margin_px = 0;
  app.add_option("--edge-margin-px", edge_margin_px,
                 "leave out depth pixels within N px of a depth jump or a hole rim "
                 "(RegionOptions::edge_margin_px)");
  app.add_option("--mode", mode)->check(CLI::IsMember({"joint", "pairwise"}));
  app.add_option("--method", method)
      ->check(CLI::IsMember({"point_to_plane", "gicp", "surface_bundle"}));
  app.add_option("--threads", threads);
  int noise_draws = 1;
  app.add_option("--noise-draws", noise_draws,
                 "runs per seed, each with another draw of the pixel noise and dropout (same "
                 "scene, cameras and start; draw 0 is the seed's own); more than 1 also splits "
                 "the mean squared error into bias and variance")
      ->check(CLI::PositiveNumber);
  std::string config;
  app.add_option("--config", config, "refine options (YAML); --mode and --method override");
  bool verbose = false, from_gt = false, verbose_sigma = false, crlb = false;
  bool segmentation = false;
  app.add_flag("--segmentation", segmentation,
               "with --crlb and --method surface_bundle: the bundle's pixels against the "
               "simulator's faces, the bound of the pixels it used and of every pixel of the "
               "faces it used, and the missed face that would lower the first most");
  std::vector<int> boundary_px;
  app.add_option("--bound-boundary-px", boundary_px,
                 "with --crlb and --noise-corr-share: also the correlated-noise bound without the "
                 "band pixels within N px of a band pixel of another face or of none (one bound "
                 "per N)")
      ->check(CLI::NonNegativeNumber);
  app.add_flag("--crlb", crlb,
               "also the Cramer-Rao bound of each seed (analysis/crlb.h) and RMS of error / bound");
  bool face_oracle = false, face_finder = false;
  app.add_flag("--face-oracle", face_oracle,
               "also the face oracle (analysis/face_oracle.h): poses and faces solved from the "
               "start with each pixel's true face, independent pixels and, with "
               "--noise-corr-share, whitened by the true correlation");
  app.add_flag("--face-finder", face_finder,
               "also the face oracle's estimator on the faces of the image face finder "
               "(analysis/face_finder.h) at the default's result, and on the true faces with "
               "the finder's pixels and split where the finder splits them");
  app.add_flag("--sigma", verbose_sigma, "print each camera's error and predicted 1-sigma");
  app.add_flag("--from-gt", from_gt, "start at the true poses (measures the estimator's bias)");
  app.add_flag("--verbose", verbose, "solver progress to stderr");
  CLI11_PARSE(app, argc, argv);
  sim.depth_model = depth_model == "stereo" ? DepthModel::kStereo : DepthModel::kGaussian;
  try {
    CheckSimOptions(sim);
  } catch (const SettingError& e) {
    std::cerr << "rig_accuracy: " << e.Spelled(SettingError::Flag) << "\n";
    return 2;
  }
  if (!config.empty()) options = LoadConfig(config);
  options.icp.mode = mode == "joint" ? RefineMode::kJoint : RefineMode::kPairwise;
  if (edge_margin_px > 0) options.region.edge_margin_px = edge_margin_px;
  bench::SetMethod(method, &options.icp);
  options.icp.keep_surface_diagnostics = segmentation;

  std::printf("mode %s, method %s, %d cameras %dx%d, noise %g, perturbation %g deg %g m%s\n",
              mode.c_str(), method.c_str(), sim.cameras, sim.width, sim.height, sim.noise,
              sim.perturb_yaw_deg, sim.perturb_xz_m, sim.bare ? ", bare" : "");
  if (sim.depth_model == DepthModel::kStereo) {
    std::printf("depth model stereo (noise unused), baseline %g m, matched at %dx\n",
                sim.stereo_baseline_m, sim.stereo_upsample);
  }
  if (sim.disparity_offset_px != 0.0 || sim.depth_scale != 1.0) {
    std::printf("miscalibration: disparity offset %g px, depth scale %g\n", sim.disparity_offset_px,
                sim.depth_scale);
  }
  // With several draws a row is "seed:draw".
  const int seed_width = noise_draws > 1 ? 7 : 4;
  std::printf("%*s | %8s %8s %7s | %8s %8s %7s %8s | %6s %6s %6s | %s\n", seed_width, "seed",
              "rot deg", "trans mm", "tilt", "rot deg", "trans mm", "tilt", "max mm", "level",
              "prep", "solve", "result");
  double sum_r2 = 0, sum_t2 = 0, sum_tilt2 = 0, worst_t = 0;
  AgainstReference bound, estimator, surface, correlated_surface;
  std::map<int, AgainstReference> away_from_boundaries;  // --bound-boundary-px
  int runs_with_weak = 0;
  int worse_rotation = 0, worse_translation = 0;
  double simulate_s = 0.0;
  int pairs = 0, cameras = 0, failures = 0, normalised = 0;
  double sum_nr2 = 0, sum_nt2 = 0, sum_model_nr2 = 0, sum_model_nt2 = 0;
  int few_surfaces = 0;
  OracleSums oracle_white, oracle_whitened;
  FinderTally finder_tally;
  BiasSplit bias;
  SegmentationDiagnostic diagnostic;
  DepthModelTally depth_models;
  // Every seed's draws in turn: run k is draw k % noise_draws of seed first_seed + k / noise_draws.
  const int runs = seeds * noise_draws;
  for (int run = 0; run < runs; ++run) {
    const int seed = first_seed + run / noise_draws;
    const int draw = run % noise_draws;
    sim.seed = static_cast<std::uint64_t>(seed);
    sim.noise_draw = static_cast<std::uint64_t>(draw);
    const std::string label =
        std::to_string(seed) + (noise_draws > 1 ? ":" + std::to_string(draw) : "");
    const auto simulate_start = std::chrono::steady_clock::now();
    const SimulatedRig rig = SimulateRig(sim);
    simulate_s += SecondsSince(simulate_start);
    Log log;
    if (verbose) {
      log.sink = [](LogLevel, const std::string& m) { std::fprintf(stderr, "%s\n", m.c_str()); };
    }
    const PoseMap& start = from_gt ? rig.gt : rig.init;
    options.threads = threads;
    const RefineResult r = Refine(rig.capture, start, options, log);
    diagnostic.Observe(r);
    const RigErrors before = EvaluateRig(start, rig.gt);
    const RigErrors after = EvaluateRig(r.refined, rig.gt);
    std::printf("%*s | %8.3f %8.2f %7.3f | %8.4f %8.2f %7.4f %8.2f | %6.3f %6.3f %6.3f | %s\n",
                seed_width, label.c_str(), before.rms_rotation_rad * kRadToDeg,
                before.rms_translation_m * 1e3, before.rms_tilt_rad * kRadToDeg,
                after.rms_rotation_rad * kRadToDeg, after.rms_translation_m * 1e3,
                after.rms_tilt_rad * kRadToDeg, after.max_translation_m * 1e3, r.times.leveling_s,
                r.times.preprocessing_s, r.times.registration_s + r.times.pose_graph_s,
                r.success ? "ok" : r.message.c_str());
    failures += r.success ? 0 : 1;
    depth_models.Observe(r, rig, sim);
    worse_rotation += after.rms_rotation_rad > before.rms_rotation_rad ? 1 : 0;
    worse_translation += after.rms_translation_m > before.rms_translation_m ? 1 : 0;
    int weak = 0;
    for (const CameraReport& c : r.cameras) weak += static_cast<int>(c.weak_directions.size());
    runs_with_weak += weak > 0 ? 1 : 0;
    if (weak > 0) std::printf("       %d weakly constrained directions\n", weak);
    std::optional<NoiseFreeTwin> twin;
    if (crlb || face_oracle || face_finder) twin = MakeNoiseFreeTwin(sim, options.region);
    if (face_oracle) {
      RunFaceOracle(sim, rig, twin->pixels, twin->faces, start, r.reference, "face oracle",
                    &oracle_white, &oracle_whitened);
    }
    if (face_finder) RunFaceFinder(sim, rig, *twin, r, options.region, &finder_tally);
    if (crlb) {
      // The bound of this run's rig, on its noise-free twin.
      const SimulatedRig& truth = twin->truth;
      RefineOptions bound_options = options;
      bound_options.icp.reference = r.reference;
      const CramerRaoBound b =
          ComputeCramerRaoBound(truth.capture, truth.gt, bound_options, sim.noise,
                                kCramerRaoNoiseFloorM, {2000, sim.seed, threads});
      // Prints a bound's line for this run ("error / it": this run's error over the bound's)
      // and adds it to its summary.
      const auto report = [&](const char* name, const SampledErrors& e, AgainstReference* sum) {
        std::printf("       %s: %.4f deg %.2f mm tilt %.4f deg; error / it: %.2f %.2f\n", name,
                    e.rotation_rad * kRadToDeg, e.translation_m * 1e3, e.tilt_rad * kRadToDeg,
                    after.rms_rotation_rad / e.rotation_rad,
                    after.rms_translation_m / e.translation_m);
        sum->Add(e, after);
      };
      // The band's pixels and faces, labelled once for the white and the correlated bounds.
      const std::vector<PlanarFace>& faces = twin->faces;
      const std::vector<FacePixels>& pixels = twin->pixels;
      const CramerRaoBound s = ComputeSurfaceCramerRaoBound(pixels, faces, truth.gt, r.reference,
                                                            {sim.noise}, {2000, sim.seed});
      if (s.ok) {
        report(sim.noise_corr_share > 0.0 ? "surface-model bound, white noise of that sigma"
                                          : "surface-model bound",
               s.rms, &surface);
        if (segmentation) {
          diagnostic.Compare(truth, bound_options, r.reference, sim.noise, sim.seed, after, s.rms);
        }
      } else {
        std::printf("       surface-model bound: not available: %s\n", s.message.c_str());
      }
      if (sim.noise_corr_share > 0.0) {
        const auto correlated_bound = [&](const std::vector<FacePixels>& cameras,
                                          const std::string& name, AgainstReference* sum) {
          const CramerRaoBound c = ComputeSurfaceCramerRaoBound(
              cameras, faces, truth.gt, r.reference,
              {sim.noise, {sim.noise_corr_px, sim.noise_corr_share}}, {2000, sim.seed, threads});
          if (c.ok) {
            report(name.c_str(), c.rms, sum);
          } else {
            std::printf("       %s: not available: %s\n", name.c_str(), c.message.c_str());
          }
        };
        correlated_bound(pixels, "correlated-noise surface bound", &correlated_surface);
        size_t all = 0;
        for (const FacePixels& c : pixels) all += c.points.size();
        for (const int px : boundary_px) {
          const std::vector<FacePixels> away = AwayFromBoundaries(pixels, truth.capture, px);
          size_t kept = 0;
          for (const FacePixels& c : away) kept += c.points.size();
          correlated_bound(away,
                           "correlated-noise surface bound without the pixels within " +
                               std::to_string(px) + " px of another face (" +
                               Fixed(100.0 * kept / std::max<size_t>(all, 1), 1) +
                               "% of the band's pixels kept)",
                           &away_from_boundaries[px]);
        }
      }
      if (b.ok) {
        report("point-to-plane information bound", b.rms, &bound);
        if (b.estimator_ok) {
          report("estimator under shared point noise", b.estimator_rms, &estimator);
        }
      } else {
        std::printf("       bound: not available: %s\n", b.message.c_str());
      }
    }
    // Errors of each camera relative to the reference against the predicted 1-sigma (joint
    // mode): a reference that does not move makes its covariance that of T_ref^-1 T_i.
    for (const CameraReport& c : r.cameras) {
      if (!c.has_covariance) continue;
      const Pose& ref_est = r.refined.at(r.reference);
      const Pose& ref_gt = rig.gt.at(r.reference);
      const RelativePoseError e =
          RelativeError(ref_est, r.refined.at(c.serial), ref_gt, rig.gt.at(c.serial));
      const double sigma_r = std::sqrt(c.covariance.topLeftCorner<3, 3>().trace());
      const double sigma_t = std::sqrt(c.covariance.bottomRightCorner<3, 3>().trace());
      if (verbose_sigma) {
        std::printf(
            "       %s: error %.4f deg %.2f mm, predicted %.4f deg %.2f mm (inflation %.2f %.2f, "
            "%d surface orientations)\n",
            c.serial.c_str(), e.rotation_rad * kRadToDeg, e.translation_m * 1e3,
            sigma_r * kRadToDeg, sigma_t * 1e3, c.sigma_inflation.rotation,
            c.sigma_inflation.translation, c.surfaces);
      }
      sum_nr2 += std::pow(e.rotation_rad / sigma_r, 2);
      sum_nt2 += std::pow(e.translation_m / sigma_t, 2);
      sum_model_nr2 += std::pow(e.rotation_rad * c.sigma_inflation.rotation / sigma_r, 2);
      sum_model_nt2 += std::pow(e.translation_m * c.sigma_inflation.translation / sigma_t, 2);
      few_surfaces += c.few_surfaces ? 1 : 0;
      ++normalised;
    }
    for (const PairError& p : after.pairs) {
      if (noise_draws > 1) {
        bias.Add(seed, p,
                 RelativeErrorPose(r.refined.at(p.serial_i), r.refined.at(p.serial_j),
                                   rig.gt.at(p.serial_i), rig.gt.at(p.serial_j)));
      }
      sum_r2 += std::pow(p.error.rotation_rad, 2);
      sum_t2 += std::pow(p.error.translation_m, 2);
      worst_t = std::max(worst_t, p.error.translation_m);
      ++pairs;
    }
    for (const auto& [serial, tilt] : after.tilt_rad) {
      sum_tilt2 += tilt * tilt;
      ++cameras;
    }
  }
  const char* unit = noise_draws > 1 ? "runs" : "seeds";
  std::printf(
      "summary over %d %s: RMS relative rotation %.4f deg, RMS relative translation "
      "%.2f mm (worst pair %.2f mm), RMS tilt %.4f deg, %d runs not successful\n",
      runs, unit, std::sqrt(sum_r2 / pairs) * kRadToDeg, std::sqrt(sum_t2 / pairs) * 1e3,
      worst_t * 1e3, std::sqrt(sum_tilt2 / cameras) * kRadToDeg, failures);
  std::printf("runs with weakly constrained directions: %d of %d\n", runs_with_weak, runs);
  oracle_white.Print("face oracle", "independent pixels");
  oracle_whitened.Print("face oracle", "whitened");
  finder_tally.Print();
  depth_models.Print();
  std::printf(
      "runs ending worse than their start: %d in RMS rotation, %d in RMS translation, of %d\n",
      worse_rotation, worse_translation, runs);
  std::printf("simulation: %.2f s per rig (%d cameras %dx%d)\n", simulate_s / runs, sim.cameras,
              sim.width, sim.height);
  if (noise_draws > 1) {
    const auto [rotation, translation] = bias.Shares();
    std::printf(
        "bias (the error every draw of the noise repeats), share of the mean squared error over "
        "%d seeds x %d draws: %.2f rotation, %.2f translation\n",
        seeds, noise_draws, rotation, translation);
  }
  if (normalised > 0) {
    std::printf(
        "normalised errors (error / reported 1-sigma): RMS %.2f "
        "rotation, %.2f translation over %d cameras\n",
        std::sqrt(sum_nr2 / normalised), std::sqrt(sum_nt2 / normalised), normalised);
    std::printf(
        "  without the inflation (the noise model's 1-sigma): RMS %.2f rotation, %.2f "
        "translation; %d of the cameras on few surfaces\n",
        std::sqrt(sum_model_nr2 / normalised), std::sqrt(sum_model_nt2 / normalised), few_surfaces);
  }
  if (crlb && surface.seeds > 0) {
    std::printf(
        "surface-model bound (Cramer-Rao: every band pixel's inverse depth once, sigma_w = "
        "noise%s, "
        "the true faces as nuisance planes, floor normal known, no prior): RMS %.4f deg %.2f mm "
        "tilt %.4f deg; RMS of error / bound over the %s: %.2f rotation, %.2f translation\n",
        sim.noise_corr_share > 0.0 ? ", white: not the simulated correlated noise" : "",
        surface.RmsRotationDeg(), surface.RmsTranslationMm(), surface.RmsTiltDeg(), unit,
        surface.RmsRatioRotation(), surface.RmsRatioTranslation());
  }
  if (crlb && correlated_surface.seeds > 0) {
    std::printf(
        "correlated-noise surface bound (the surface-model bound with the simulator's noise "
        "correlation: %.3g px, share %.3g): RMS %.4f deg %.2f mm tilt %.4f deg; RMS of error / "
        "bound over the %s: %.2f rotation, %.2f translation\n",
        sim.noise_corr_px, sim.noise_corr_share, correlated_surface.RmsRotationDeg(),
        correlated_surface.RmsTranslationMm(), correlated_surface.RmsTiltDeg(), unit,
        correlated_surface.RmsRatioRotation(), correlated_surface.RmsRatioTranslation());
    for (const auto& [px, sum] : away_from_boundaries) {
      if (sum.seeds == 0) continue;  // not available in any run (said per run)
      std::printf(
          "  without the pixels within %d px of another face (%d runs): RMS %.4f deg %.2f mm tilt "
          "%.4f deg; RMS of error / bound: %.2f rotation, %.2f translation\n",
          px, sum.seeds, sum.RmsRotationDeg(), sum.RmsTranslationMm(), sum.RmsTiltDeg(),
          sum.RmsRatioRotation(), sum.RmsRatioTranslation());
    }
  }
  diagnostic.Summary();
  if (crlb && bound.seeds > 0) {
    std::printf(
        "point-to-plane information bound (issue 5's: the joint problem's correspondences, "
        "normals known, a point counted once per term): RMS %.4f deg %.2f mm; RMS of error / "
        "bound over the %s: %.2f rotation, %.2f translation\n",
        bound.RmsRotationDeg(), bound.RmsTranslationMm(), unit, bound.RmsRatioRotation(),
        bound.RmsRatioTranslation());
  }
  if (crlb && estimator.seeds > 0) {
    std::printf(
        "estimator under shared point noise: RMS %.4f deg %.2f mm; RMS of error / it over "
        "%d %s: %.2f rotation, %.2f translation\n",
        estimator.RmsRotationDeg(), estimator.RmsTranslationMm(), estimator.seeds, unit,
        estimator.RmsRatioRotation(), estimator.RmsRatioTranslation());
  }
  return 0;
}

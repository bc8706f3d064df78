#include "options/refine_options.h"

#include <cmath>
#include <sstream>
#include <string>

namespace rigfit {
namespace {

/// Collects one line per problem; every check is written so that NaN fails it.
class ProblemList {
 public:
  template <typename T>
  void Require(bool ok, const std::string& key, const std::string& rule, const T& value) {
    if (ok) return;
    std::ostringstream line;
    line << key << " must be " << rule << ", got " << value;
    problems_.push_back(line.str());
  }
  void Add(const std::string& line) { problems_.push_back(line); }
  std::vector<std::string> Take() { return std::move(problems_); }

 private:
  std::vector<std::string> problems_;
};

bool Positive(double x) { return x > 0.0 && std::isfinite(x); }
bool NonNegative(double x) { return x >= 0.0 && std::isfinite(x); }
bool InHalfOpenRange(double x, double lo, double hi) { return x > lo && x <= hi; }

void CheckGround(const GroundOptions& g, ProblemList& p) {
  p.Require(InHalfOpenRange(g.max_normal_angle_deg, 0.0, 90.0), "ground.max_normal_angle_deg",
            "in (0, 90]", g.max_normal_angle_deg);
  p.Require(Positive(g.ransac_distance_m), "ground.ransac_distance_m", "> 0", g.ransac_distance_m);
  p.Require(g.ransac_iterations >= 1, "ground.ransac_iterations", ">= 1", g.ransac_iterations);
  p.Require(Positive(g.search_height_m), "ground.search_height_m", "> 0", g.search_height_m);
  // A plane needs three points.
  p.Require(g.min_inliers >= 3, "ground.min_inliers", ">= 3", g.min_inliers);
  p.Require(InHalfOpenRange(g.max_rotation_deg, 0.0, 180.0), "ground.max_rotation_deg",
            "in (0, 180]", g.max_rotation_deg);
  p.Require(Positive(g.max_translation_m), "ground.max_translation_m", "> 0", g.max_translation_m);
}

void CheckRegion(const RegionOptions& r, ProblemList& p) {
  p.Require(NonNegative(r.band_below), "region.band_below", ">= 0", r.band_below);
  p.Require(NonNegative(r.band_height), "region.band_height", ">= 0", r.band_height);
  p.Require(r.pixel_stride >= 1, "region.pixel_stride", ">= 1", r.pixel_stride);
  p.Require(r.edge_margin_px >= 0, "region.edge_margin_px", ">= 0", r.edge_margin_px);
  p.Require(r.stereo_edge_margin_px >= 0, "region.stereo_edge_margin_px", ">= 0",
            r.stereo_edge_margin_px);
  p.Require(r.stereo_edge_min_width_px >= 0, "region.stereo_edge_min_width_px", ">= 0",
            r.stereo_edge_min_width_px);
  p.Require(Positive(r.edge_jump), "region.edge_jump", "> 0", r.edge_jump);
  p.Require(Positive(r.min_depth_m), "region.min_depth_m", "> 0", r.min_depth_m);
  p.Require(Positive(r.max_depth_m), "region.max_depth_m", "> 0", r.max_depth_m);
  if (Positive(r.min_depth_m) && Positive(r.max_depth_m) && !(r.min_depth_m < r.max_depth_m)) {
    std::ostringstream line;
    line << "region.min_depth_m must be < region.max_depth_m, got " << r.min_depth_m
         << " >= " << r.max_depth_m;
    p.Add(line.str());
  }
}

void CheckIcp(const IcpOptions& o, ProblemList& p) {
  p.Require(o.mode == RefineMode::kJoint || o.mode == RefineMode::kPairwise, "icp.mode",
            "joint or pairwise", static_cast<int>(o.mode));
  p.Require(o.method == RegistrationMethod::kPointToPlane || o.method == RegistrationMethod::kGicp,
            "icp.method", "point_to_plane or gicp", static_cast<int>(o.method));
  p.Require(o.depth_noise_model == DepthNoiseModel::kGaussianDepth ||
                o.depth_noise_model == DepthNoiseModel::kDisparity,
            "icp.depth_noise_model", "gaussian_depth or disparity",
            static_cast<int>(o.depth_noise_model));
  p.Require(o.surface_rounds >= 1, "icp.surface_rounds", ">= 1", o.surface_rounds);
  p.Require(o.surface_faces == SurfaceFaces::kRays || o.surface_faces == SurfaceFaces::kImage,
            "icp.surface_faces", "rays or image", static_cast<int>(o.surface_faces));
  p.Require(o.depth_model == CameraDepthModel::kNone ||
                o.depth_model == CameraDepthModel::kOffset ||
                o.depth_model == CameraDepthModel::kScaleOffset,
            "icp.depth_model", "none, offset or scale_offset", static_cast<int>(o.depth_model));
  p.Require(Positive(o.depth_scale_sigma), "icp.depth_scale_sigma", "> 0", o.depth_scale_sigma);
  p.Require(Positive(o.depth_offset_sigma_px), "icp.depth_offset_sigma_px", "> 0",
            o.depth_offset_sigma_px);
  p.Require(NonNegative(o.surface_bias_px), "icp.surface_bias_px", ">= 0", o.surface_bias_px);
  p.Require(o.robust_loss == RobustLoss::kHuber || o.robust_loss == RobustLoss::kCauchy ||
                o.robust_loss == RobustLoss::kTukey || o.robust_loss == RobustLoss::kNone,
            "icp.robust_loss", "huber, cauchy, tukey or none", static_cast<int>(o.robust_loss));
  p.Require(Positive(o.voxel_size), "icp.voxel_size", "> 0", o.voxel_size);

  if (o.scales.empty()) p.Add("icp.scales must not be empty");
  for (size_t i = 0; i < o.scales.size(); ++i) {
    const std::string key = "icp.scales[" + std::to_string(i) + "]";
    p.Require(Positive(o.scales[i]), key, "> 0", o.scales[i]);
    if (i > 0) {
      p.Require(o.scales[i] < o.scales[i - 1], key,
                "< icp.scales[" + std::to_string(i - 1) + "] (coarse to fine, decreasing)",
                o.scales[i]);
    }
  }
  if (o.max_iterations.size() != o.scales.size()) {
    p.Add("icp.max_iterations must have one entry per icp.scales entry (" +
          std::to_string(o.scales.size()) + "), got " + std::to_string(o.max_iterations.size()));
  }
  for (size_t i = 0; i < o.max_iterations.size(); ++i) {
    p.Require(o.max_iterations[i] >= 1, "icp.max_iterations[" + std::to_string(i) + "]", ">= 1",
              o.max_iterations[i]);
  }

  p.Require(Positive(o.max_correspondence_distance_factor),
            "icp.max_correspondence_distance_factor", "> 0", o.max_correspondence_distance_factor);
  p.Require(InHalfOpenRange(o.max_normal_angle_deg, 0.0, 180.0), "icp.max_normal_angle_deg",
            "in (0, 180]", o.max_normal_angle_deg);
  // Normals and covariances are fitted to at least three neighbours.
  p.Require(o.normal_neighbors >= 3, "icp.normal_neighbors", ">= 3", o.normal_neighbors);
  p.Require(NonNegative(o.depth_noise), "icp.depth_noise", ">= 0", o.depth_noise);
  // The noise floor divides every residual (whitening), so it cannot be 0.
  p.Require(Positive(o.min_noise_m), "icp.min_noise_m", "> 0", o.min_noise_m);
  p.Require(NonNegative(o.plane_noise_share), "icp.plane_noise_share", ">= 0", o.plane_noise_share);
  p.Require(NonNegative(o.gravity_weight), "icp.gravity_weight", ">= 0", o.gravity_weight);
  p.Require(o.degeneracy_threshold >= 0.0 && o.degeneracy_threshold < 1.0,
            "icp.degeneracy_threshold", "in [0, 1)", o.degeneracy_threshold);
  p.Require(Positive(o.robust_loss_scale), "icp.robust_loss_scale", "> 0", o.robust_loss_scale);
  p.Require(o.min_fitness >= 0.0 && o.min_fitness <= 1.0, "icp.min_fitness", "in [0, 1]",
            o.min_fitness);
  p.Require(NonNegative(o.overlap_margin), "icp.overlap_margin", ">= 0", o.overlap_margin);
  p.Require(NonNegative(o.min_overlap_area), "icp.min_overlap_area", ">= 0", o.min_overlap_area);
  p.Require(o.reference.find('/') == std::string::npos, "icp.reference", "a camera serial (no '/')",
            "'" + o.reference + "'");
  p.Require(InHalfOpenRange(o.max_rotation_deg, 0.0, 180.0), "icp.max_rotation_deg", "in (0, 180]",
            o.max_rotation_deg);
  p.Require(Positive(o.max_translation_m), "icp.max_translation_m", "> 0", o.max_translation_m);
}

}  // namespace

std::vector<std::string> OptionProblems(const RefineOptions& options) {
  ProblemList problems;
  CheckGround(options.ground, problems);
  CheckRegion(options.region, problems);
  CheckIcp(options.icp, problems);
  problems.Require(options.threads >= 1 && options.threads <= kMaxRefineThreads, "threads",
                   "in [1, " + std::to_string(kMaxRefineThreads) + "]", options.threads);
  return problems.Take();
}

}  // namespace rigfit

#include "registration/surface_bundle.h"

#include <ceres/manifold.h>
#include <ceres/normal_prior.h>
#include <ceres/ordered_groups.h>
#include <ceres/product_manifold.h>
#include <ceres/solver.h>
#include <ceres/sphere_manifold.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <memory>
#include <tuple>
#include <unordered_map>
#include <utility>

#include "core/format.h"
#include "core/geometry.h"
#include "core/parallel.h"
#include "prepare/correspondences.h"
#include "registration/image_faces.h"
#include "registration/plane_segmentation.h"
#include "registration/ray_membership.h"
#include "residuals/gravity_prior.h"
#include "residuals/plane_cluster.h"
#include "residuals/pose_prior.h"
#include "uncertainty/covariance.h"
#include "uncertainty/degeneracy.h"

namespace rigfit {
namespace {

using PoseBlock = std::array<double, kPoseAmbientSize>;
/// A camera's depth model [alpha, beta] (residuals/plane_cluster.h).
using DepthBlock = std::array<double, kDepthModelSize>;
constexpr DepthBlock kNoDepthModel = {1.0, 0.0};

/// Model error of the segmentation per round, in voxels: the joint start is
/// about a centimetre off; each solve sharpens the surfaces, so the next round
/// may be stricter (on a noise-free rig the last round's 1 mm keeps the pixels
/// of neighbouring faces out: 0.05 mm against 0.18 mm with 3 mm).
constexpr std::array<double, 3> kRoundModelVoxels = {0.5, 0.15, 0.05};
/// A camera needs this many planes, whose normals spread over all three
/// directions (the smallest eigenvalue of sum n n^T at least this share of the
/// largest), for its six pose directions to be fixed by planes; otherwise it
/// keeps its start pose.
constexpr int kMinPlanesPerCamera = 3;
constexpr double kMinNormalSpread = 0.02;
/// The start's covariance is inflated this much for the prior that holds an
/// untied camera (PlaneSupport): along the directions its planes fix it weighs
/// little next to them, along the one they do not it stops the slide. Seed 2
/// (whose cameras 2 and 3 are untied), RMS translation: 1, white 2.36 mm (2
/// draws; no prior, free to slide: 1.60), stereo 50.0 mm; 10, 1.56 and 46.8;
/// 100, 1.71 and 79.2 (the joint start 51.8 on stereo).
constexpr double kUntiedPriorInflation = 10.0;
/// Levenberg-Marquardt iterations per round.
constexpr int kIterationsPerRound = 25;

/// The inverse depth sigma of a pixel at depth z: the sensor's k, and the
/// metric noise floor seen in inverse depth (min_noise / z^2).
double InverseDepthSigma(double k, double z, double min_noise_m) {
  const double floor = min_noise_m / (z * z);
  return std::sqrt(k * k + floor * floor);
}

/// The measured inverse depth of a pixel: with noise Gaussian in z, E[1/z_m] =
/// 1/z + k^2 z to second order, so 1/z_m - k^2 z_m is unbiased to that order;
/// disparity noise needs none.
double InverseDepth(double z, double k, DepthNoiseModel model) {
  return model == DepthNoiseModel::kGaussianDepth ? 1.0 / z - k * k * z : 1.0 / z;
}

/// The start's prior along the directions where the planes know the pose less
/// well than the start does: with the start's covariance S = C C^T and the
/// planes' Q, the eigenvectors u_k of C^-1 Q C^-T with eigenvalues lambda_k
/// above 1 give the rows sqrt(1 - 1 / lambda_k) u_k^T C^-1 of W (zero rows
/// elsewhere); an empty matrix when there are none. The prior adds what the
/// start knows beyond the planes (1 - 1 / lambda_k of its information), so that
/// the planes and the prior together know the direction as well as the start,
/// not better: the two come from the same pixels, and adding the start's whole
/// information counted them twice (seeds 0..9 x 3 at ee4335c: 3.76 mm
/// against 3.40, held out 6.40 against 6.36, the covariance optimistic by 1.30
/// against 1.03).
Mat6 WeakDirectionPrior(const Mat6& start, const Mat6& planes, int* directions) {
  *directions = 0;
  const Eigen::SelfAdjointEigenSolver<Mat6> start_eigen(start);
  const Vec6 values = start_eigen.eigenvalues();
  if (!(values(5) > 0.0)) return Mat6::Zero();
  const Mat6 whiten = values.cwiseMax(1e-12 * values(5)).cwiseSqrt().cwiseInverse().asDiagonal() *
                      start_eigen.eigenvectors().transpose();  // C^-1
  const Eigen::SelfAdjointEigenSolver<Mat6> ratio(whiten * planes * whiten.transpose());
  Mat6 W = Mat6::Zero();
  for (int k = 0; k < 6; ++k) {
    if (ratio.eigenvalues()(k) <= 1.0) continue;
    const double excess = std::sqrt(1.0 - 1.0 / ratio.eigenvalues()(k));
    W.row(k) = excess * ratio.eigenvectors().col(k).transpose() * whiten;
    ++*directions;
  }
  return W;
}

/// A plane parameter block [n; d] (residuals/plane_cluster.h).
struct PlaneBlock {
  Vec4 x;
  bool floor;
  Vec3 Normal() const { return x.head<3>(); }
};

/// One camera's pixels on one plane.
struct ClusterTerm {
  int camera;
  int plane;
  PlaneCluster cluster;
  std::vector<int> pixels;  ///< indices into the camera's points
};

/// The segmentation's input at the given poses, and which camera point each
/// entry is.
struct MergedCloud {
  std::vector<SegmentPoint> points;
  std::vector<std::pair<int, int>> source;  ///< (camera, point index)
};

MergedCloud Merge(const std::vector<SurfaceCamera>& cameras, const std::vector<Pose>& poses,
                  int num_threads) {
  MergedCloud cloud;
  std::vector<size_t> first(cameras.size() + 1, 0);  // each camera's first entry
  for (size_t c = 0; c < cameras.size(); ++c) first[c + 1] = first[c] + cameras[c].points.size();
  cloud.points.resize(first.back());
  cloud.source.resize(first.back());
  ParallelFor(
      static_cast<int>(cameras.size()), num_threads,
      [&](int c) {
        const Pose& T = poses[c];
        const SurfaceCamera& camera = cameras[c];
        for (size_t i = 0; i < camera.points.size(); ++i) {
          const Vec3& p = camera.points[i];
          SegmentPoint& s = cloud.points[first[c] + i];
          s.world = T * p;
          s.camera = c;
          if (camera.ray_model) {
            s.ray_world = T.linear() * (p / p.z());
            s.sigma_z = camera.depth_noise * p.z() * p.z();
            s.depth = p.z();
          }
          cloud.source[first[c] + i] = {c, static_cast<int>(i)};
        }
      },
      /*min_per_thread=*/1);
  return cloud;
}

/// Adds the camera's pixel i to `cluster`, its sigma times `inflation`.
void AddPixel(const SurfaceCamera& camera, const IcpOptions& options, double inflation, int i,
              PlaneCluster* cluster) {
  const Vec3& p = camera.points[i];
  if (camera.ray_model) {
    cluster->AddRay(p, InverseDepth(p.z(), camera.depth_noise, options.depth_noise_model),
                    inflation * InverseDepthSigma(camera.depth_noise, p.z(), options.min_noise_m));
  } else {
    cluster->AddPoint(p, inflation * options.min_noise_m);
  }
}

/// Sums each term's pixels into its cluster, each pixel's variance times its
/// camera's noise correlation.
void FillClusters(const std::vector<SurfaceCamera>& cameras, const IcpOptions& options,
                  const std::vector<double>& correlation, std::vector<ClusterTerm>* terms) {
  for (ClusterTerm& t : *terms) {
    t.cluster = PlaneCluster{};
    const double inflation = std::sqrt(correlation[t.camera]);
    for (const int i : t.pixels) AddPixel(cameras[t.camera], options, inflation, i, &t.cluster);
  }
}

/// The side of the image tiles over which the noise's correlation is measured,
/// pixels.
constexpr double kCorrelationTilePx = 32.0;

/// The image tile of kCorrelationTilePx that holds the camera point p (the
/// camera has a pixel angle).
std::pair<long long, long long> TileOf(const SurfaceCamera& camera, const Vec3& p) {
  const double tile = kCorrelationTilePx * camera.pixel_angle;
  return {static_cast<long long>(std::floor(p.x() / p.z() / tile)),
          static_cast<long long>(std::floor(p.y() / p.z() / tile))};
}

/// A hash of integer keys (cells, tiles) for the lookups of PixelSandwiches, whose
/// results do not depend on the maps' order.
struct KeyHash {
  template <size_t N>
  size_t operator()(const std::array<int64_t, N>& key) const {
    std::uint64_t h = 0;
    for (const int64_t k : key) h = (h ^ static_cast<std::uint64_t>(k)) * 0x9E3779B97F4A7C15ull;
    return static_cast<size_t>(h ^ (h >> 29));
  }
};

/// Per camera, the noise correlation (SurfaceBundleResult::noise_correlation)
/// at the blocks: the pixels of each term are grouped by image tile, and the
/// squared sums of their whitened residuals over the groups are divided by the
/// number of pixels: the variance of a tile's sum against what the noise model
/// predicts for independent pixels (correlated pixels add their covariances).
/// Against the model, not against the residuals' own scale: noise-free data,
/// whose tiny residuals are all structure, stay at 1. At least 1; 1 for cameras
/// without a pixel angle.
std::vector<double> NoiseCorrelation(const std::vector<ClusterTerm>& terms,
                                     const std::vector<SurfaceCamera>& cameras,
                                     const std::vector<PoseBlock>& poses,
                                     const std::vector<PlaneBlock>& planes,
                                     const std::vector<DepthBlock>& depth,
                                     const IcpOptions& options) {
  std::vector<double> squared_sums(cameras.size(), 0.0);
  std::vector<int> pixels(cameras.size(), 0);
  for (const ClusterTerm& t : terms) {
    const SurfaceCamera& camera = cameras[t.camera];
    if (!camera.ray_model || !(camera.pixel_angle > 0.0)) continue;
    const Pose T = PoseFromParameters(poses[t.camera].data());
    const Vec3 n = planes[t.plane].Normal();
    Vec4 plane_camera;  // [R^T n; n^T t + d]
    plane_camera << T.linear().transpose() * n, n.dot(T.translation()) + planes[t.plane].x(3);
    std::map<std::pair<long long, long long>, double> tile_sums;
    for (const int i : t.pixels) {
      const Vec3& p = camera.points[i];
      const Vec3 a = p / p.z();
      Vec4 b;
      b << a,
          depth[t.camera][0] * InverseDepth(p.z(), camera.depth_noise, options.depth_noise_model) +
              depth[t.camera][1];
      const double r = b.dot(plane_camera) / plane_camera(3) /
                       InverseDepthSigma(camera.depth_noise, p.z(), options.min_noise_m);
      tile_sums[TileOf(camera, p)] += r;
      ++pixels[t.camera];
    }
    for (const auto& [key, sum] : tile_sums) squared_sums[t.camera] += sum * sum;
  }
  std::vector<double> correlation(cameras.size(), 1.0);
  for (size_t c = 0; c < cameras.size(); ++c) {
    if (pixels[c] > 0) {
      correlation[c] = std::max(1.0, squared_sums[c] / pixels[c]);
    }
  }
  return correlation;
}

/// The pixels of every (camera, plane) with points (clusters not yet summed).
std::vector<ClusterTerm> Clusters(const std::vector<SurfaceCamera>& cameras,
                                  const MergedCloud& cloud,
                                  const std::vector<SegmentedPlane>& planes) {
  std::vector<ClusterTerm> terms;
  for (size_t j = 0; j < planes.size(); ++j) {
    std::vector<int> term_of(cameras.size(), -1);
    for (const int s : planes[j].points) {
      const auto [c, i] = cloud.source[s];
      if (term_of[c] < 0) {
        term_of[c] = static_cast<int>(terms.size());
        terms.push_back({c, static_cast<int>(j), PlaneCluster{}, {}});
      }
      terms[term_of[c]].pixels.push_back(i);
    }
  }
  return terms;
}

/// Keeps the pixels of each non-floor term whose predicted point lies within
/// kWindowSigmas of the band's top (inside the points' own, wider, top:
/// SurfaceCamera::points_top) and of the segmentation's floor margin; a term
/// left with too few pixels goes.
void PredictedHeightWindow(const std::vector<SurfaceCamera>& cameras,
                           const std::vector<Pose>& poses, const std::vector<PlaneBlock>& planes,
                           const PlaneSegmentationOptions& segmentation,
                           std::vector<ClusterTerm>* terms) {
  const double base = BaseVariance(segmentation);
  std::vector<ClusterTerm> kept;
  for (ClusterTerm& t : *terms) {
    const SurfaceCamera& camera = cameras[t.camera];
    if (planes[t.plane].floor || !camera.ray_model) {
      kept.push_back(std::move(t));
      continue;
    }
    const Pose& T = poses[t.camera];
    const Vec3 n = planes[t.plane].Normal();
    const double d = planes[t.plane].x(3);
    std::vector<int> inside;
    for (const int i : t.pixels) {
      const Vec3& p = camera.points[i];
      const Vec3 ray = T.linear() * (p / p.z());
      const double z = RayPlaneDepth(T.translation(), ray, n, d);  // predicted depth
      if (!std::isfinite(z) || z <= 0.0) continue;
      const double y = T.translation().y() + z * ray.y();
      const double sigma_v = VerticalSigma(camera, z, ray, base);
      double bottom = camera.band_bottom;
      if (segmentation.leveled_floor) {
        bottom = std::max(bottom, std::min(segmentation.floor_margin_m,
                                           segmentation.floor_margin_sigmas * sigma_v));
      }
      if (y >= bottom + kWindowSigmas * sigma_v && y <= PredictedTop(camera, sigma_v)) {
        inside.push_back(i);
      }
    }
    if (static_cast<int>(inside.size()) < segmentation.min_points_per_camera) continue;
    t.pixels = std::move(inside);
    kept.push_back(std::move(t));
  }
  *terms = std::move(kept);
}

/// The planes of the blocks.
std::vector<PlanarFace> PlaneList(const std::vector<PlaneBlock>& planes) {
  std::vector<PlanarFace> list;
  for (const PlaneBlock& plane : planes) list.push_back({plane.Normal(), plane.x(3), plane.floor});
  return list;
}

/// The terms' pixels assigned anew by their rays
/// (registration/ray_membership.h).
void AssignByRays(const std::vector<SurfaceCamera>& cameras, const std::vector<Pose>& poses,
                  const std::vector<PlaneBlock>& planes,
                  const PlaneSegmentationOptions& segmentation, int num_threads,
                  std::vector<ClusterTerm>* terms) {
  std::vector<SurfaceTerm> segmented;
  for (ClusterTerm& t : *terms) segmented.push_back({t.camera, t.plane, std::move(t.pixels)});
  terms->clear();
  for (SurfaceTerm& t :
       MembershipByRays(cameras, poses, PlaneList(planes), segmented, segmentation, num_threads)) {
    terms->push_back({t.camera, t.plane, PlaneCluster{}, std::move(t.pixels)});
  }
}

/// The faces found in the depth cameras' images at `poses` (registration/image_faces.h), with
/// each camera's pixels kept where its ray meets the face's plane inside the band; empty when a
/// camera has no image.
std::map<std::pair<int, int>, std::vector<int>> ImageFacePixels(
    const std::vector<SurfaceCamera>& cameras, const std::vector<Pose>& poses, bool leveled_floor,
    int num_threads, std::vector<PlanarFace>* faces) {
  std::vector<ImageFaceCamera> in(cameras.size());
  for (size_t c = 0; c < cameras.size(); ++c) {
    const SurfaceCamera& camera = cameras[c];
    if (!camera.ray_model || camera.width == 0) return {};
    in[c] = {&camera.points, camera.intrinsics, camera.width,
             camera.height,  poses[c],          camera.depth_noise};
  }
  ImageFacesOptions options;
  options.leveled_floor = leveled_floor;
  const ImageFaces found = FindImageFaces(in, options, num_threads);
  *faces = found.faces;
  std::map<std::pair<int, int>, std::vector<int>> pixels;  // (face, camera)
  for (size_t c = 0; c < cameras.size(); ++c) {
    const Pose& T = poses[c];
    const CameraImageFaces& camera_faces = found.cameras[c];
    for (size_t i = 0; i < camera_faces.label.size(); ++i) {
      if (camera_faces.label[i] < 0) continue;
      const int f = camera_faces.face[camera_faces.label[i]];
      const Vec3 ray = T.linear() * (cameras[c].points[i] / cameras[c].points[i].z());
      const double s =
          RayPlaneDepth(T.translation(), ray, found.faces[f].normal, found.faces[f].offset);
      const double height = T.translation().y() + s * ray.y();
      if (std::isfinite(s) && s > 0.0 && height >= cameras[c].band_bottom &&
          height <= cameras[c].band_top) {
        pixels[{f, static_cast<int>(c)}].push_back(static_cast<int>(i));
      }
    }
  }
  return pixels;
}

/// The terms other than the floor's replaced by the faces found in the depth cameras' images
/// (ImageFacePixels): a (face, camera) with the segmentation's min_points_per_camera or more, a
/// face two cameras or more have.
/// The floor's terms stay (its pixels by their rays: the image floor, the points its plane
/// predicts within the poses' tolerance, tilted the cameras 2.8x more on white noise,
/// docs/benchmarks.md). False (nothing changed) when a camera has no image.
bool AssignByImageFaces(const std::vector<SurfaceCamera>& cameras, const std::vector<Pose>& poses,
                        const PlaneSegmentationOptions& segmentation, int num_threads,
                        std::vector<PlaneBlock>* planes, std::vector<ClusterTerm>* terms) {
  const int min_pixels = segmentation.min_points_per_camera;
  std::vector<PlanarFace> faces;
  std::map<std::pair<int, int>, std::vector<int>> pixels =
      ImageFacePixels(cameras, poses, segmentation.leveled_floor, num_threads, &faces);
  if (pixels.empty()) return false;
  std::vector<PlaneBlock> kept_planes;
  std::vector<ClusterTerm> kept_terms;
  std::map<int, int> floor_of;
  for (ClusterTerm& t : *terms) {
    if (!(*planes)[t.plane].floor) continue;
    const auto [it, added] = floor_of.emplace(t.plane, static_cast<int>(kept_planes.size()));
    if (added) kept_planes.push_back((*planes)[t.plane]);
    t.plane = it->second;
    kept_terms.push_back(std::move(t));
  }
  std::map<int, int> seen_by;
  for (const auto& [key, p] : pixels) {
    seen_by[key.first] += static_cast<int>(p.size()) >= min_pixels ? 1 : 0;
  }
  std::map<int, int> plane_of;
  for (auto& [key, p] : pixels) {
    const PlanarFace& face = faces[key.first];
    if (face.floor || static_cast<int>(p.size()) < min_pixels || seen_by[key.first] < 2) continue;
    const auto [it, added] = plane_of.emplace(key.first, static_cast<int>(kept_planes.size()));
    if (added) {
      kept_planes.push_back(
          {Vec4(face.normal.x(), face.normal.y(), face.normal.z(), face.offset), false});
    }
    kept_terms.push_back({key.second, it->second, PlaneCluster{}, std::move(p)});
  }
  std::sort(kept_terms.begin(), kept_terms.end(), [](const ClusterTerm& a, const ClusterTerm& b) {
    return std::tie(a.camera, a.plane) < std::tie(b.camera, b.plane);
  });
  *planes = std::move(kept_planes);
  *terms = std::move(kept_terms);
  return true;
}

/// LevelOnFloor's Gauss-Newton: at most this many iterations, until a step is
/// below kLevelStepRad (the start is a few hundredths of a degree off).
constexpr int kLevelIterations = 20;
constexpr double kLevelStepRad = 1e-12;

/// `block` turned about world X and Z through its centre, its yaw and centre
/// held, so that its pixels of `cluster` lie best on the plane `floor` (held):
/// Gauss-Newton on the plane-cluster residual over the two tilt angles of the
/// pose's tangent (core/pose.h).
void LevelOnFloor(const PlaneCluster& cluster, bool ray_model, const Vec4& floor,
                  PoseBlock* block) {
  const std::unique_ptr<ceres::CostFunction> cost(PlaneClusterCost::Create(cluster, ray_model));
  for (int iteration = 0; iteration < kLevelIterations; ++iteration) {
    Vec4 r;
    Eigen::Matrix<double, 4, kPoseAmbientSize, Eigen::RowMajor> J;
    const double* parameters[2] = {block->data(), floor.data()};
    double* jacobians[2] = {J.data(), nullptr};
    if (!cost->Evaluate(parameters, r.data(), jacobians)) return;
    Eigen::Matrix<double, kPoseAmbientSize, 6, Eigen::RowMajor> plus;
    SharedPoseManifold()->PlusJacobian(block->data(), plus.data());
    const Eigen::Matrix<double, 4, 6> J_tangent = J * plus;
    Eigen::Matrix<double, 4, 2> J_tilt;
    J_tilt << J_tangent.col(0),
        J_tangent.col(2);  // rotations about world X and Z
    const Eigen::Vector2d step =
        -(J_tilt.transpose() * J_tilt).ldlt().solve(J_tilt.transpose() * r);
    if (!step.allFinite()) return;
    Vec6 delta;
    delta << step(0), 0.0, step(1), 0.0, 0.0, 0.0;
    PoseBlock next;
    SharedPoseManifold()->Plus(block->data(), delta.data(), next.data());
    *block = next;
    if (step.norm() < kLevelStepRad) return;
  }
}

/// The reference leveled again on the bundle's floor: the cameras that are not
/// free and see the leveled floor (the reference: a camera the joint solve
/// could not link holds no pixels) are turned by LevelOnFloor on their floor
/// pixels. Leveling fitted each camera's floor alone, with the feet of walls
/// and boxes in it; the bundle's floor leaves them out and is shared by every
/// camera. Marks them in `leveled`; returns the world correction C applied to
/// the reference (T <- C T; the identity when none).
Pose LevelReference(const std::vector<SurfaceCamera>& cameras,
                    const std::vector<ClusterTerm>& terms, const std::vector<PlaneBlock>& planes,
                    std::vector<PoseBlock>* blocks, std::vector<bool>* leveled) {
  Pose correction = Pose::Identity();
  for (const ClusterTerm& t : terms) {
    const SurfaceCamera& camera = cameras[t.camera];
    if (camera.free || !camera.floor_leveled || !planes[t.plane].floor) continue;
    PoseBlock& block = (*blocks)[t.camera];
    const Pose before = PoseFromParameters(block.data());
    LevelOnFloor(t.cluster, camera.ray_model, planes[t.plane].x, &block);
    correction = PoseFromParameters(block.data()) * before.inverse();
    (*leveled)[t.camera] = true;
  }
  return correction;
}

/// Whether the normals of a camera's planes (their scatter, `count` of them)
/// fix its pose (see kMinPlanesPerCamera).
bool Spans(const Mat3& scatter, int count) {
  if (count < kMinPlanesPerCamera) return false;
  const Vec3 eigenvalues = Eigen::SelfAdjointEigenSolver<Mat3>(scatter).eigenvalues();
  return eigenvalues(0) >= kMinNormalSpread * eigenvalues(2);
}

/// Per camera: its planes fix its pose (`fixed`, see kMinPlanesPerCamera), and
/// they do so against the cameras held in place (`tied`): the planes of a tied
/// camera that a held or an already tied camera sees fix its pose, repeated until
/// no camera is added. Free cameras that alone share the planes fixing one
/// direction are fixed but not tied: together with those planes they can slide
/// along it (stereo seed 2 of the benchmark: two cameras saw the only walls
/// facing X and went 8 m along X in the first round).
struct PlaneSupport {
  std::vector<bool> fixed;
  std::vector<bool> tied;
};
PlaneSupport PlanesFixPose(const std::vector<ClusterTerm>& terms,
                           const std::vector<PlaneBlock>& planes,
                           const std::vector<SurfaceCamera>& cameras) {
  const size_t n = cameras.size();
  PlaneSupport support{std::vector<bool>(n, false), std::vector<bool>(n, false)};
  std::vector<bool> anchored(n);
  for (size_t c = 0; c < n; ++c) anchored[c] = !cameras[c].free;
  // Pass 0 counts every plane (fixed), the others the planes anchored cameras see.
  for (bool first = true, grew = true; grew; first = false) {
    grew = false;
    std::vector<bool> plane_anchored(planes.size(), first);
    for (const ClusterTerm& t : terms) {
      if (anchored[t.camera]) plane_anchored[t.plane] = true;
    }
    std::vector<Mat3> scatter(n, Mat3::Zero());
    std::vector<int> count(n, 0);
    for (const ClusterTerm& t : terms) {
      if (!plane_anchored[t.plane]) continue;
      const Vec3 normal = planes[t.plane].Normal();
      scatter[t.camera] += normal * normal.transpose();
      ++count[t.camera];
    }
    for (size_t c = 0; c < n; ++c) {
      if (first) {
        support.fixed[c] = Spans(scatter[c], count[c]);
        grew = true;
      } else if (!anchored[c] && support.fixed[c] && Spans(scatter[c], count[c])) {
        support.tied[c] = anchored[c] = true;
        grew = true;
      }
    }
  }
  return support;
}

/// Leaves out the pixels of the free cameras that `fixed` does not fix, then the planes no
/// pixel is left on: held at their start, which may be centimetres off, those cameras pulled
/// the planes the others are solved on (in the test ACameraIsFixedOnlyByPlanesTiedToTheReference
/// two cameras 5 mm off left the others 4.7 mm off on noise-free pixels).
void DropUnfixedCameras(const std::vector<SurfaceCamera>& cameras, const std::vector<bool>& fixed,
                        std::vector<ClusterTerm>* terms, std::vector<PlaneBlock>* planes) {
  std::vector<ClusterTerm> kept;
  std::vector<PlaneBlock> used;
  std::vector<int> index(planes->size(), -1);
  for (ClusterTerm& t : *terms) {
    if (cameras[t.camera].free && !fixed[t.camera]) continue;
    if (index[t.plane] < 0) {
      index[t.plane] = static_cast<int>(used.size());
      used.push_back((*planes)[t.plane]);
    }
    t.plane = index[t.plane];
    kept.push_back(std::move(t));
  }
  *terms = std::move(kept);
  *planes = std::move(used);
}

/// Squared whitened residual of every term at the blocks (the depth models' applied).
std::vector<double> TermCosts(const std::vector<ClusterTerm>& terms,
                              const std::vector<SurfaceCamera>& cameras,
                              const std::vector<PoseBlock>& poses,
                              const std::vector<PlaneBlock>& planes,
                              const std::vector<DepthBlock>& depth) {
  std::vector<double> costs;
  for (const ClusterTerm& t : terms) {
    const DepthBlock& model = depth[t.camera];
    // In the measured inverse depth's sigma, as PlaneClusterDepthCost.
    const PlaneClusterCost cost(
        DepthModelMatrix(model[0], model[1]) * t.cluster.SquareRoot() / model[0],
        cameras[t.camera].ray_model);
    const double* parameters[] = {poses[t.camera].data(), planes[t.plane].x.data()};
    Vec4 r;
    cost.Evaluate(parameters, r.data(), nullptr);
    costs.push_back(r.squaredNorm());
  }
  return costs;
}

/// RMS whitened residual per camera ("plane thickness").
std::vector<double> Thickness(const std::vector<ClusterTerm>& terms,
                              const std::vector<double>& costs, size_t num_cameras) {
  std::vector<double> sum(num_cameras, 0.0);
  std::vector<int> pixels(num_cameras, 0);
  for (size_t k = 0; k < terms.size(); ++k) {
    sum[terms[k].camera] += costs[k];
    pixels[terms[k].camera] += terms[k].cluster.Count();
  }
  std::vector<double> rms(num_cameras, 0.0);
  for (size_t c = 0; c < num_cameras; ++c) {
    if (pixels[c] > 0) rms[c] = std::sqrt(sum[c] / pixels[c]);
  }
  return rms;
}

/// The last round's planes and pixels (SurfaceBundleResult::plane_list, terms).
void RecordUse(const std::vector<PlaneBlock>& planes, const std::vector<ClusterTerm>& terms,
               SurfaceBundleResult* result) {
  result->plane_list = PlaneList(planes);
  result->terms.clear();
  for (const ClusterTerm& t : terms) result->terms.push_back({t.camera, t.plane, t.pixels});
}

/// A term's Jacobians (PlaneClusterCost) with, for residuals, what an offset of one sigma in
/// its camera's inverse depth on this surface does to them: r(beta) - r(0) = beta L^T e_3
/// (docs/residuals.md section 11, dr/dbeta at scale 1). The cluster-robust sandwich of these
/// residuals, each term its own cluster, is the covariance that independent offsets of that
/// sigma give the poses.
class SurfaceBiasShift final : public ceres::SizedCostFunction<4, kPoseAmbientSize, 4> {
 public:
  /// L: the cluster's PlaneCluster::SquareRoot.
  SurfaceBiasShift(const Mat4& L, bool ray_model, double sigma)
      : cost_(L, ray_model), shift_(sigma * L.row(2).transpose()) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    Vec4 unused;
    if (!cost_.Evaluate(parameters, unused.data(), jacobians)) return false;
    Eigen::Map<Vec4> r(residuals);
    r = shift_;
    return true;
  }

 private:
  PlaneClusterCost cost_;
  Vec4 shift_;
};

/// The surface bundle's solve: rounds of segmentation and a joint Ceres solve
/// of poses and planes, then the statistics (noise scale, thickness,
/// covariance) and, where the start knows a camera's pose better than the
/// planes do, a last solve with the start as a prior.
class BundleSolver {
 public:
  BundleSolver(const std::vector<SurfaceCamera>& cameras, const IcpOptions& options,
               int num_threads, const Log& log);
  SurfaceBundleResult Run();

 private:
  /// Solves poses and planes over the terms; false when Ceres fails (summary_
  /// says why).
  bool SolveOnce(const std::vector<Mat6>& priors);
  /// The pose and plane blocks into `problem` (and `ordering`, not null: planes
  /// eliminated first).
  void AddPoseAndPlaneBlocks(ceres::Problem* problem, ceres::ParameterBlockOrdering* ordering);
  void AddPriors(ceres::Problem* problem, const std::vector<Mat6>& priors);
  /// What a round tells the rounds: go on, stop (no plane: the last round's
  /// result stands) or return at once (the solve failed: the previous round's
  /// poses stand, as they are).
  enum class Next { kContinue, kStop, kReturn };
  /// One round: segmentation at the current poses, the terms, the solve.
  Next Round(int round, int rounds);
  void LogRound(int round, int pixels) const;
  /// The noise scale, the thickness and the poses' covariance (planes
  /// marginalised).
  void Statistics();
  /// Per free camera (in camera order, 6 columns each) the design effect of the
  /// pixels' residuals (ClusterSandwiches): fine clusters the image tiles of the
  /// noise correlation (what the noise model already counts: each pixel weighs
  /// 1 / its camera's correlation) within each term and cube, coarse ones the
  /// cubes of kCovarianceCellM within each term (the correlated noise of
  /// neighbouring tiles, a surface's bias). From the problem of the last solve
  /// with each term split by tile and cube: the same J^T J, the same covariance.
  /// Returns the poses' covariance (MarginalPoseSandwiches', not scaled), the
  /// sandwiches and in `priors` the information of the priors.
  Eigen::MatrixXd PixelSandwiches(const std::vector<double*>& free_poses,
                                  const std::vector<double*>& plane_blocks,
                                  ClusterSandwiches* sandwiches, Eigen::MatrixXd* priors);
  /// The poses' covariance (free_poses' columns) from an independent offset of each stereo
  /// camera's inverse depth on each surface (SurfaceCamera::surface_bias): a bias that no number of
  /// pixels averages away and that a camera on few surfaces absorbs whole, so its residuals do not
  /// show it. Empty when no camera has one or a depth model is solved.
  Eigen::MatrixXd SurfaceBiasCovariance(const std::vector<double*>& free_poses,
                                        const std::vector<double*>& plane_blocks);
  /// The start as a prior along the directions it knows better than the planes;
  /// false when no camera has such a direction.
  bool StartPriors(std::vector<Mat6>* priors) const;
  /// The start as a prior with its whole covariance on the fixed cameras that
  /// are not tied (PlaneSupport); zero for the others.
  std::vector<Mat6> UntiedPriors() const;
  bool Free(size_t c) const { return cameras_[c].free && !result_.fallback[c]; }
  /// Its depth model is a parameter block of the problem (IcpOptions::depth_model).
  bool DepthSolved(size_t c) const {
    return options_.depth_model != CameraDepthModel::kNone && Free(c) && cameras_[c].ray_model &&
           !depth_held_[c];
  }
  void AddDepthModels(ceres::ParameterBlockOrdering* ordering);
  /// The prior 1-sigma of camera c's [alpha, beta].
  Eigen::Vector2d DepthPriorSigma(size_t c) const;
  /// The depth models into result_.depth_model, their 1-sigma from the last solve's problem;
  /// true when a solved one is not observable.
  bool MeasureDepthModels();
  /// The depth models that are not observable held at scale 1, offset 0, and the last solve
  /// (with the start's `priors`) done again.
  void HoldUnobservableDepthModels(const std::vector<Mat6>& priors);
  /// The cameras with their points at the depth their current models give (in `storage`), or
  /// the cameras as given when every model is at scale 1, offset 0.
  const std::vector<SurfaceCamera>& CorrectedCameras(std::vector<SurfaceCamera>* storage) const;
  /// The last solve again with `priors`, then the statistics; false when Ceres fails.
  bool Resolve(const std::vector<Mat6>& priors);

  const std::vector<SurfaceCamera>& cameras_;
  const IcpOptions& options_;
  const int num_threads_;
  const Log& log_;
  const size_t n_;
  SurfaceBundleResult result_;
  std::vector<Pose> poses_;
  std::vector<PoseBlock> blocks_;
  ceres::ProductManifold<ceres::SphereManifold<3>, ceres::EuclideanManifold<1>> plane_manifold_;
  ceres::SubsetManifold floor_manifold_{4, {0, 1, 2}};  // the floor's normal stays +Y
  std::unique_ptr<ceres::Problem> problem_;
  std::vector<ClusterTerm> terms_;
  std::vector<PlaneBlock> planes_;
  // The noise correlation the current terms are weighted with, and the one
  // measured at the last solve (for the next round's terms).
  std::vector<double> correlation_;
  std::vector<double> measured_;
  ceres::Solver::Summary summary_;
  std::vector<Mat6> priors_;  ///< of the last solve
  // Per camera, the planes' covariance of the poses without PixelSandwiches'
  // inflation: what the start's prior is weighed against (StartPriors).
  std::vector<Mat6> planes_covariance_;
  std::vector<bool> fixed_;
  std::vector<bool> untied_;  ///< fixed but not tied (PlaneSupport)
  std::vector<DepthBlock> depth_;
  std::vector<bool> depth_held_;  ///< not observable: held at kNoDepthModel
  ceres::SubsetManifold offset_manifold_{kDepthModelSize, {0}};  // icp.depth_model offset
  // The correction of the world that LevelReference applied to the reference:
  // the start's poses, which the joint solve found against the reference's
  // leveled pose, move with it where the start holds a direction (a camera that
  // keeps its joint pose stays where it is: moving it too changed nothing on
  // the held-out seed that has one).
  Pose gauge_ = Pose::Identity();
};

BundleSolver::BundleSolver(const std::vector<SurfaceCamera>& cameras, const IcpOptions& options,
                           int num_threads, const Log& log)
    : cameras_(cameras),
      options_(options),
      num_threads_(num_threads),
      log_(log),
      n_(cameras.size()),
      poses_(cameras.size()),
      blocks_(cameras.size()),
      correlation_(cameras.size(), 1.0),
      measured_(cameras.size(), 1.0),
      planes_covariance_(cameras.size(), Mat6::Zero()),
      untied_(cameras.size(), false),
      depth_(cameras.size(), kNoDepthModel),
      depth_held_(cameras.size(), false) {
  result_.fallback.assign(n_, false);
  result_.depth_model.assign(n_, DepthModelEstimate{});
  result_.leveled.assign(n_, false);
  result_.covariance.assign(n_, Mat6::Zero());
  result_.sigma_inflation.assign(n_, SigmaInflation{});
  result_.surfaces.assign(n_, 0);
  result_.thickness_before.assign(n_, 0.0);
  result_.thickness_after.assign(n_, 0.0);
  for (size_t c = 0; c < n_; ++c) {
    poses_[c] = cameras[c].T_world_camera;
    PoseToParameters(poses_[c], blocks_[c].data());
  }
  result_.poses = poses_;
}

void BundleSolver::AddPoseAndPlaneBlocks(ceres::Problem* problem,
                                         ceres::ParameterBlockOrdering* ordering) {
  for (size_t c = 0; c < n_; ++c) {
    problem->AddParameterBlock(blocks_[c].data(), kPoseAmbientSize, SharedPoseManifold());
    if (ordering != nullptr) ordering->AddElementToGroup(blocks_[c].data(), 1);
    result_.fallback[c] = cameras_[c].free && !fixed_[c];
    if (!Free(c)) problem->SetParameterBlockConstant(blocks_[c].data());
  }
  for (PlaneBlock& plane : planes_) {
    problem->AddParameterBlock(
        plane.x.data(), 4,
        plane.floor ? static_cast<ceres::Manifold*>(&floor_manifold_) : &plane_manifold_);
    if (ordering != nullptr) ordering->AddElementToGroup(plane.x.data(), 0);
  }
}

void BundleSolver::AddPriors(ceres::Problem* problem, const std::vector<Mat6>& priors) {
  if (options_.gravity_weight > 0.0) {
    for (size_t c = 0; c < n_; ++c) {
      if (!Free(c)) continue;
      problem->AddResidualBlock(
          GravityPriorCost::Create(cameras_[c].T_world_leveled.linear(), options_.gravity_weight),
          nullptr, blocks_[c].data());
    }
  }
  for (size_t c = 0; c < n_; ++c) {
    if (priors.empty() || priors[c].isZero() || !Free(c)) continue;
    const Pose T0 = gauge_ * cameras_[c].T_world_camera;
    problem->AddResidualBlock(new PosePriorCost(T0, priors[c]), nullptr, blocks_[c].data());
  }
}

bool BundleSolver::SolveOnce(const std::vector<Mat6>& priors) {
  problem_ = NewProblem();
  priors_ = priors;
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  AddPoseAndPlaneBlocks(problem_.get(), ordering.get());
  AddDepthModels(ordering.get());
  for (const ClusterTerm& t : terms_) {
    double* pose = blocks_[t.camera].data();
    double* plane = planes_[t.plane].x.data();
    if (DepthSolved(t.camera)) {
      problem_->AddResidualBlock(PlaneClusterDepthCost::Create(t.cluster), nullptr, pose, plane,
                                 depth_[t.camera].data());
    } else {
      problem_->AddResidualBlock(PlaneClusterCost::Create(t.cluster, cameras_[t.camera].ray_model),
                                 nullptr, pose, plane);
    }
  }
  AddPriors(problem_.get(), priors);
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_SCHUR;
  solver_options.linear_solver_ordering = ordering;
  solver_options.max_num_iterations = kIterationsPerRound;
  // One thread: Ceres' Schur eliminator adds the chunks of a multi-threaded
  // elimination in whatever order the threads finish, so the last digits of the
  // poses changed from run to run; the reduced problem (a few hundred
  // 4-dimensional blocks) is small.
  solver_options.num_threads = 1;
  solver_options.logging_type = ceres::SILENT;
  summary_ = ceres::Solver::Summary{};
  ceres::Solve(solver_options, problem_.get(), &summary_);
  return summary_.IsSolutionUsable();
}

BundleSolver::Next BundleSolver::Round(int round, int rounds) {
  // The segmentation and the pixels' assignment see each camera's depth through its current
  // depth model (gated on the measured depth, a miscalibrated camera kept only the pixels that
  // agreed with no correction); the clusters hold the measured depth, which the residual
  // corrects.
  std::vector<SurfaceCamera> corrected;
  const std::vector<SurfaceCamera>& seen = CorrectedCameras(&corrected);
  const MergedCloud cloud = Merge(seen, poses_, num_threads_);
  PlaneSegmentationOptions segmentation;
  segmentation.voxel_size = options_.voxel_size;
  segmentation.min_noise_m = options_.min_noise_m;
  segmentation.leveled_floor =
      std::any_of(cameras_.begin(), cameras_.end(),
                  [](const SurfaceCamera& camera) { return camera.floor_leveled; });
  segmentation.model_sigma_voxels =
      kRoundModelVoxels[std::min<size_t>(round, kRoundModelVoxels.size() - 1)];
  const std::vector<SegmentedPlane> segmented =
      SegmentPlanes(cloud.points, static_cast<int>(n_), segmentation, num_threads_);
  if (segmented.empty()) {
    result_.message = "surface bundle: no plane is seen by two cameras";
    return Next::kStop;
  }
  planes_.clear();
  for (const SegmentedPlane& s : segmented) {
    planes_.push_back({Vec4(s.normal.x(), s.normal.y(), s.normal.z(), s.offset), s.floor});
  }
  terms_ = Clusters(seen, cloud, segmented);
  PredictedHeightWindow(seen, poses_, planes_, segmentation, &terms_);
  // The last round's pixels by their rays, from the segmentation at the poses
  // of the previous rounds' solves.
  if (round == rounds - 1) {
    AssignByRays(seen, poses_, planes_, segmentation, num_threads_, &terms_);
    if (options_.surface_faces == SurfaceFaces::kImage &&
        !AssignByImageFaces(seen, poses_, segmentation, num_threads_, &planes_, &terms_)) {
      log_.Debug("surface bundle: a camera without a depth image: the faces by rays");
    }
  }
  correlation_ = measured_;
  FillClusters(cameras_, options_, correlation_, &terms_);
  if (round == 0) {
    result_.thickness_before =
        Thickness(terms_, TermCosts(terms_, cameras_, blocks_, planes_, depth_), n_);
  }
  const PlaneSupport support = PlanesFixPose(terms_, planes_, cameras_);
  fixed_ = support.fixed;
  untied_.assign(n_, false);
  for (size_t c = 0; c < n_; ++c) {
    // Untied, a camera is held along the directions its planes share with free
    // cameras alone by its start, with the start's covariance; without one, at
    // its start.
    if (!cameras_[c].free || !fixed_[c] || support.tied[c]) continue;
    untied_[c] = true;
    if (cameras_[c].start_covariance.isZero()) fixed_[c] = false;
  }
  DropUnfixedCameras(cameras_, fixed_, &terms_, &planes_);
  if (!SolveOnce(UntiedPriors())) {
    // The previous round's poses stand (the start's in the first round).
    result_.message = "surface bundle: " + summary_.message;
    result_.poses = poses_;
    return Next::kReturn;
  }
  gauge_ = LevelReference(cameras_, terms_, planes_, &blocks_, &result_.leveled) * gauge_;
  for (size_t c = 0; c < n_; ++c) poses_[c] = PoseFromParameters(blocks_[c].data());
  measured_ = NoiseCorrelation(terms_, cameras_, blocks_, planes_, depth_, options_);
  int pixels = 0;
  for (const ClusterTerm& t : terms_) pixels += t.cluster.Count();
  result_.planes = static_cast<int>(planes_.size());
  result_.pixels = pixels;
  result_.rounds = round + 1;
  result_.usable = true;
  if (options_.keep_surface_diagnostics) RecordUse(planes_, terms_, &result_);
  LogRound(round, pixels);
  return Next::kContinue;
}

void BundleSolver::LogRound(int round, int pixels) const {
  log_.Debug("surface bundle: round " + std::to_string(round) + ": " +
             std::to_string(planes_.size()) + " planes, " + std::to_string(pixels) +
             " pixels, cost " + Fixed(2.0 * summary_.final_cost / std::max(pixels, 1), 4) +
             " per pixel, " + std::to_string(summary_.iterations.size()) + " iterations");
  std::string measured_text;
  for (const double m : measured_) measured_text += " " + Fixed(m, 1);
  log_.Debug("surface bundle: noise correlation per camera" + measured_text);
}

void BundleSolver::Statistics() {
  // Each pixel's own squared whitened residual, without the correlation's
  // weight.
  std::vector<double> costs = TermCosts(terms_, cameras_, blocks_, planes_, depth_);
  for (size_t k = 0; k < terms_.size(); ++k) costs[k] *= correlation_[terms_[k].camera];
  result_.thickness_after = Thickness(terms_, costs, n_);
  std::vector<SurfaceOrientations> orientations(n_);
  for (const ClusterTerm& t : terms_) {
    orientations[t.camera].Add(planes_[t.plane].Normal(), t.cluster.Count());
  }
  for (size_t c = 0; c < n_; ++c) result_.surfaces[c] = orientations[c].Count();
  int parameters = 0;
  for (size_t c = 0; c < n_; ++c) {
    if (Free(c)) parameters += 6;
  }
  for (const PlaneBlock& plane : planes_) parameters += plane.floor ? 1 : 3;
  double total = 0.0;
  for (const double cost : costs) total += cost;
  const int dof = result_.pixels - parameters;
  result_.noise_scale = dof > 0 ? std::sqrt(total / dof) : 0.0;
  std::vector<double*> free_poses, plane_blocks;
  std::vector<size_t> free_cameras;
  for (size_t c = 0; c < n_; ++c) {
    if (!Free(c)) continue;
    free_poses.push_back(blocks_[c].data());
    free_cameras.push_back(c);
  }
  for (PlaneBlock& plane : planes_) plane_blocks.push_back(plane.x.data());
  for (size_t c = 0; c < n_; ++c) {
    if (DepthSolved(c)) free_poses.push_back(depth_[c].data());  // marginalised with the planes
  }
  // The noise model's covariance, scaled by the residuals' spread, raised where
  // the planes' residuals scatter more than it says (the cluster-robust
  // covariance: each plane's model error and wrong pixels, which the noise
  // model does not know).
  Eigen::MatrixXd robust;
  const Eigen::MatrixXd model =
      result_.noise_scale * result_.noise_scale *
      MarginalPoseCovariance(problem_.get(), free_poses, plane_blocks, &robust);
  result_.covariance_ok = model.size() > 0;
  if (!result_.covariance_ok) return;
  const bool with_robust = robust.size() > 0 && result_.noise_scale > 0.0;
  const Eigen::MatrixXd planes = with_robust ? CovarianceAtLeast(model, robust) : model;
  // Reported: the planes' part of the information raised by the design effect
  // of the pixels' residuals, the priors' by the start's inflation, and at least
  // the planes' cluster-robust covariance.
  ClusterSandwiches sandwiches;
  Eigen::MatrixXd priors;
  const Eigen::MatrixXd unscaled = PixelSandwiches(free_poses, plane_blocks, &sandwiches, &priors);
  Eigen::MatrixXd covariance = model;
  if (unscaled.size() > 0) {
    Eigen::VectorXd pixels(model.rows()), start(model.rows());
    for (size_t k = 0; k < free_cameras.size(); ++k) {
      const SigmaInflation f = InflationOf(sandwiches, 6 * static_cast<int>(k));
      const SigmaInflation& g = cameras_[free_cameras[k]].start_inflation;
      pixels.segment<6>(6 * k) << Vec3::Constant(f.rotation), Vec3::Constant(f.translation);
      start.segment<6>(6 * k) << Vec3::Constant(g.rotation), Vec3::Constant(g.translation);
    }
    covariance =
        result_.noise_scale * result_.noise_scale *
        (pixels.asDiagonal() * (unscaled - unscaled * priors * unscaled) * pixels.asDiagonal() +
         unscaled * start.asDiagonal() * priors * start.asDiagonal() * unscaled);
  }
  if (with_robust) covariance = CovarianceAtLeast(covariance, robust);
  // The surfaces' offsets (stereo cameras) widen the 1-sigma after the inflation.
  const Eigen::MatrixXd bias = SurfaceBiasCovariance(free_poses, plane_blocks);
  for (size_t k = 0; k < free_cameras.size(); ++k) {
    const size_t c = free_cameras[k];
    planes_covariance_[c] = planes.block<6, 6>(6 * k, 6 * k);
    result_.covariance[c] = covariance.block<6, 6>(6 * k, 6 * k);
    result_.sigma_inflation[c] =
        InflationBetween(model.block<6, 6>(6 * k, 6 * k), result_.covariance[c]);
    if (bias.size() > 0) result_.covariance[c] += bias.block<6, 6>(6 * k, 6 * k);
  }
}

Eigen::MatrixXd BundleSolver::PixelSandwiches(const std::vector<double*>& free_poses,
                                              const std::vector<double*>& plane_blocks,
                                              ClusterSandwiches* sandwiches,
                                              Eigen::MatrixXd* priors) {
  // A camera's depth model is not in the split problem: with one, the reported covariance
  // stays the planes' (Statistics; docs/uncertainty.md).
  for (size_t c = 0; c < n_; ++c) {
    if (DepthSolved(c)) return {};
  }
  // The terms split: one atom per (term, cube, tile), its cube's cluster.
  std::vector<ClusterTerm> atoms;
  BlockClusters clusters;
  int cubes = 0;
  for (const ClusterTerm& t : terms_) {
    const SurfaceCamera& camera = cameras_[t.camera];
    const Pose T = PoseFromParameters(blocks_[t.camera].data());
    const bool tiles = camera.ray_model && camera.pixel_angle > 0.0;
    std::unordered_map<std::array<int64_t, 3>, int, KeyHash> cube_of;
    std::unordered_map<std::array<int64_t, 5>, int, KeyHash> atom_of;
    for (const int i : t.pixels) {
      const Vec3& p = camera.points[i];
      const std::array<int64_t, 3> cube = CellOf(T * p, kCovarianceCellM);
      const auto [cube_it, new_cube] = cube_of.try_emplace(cube, cubes);
      if (new_cube) ++cubes;
      const auto tile = tiles ? TileOf(camera, p) : std::pair<long long, long long>{0, 0};
      const auto [atom_it, new_atom] = atom_of.try_emplace(
          {cube[0], cube[1], cube[2], tile.first, tile.second}, static_cast<int>(atoms.size()));
      if (new_atom) {
        atoms.push_back({t.camera, t.plane, PlaneCluster{}, {}});
        clusters.fine.push_back(atom_it->second);
        clusters.coarse.push_back(cube_it->second);
      }
      AddPixel(camera, options_, std::sqrt(correlation_[t.camera]), i,
               &atoms[atom_it->second].cluster);
    }
  }
  const std::unique_ptr<ceres::Problem> split = NewProblem();
  AddPoseAndPlaneBlocks(split.get(), nullptr);
  for (const ClusterTerm& a : atoms) {
    split->AddResidualBlock(PlaneClusterCost::Create(a.cluster, cameras_[a.camera].ray_model),
                            nullptr, blocks_[a.camera].data(), planes_[a.plane].x.data());
  }
  AddPriors(split.get(), priors_);
  std::vector<ceres::ResidualBlockId> residual_blocks;
  split->GetResidualBlocks(&residual_blocks);
  clusters.fine.resize(residual_blocks.size(), -1);  // the priors: in none
  clusters.coarse.resize(residual_blocks.size(), -1);
  return MarginalPoseSandwiches(split.get(), free_poses, plane_blocks, clusters, sandwiches,
                                priors);
}

Eigen::MatrixXd BundleSolver::SurfaceBiasCovariance(const std::vector<double*>& free_poses,
                                                    const std::vector<double*>& plane_blocks) {
  bool any = false;
  for (size_t c = 0; c < n_; ++c) {
    if (DepthSolved(c)) return {};
    any = any || (Free(c) && cameras_[c].surface_bias > 0.0);
  }
  if (!any) return {};
  const std::unique_ptr<ceres::Problem> problem = NewProblem();
  AddPoseAndPlaneBlocks(problem.get(), nullptr);
  BlockClusters clusters;
  for (size_t k = 0; k < terms_.size(); ++k) {
    const ClusterTerm& t = terms_[k];
    const SurfaceCamera& camera = cameras_[t.camera];
    problem->AddResidualBlock(
        new SurfaceBiasShift(t.cluster.SquareRoot(), camera.ray_model, camera.surface_bias),
        nullptr, blocks_[t.camera].data(), planes_[t.plane].x.data());
    clusters.fine.push_back(static_cast<int>(k));
    clusters.coarse.push_back(static_cast<int>(k));
  }
  AddPriors(problem.get(), priors_);
  clusters.fine.resize(problem->NumResidualBlocks(), -1);  // the priors: in none
  clusters.coarse.resize(problem->NumResidualBlocks(), -1);
  ClusterSandwiches sandwiches;
  if (MarginalPoseSandwiches(problem.get(), free_poses, plane_blocks, clusters, &sandwiches)
          .size() == 0) {
    return {};
  }
  return sandwiches.fine;
}

std::vector<Mat6> BundleSolver::UntiedPriors() const {
  std::vector<Mat6> priors(n_, Mat6::Zero());
  for (size_t c = 0; c < n_; ++c) {
    if (!untied_[c] || !fixed_[c]) continue;
    const Mat6 information = cameras_[c].start_covariance.inverse() / kUntiedPriorInflation;
    priors[c] = information.llt().matrixL().transpose();  // W^T W = information
  }
  return priors;
}

bool BundleSolver::StartPriors(std::vector<Mat6>* priors) const {
  priors->assign(n_, Mat6::Zero());
  int held = 0;
  for (size_t c = 0; c < n_; ++c) {
    if (!Free(c) || cameras_[c].start_covariance.isZero()) continue;
    if (untied_[c]) {
      (*priors)[c] = UntiedPriors()[c];
      ++held;
      continue;
    }
    // The start measured a camera with a depth model through its uncorrected depth: held by
    // it, a camera 0.1 px off kept 57 % of its offset (white noise, seed 0; -4 % without).
    if (DepthSolved(c)) continue;
    int directions = 0;
    (*priors)[c] =
        WeakDirectionPrior(cameras_[c].start_covariance, planes_covariance_[c], &directions);
    held += directions;
  }
  if (held > 0) {
    log_.Debug("surface bundle: the start holds " + std::to_string(held) + " weak directions");
  }
  return held > 0;
}

SurfaceBundleResult BundleSolver::Run() {
  const int rounds = std::max(1, options_.surface_rounds);
  for (int round = 0; round < rounds; ++round) {
    const Next next = Round(round, rounds);
    if (next == Next::kReturn) return result_;
    if (next == Next::kStop) break;
  }
  if (!result_.usable) return result_;
  result_.poses = poses_;
  result_.noise_correlation = correlation_;
  Statistics();
  // Planes do not see their own boundaries, which the joint point-to-plane
  // solve (the start) does: along the directions where the planes know a
  // camera's pose less well than the start does, the start enters as a prior
  // with its covariance, and the last round is solved again.
  std::vector<Mat6> priors;
  if (result_.covariance_ok && StartPriors(&priors) && !Resolve(priors)) return result_;
  if (options_.depth_model != CameraDepthModel::kNone) {
    HoldUnobservableDepthModels(priors.empty() ? UntiedPriors() : priors);
  }
  return result_;
}

bool BundleSolver::Resolve(const std::vector<Mat6>& priors) {
  if (!SolveOnce(priors)) {
    result_.message = "surface bundle: " + summary_.message;
    return false;
  }
  for (size_t c = 0; c < n_; ++c) result_.poses[c] = PoseFromParameters(blocks_[c].data());
  Statistics();
  return true;
}

const std::vector<SurfaceCamera>& BundleSolver::CorrectedCameras(
    std::vector<SurfaceCamera>* storage) const {
  if (std::all_of(depth_.begin(), depth_.end(),
                  [](const DepthBlock& d) { return d == kNoDepthModel; })) {
    return cameras_;
  }
  *storage = cameras_;
  for (size_t c = 0; c < n_; ++c) {
    // On its ray, at the depth 1 / (alpha / z + beta).
    for (Vec3& p : (*storage)[c].points) p /= depth_[c][0] + depth_[c][1] * p.z();
  }
  return *storage;
}

void BundleSolver::AddDepthModels(ceres::ParameterBlockOrdering* ordering) {
  for (size_t c = 0; c < n_; ++c) {
    if (!DepthSolved(c)) continue;
    // An offset alone: alpha stays 1.
    if (options_.depth_model == CameraDepthModel::kOffset) depth_[c][0] = 1.0;
    problem_->AddParameterBlock(
        depth_[c].data(), kDepthModelSize,
        options_.depth_model == CameraDepthModel::kOffset ? &offset_manifold_ : nullptr);
    ordering->AddElementToGroup(depth_[c].data(), 1);
    const Eigen::Vector2d sigma = DepthPriorSigma(c);
    problem_->AddResidualBlock(
        new ceres::NormalPrior(sigma.cwiseInverse().asDiagonal().toDenseMatrix(),
                               Eigen::Vector2d(kNoDepthModel[0], kNoDepthModel[1])),
        nullptr, depth_[c].data());
  }
}

Eigen::Vector2d BundleSolver::DepthPriorSigma(size_t c) const {
  const SurfaceCamera& camera = cameras_[c];
  double offset = 0.0;
  if (camera.baseline_m > 0.0 && camera.pixel_angle > 0.0) {
    // A disparity offset delta (px) is delta / (fx baseline) in inverse depth.
    offset = options_.depth_offset_sigma_px * camera.pixel_angle / camera.baseline_m;
  } else {
    // The scale prior's effect at the camera's mean inverse depth.
    double sum = 0.0;
    for (const Vec3& p : camera.points) sum += 1.0 / p.z();
    offset = options_.depth_scale_sigma * sum / std::max<size_t>(camera.points.size(), 1);
  }
  return {options_.depth_scale_sigma, offset};
}

bool BundleSolver::MeasureDepthModels() {
  std::vector<double*> blocks, plane_blocks;
  std::vector<int> pose_column(n_, -1);
  for (size_t c = 0; c < n_; ++c) {
    if (!Free(c)) continue;
    pose_column[c] = 6 * static_cast<int>(blocks.size());
    blocks.push_back(blocks_[c].data());
  }
  std::vector<int> depth_column(n_, -1);
  int column = 6 * static_cast<int>(blocks.size());
  for (size_t c = 0; c < n_; ++c) {
    if (!DepthSolved(c)) continue;
    depth_column[c] = column;
    column += problem_->ParameterBlockTangentSize(depth_[c].data());
    blocks.push_back(depth_[c].data());
  }
  for (PlaneBlock& plane : planes_) plane_blocks.push_back(plane.x.data());
  // The noise model's information with the priors': what the data add to the prior.
  const Eigen::MatrixXd covariance = MarginalPoseCovariance(problem_.get(), blocks, plane_blocks);
  const bool scale = options_.depth_model == CameraDepthModel::kScaleOffset;
  bool unobservable = false;
  for (size_t c = 0; c < n_; ++c) {
    DepthModelEstimate& e = result_.depth_model[c];
    e = DepthModelEstimate{};
    if (!cameras_[c].free || !cameras_[c].ray_model) continue;
    const Eigen::Vector2d prior = DepthPriorSigma(c);
    e.scale_prior_sigma = scale ? prior(0) : 0.0;
    e.offset_prior_sigma = prior(1);
    if (!DepthSolved(c)) continue;
    e.solved = true;
    e.scale = depth_[c][0];
    e.offset = depth_[c][1];
    if (cameras_[c].baseline_m > 0.0 && cameras_[c].pixel_angle > 0.0) {
      e.offset_px = e.offset * cameras_[c].baseline_m / cameras_[c].pixel_angle;
    }
    e.observable = covariance.size() > 0;
    // The tangent of [alpha, beta]: both, or beta alone.
    for (int k = 0; covariance.size() > 0 && k < (scale ? 2 : 1); ++k) {
      const int j = depth_column[c] + k;
      const double sigma = std::sqrt(covariance(j, j));
      const bool is_scale = scale && k == 0;
      (is_scale ? e.scale_sigma : e.offset_sigma) = sigma;
      e.observable =
          e.observable && sigma <= kDepthObservableSigmaRatio * (is_scale ? prior(0) : prior(1));
      for (int i = pose_column[c]; i < pose_column[c] + 6; ++i) {
        e.pose_correlation =
            std::max(e.pose_correlation,
                     std::abs(covariance(i, j)) / std::sqrt(covariance(i, i) * covariance(j, j)));
      }
    }
    unobservable = unobservable || !e.observable;
  }
  return unobservable;
}

void BundleSolver::HoldUnobservableDepthModels(const std::vector<Mat6>& priors) {
  if (!result_.usable || problem_ == nullptr || !MeasureDepthModels()) return;
  for (size_t c = 0; c < n_; ++c) {
    if (!DepthSolved(c) || result_.depth_model[c].observable) continue;
    depth_held_[c] = true;
    depth_[c] = kNoDepthModel;
  }
  const std::vector<DepthModelEstimate> measured = result_.depth_model;
  if (!Resolve(priors)) return;
  MeasureDepthModels();
  // The held ones as they were measured, at scale 1 and offset 0.
  for (size_t c = 0; c < n_; ++c) {
    if (!depth_held_[c]) continue;
    result_.depth_model[c] = measured[c];
    result_.depth_model[c].solved = false;
    result_.depth_model[c].scale = 1.0;
    result_.depth_model[c].offset = result_.depth_model[c].offset_px = 0.0;
  }
}

}  // namespace

SurfaceBundleResult RegisterSurfaceBundle(const std::vector<SurfaceCamera>& cameras,
                                          const IcpOptions& options, int num_threads,
                                          const Log& log) {
  return BundleSolver(cameras, options, num_threads, log).Run();
}

}  // namespace rigfit

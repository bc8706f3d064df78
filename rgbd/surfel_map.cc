#include "rgbd/surfel_map.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "core/parallel.h"

namespace rigfit {

namespace {

constexpr double kPi = 3.14159265358979323846;
/// The smallest |n_z| of the radius (cos 75 degrees).
constexpr float kMinRadiusCosine = 0.26f;
/// How many pixels ahead the merge asks for the map point it will update (Prefetch).
constexpr int kPrefetchAhead = 16;

/// Pixel j's colour of an RGB image ([height, width, 3]).
Vec3f PixelColor(const std::vector<std::uint8_t>& color, int j) {
  return Vec3f(color[3 * j], color[3 * j + 1], color[3 * j + 2]);
}

}  // namespace

float SurfelRadius(float z, float n_z, double focal_px) {
  return static_cast<float>(z / focal_px) / std::max(std::abs(n_z), kMinRadiusCosine);
}

bool MapView::Covers(const FrameLevel& frame, const Pose& T_world_camera_now, int map_size_now,
                     double max_distance_m) const {
  if (map_size != map_size_now || frame.width != width || frame.height != height ||
      frame.intrinsics.fx != intrinsics.fx || frame.intrinsics.fy != intrinsics.fy ||
      frame.intrinsics.cx != intrinsics.cx || frame.intrinsics.cy != intrinsics.cy) {
    return false;
  }
  // The nearest a point can be and still pass the distance gate of some valid pixel.
  float nearest = std::numeric_limits<float>::infinity();
  for (const int j : frame.valid_pixels) nearest = std::min(nearest, frame.vertices[j].z());
  const Pose delta = T_world_camera.inverse() * T_world_camera_now;  // view <- now
  const double dt = delta.translation().norm();
  const double dtheta = Eigen::AngleAxisd(delta.linear()).angle();
  const double z_low = nearest - max_distance_m - dt;  // in the view's camera
  if (!(z_low >= kMinDepthM)) return false;
  // The largest |x / z| and |y / z| in the image and its margin.
  const double a =
      std::max(intrinsics.cx + margin_px + 0.5, width - 0.5 + margin_px - intrinsics.cx) /
      intrinsics.fx;
  const double b =
      std::max(intrinsics.cy + margin_px + 0.5, height - 0.5 + margin_px - intrinsics.cy) /
      intrinsics.fy;
  const double f = std::max(intrinsics.fx, intrinsics.fy);
  const double bound_px =
      1.5 * f * (dtheta * std::sqrt(1.0 + a * a + b * b) + dt / z_low) * (1.0 + std::max(a, b));
  return bound_px < margin_px;
}

double SurfelMap::CompressionRatio() const {
  return positions_.empty() ? 0.0 : static_cast<double>(input_points_) / positions_.size();
}

namespace {

/// The 21 low bits of v spread to every third bit (bit k to bit 3k).
std::uint64_t SpreadBits(std::uint64_t v) {
  v &= 0x1fffff;
  v = (v | v << 32) & 0x1f00000000ffff;
  v = (v | v << 16) & 0x1f0000ff0000ff;
  v = (v | v << 8) & 0x100f00f00f00f00f;
  v = (v | v << 4) & 0x10c30c30c30c30c3;
  v = (v | v << 2) & 0x1249249249249249;
  return v;
}

/// v's elements from `first` on in the order `order` (a permutation of [first, v->size())).
template <typename T>
void Permute(const std::vector<int>& order, int first, std::vector<T>* v) {
  if (v->empty()) return;
  std::vector<T> sorted(order.size());
  for (std::size_t k = 0; k < order.size(); ++k) sorted[k] = (*v)[order[k]];
  std::copy(sorted.begin(), sorted.end(), v->begin() + first);
}

}  // namespace

void SurfelMap::SortNewPoints(double cell_m) {
  if (!(cell_m > 0.0)) throw std::invalid_argument("SurfelMap::SortNewPoints: cell_m must be > 0");
  const int n = size();
  // Cell coordinates offset by 2^20: 21 bits each, +-2^20 cells.
  const float scale = static_cast<float>(1.0 / cell_m);
  const auto coordinate = [](float c) {
    return static_cast<std::uint64_t>(std::clamp(std::floor(c) + 1048576.0f, 0.0f, 2097151.0f));
  };
  std::vector<std::pair<std::uint64_t, int>> keyed;
  keyed.reserve(n - sorted_);
  for (int i = sorted_; i < n; ++i) {
    const Vec3f cell = positions_[i] * scale;
    keyed.emplace_back(SpreadBits(coordinate(cell.x())) | SpreadBits(coordinate(cell.y())) << 1 |
                           SpreadBits(coordinate(cell.z())) << 2,
                       i);
  }
  std::sort(keyed.begin(), keyed.end());  // one cell's points by index: their order kept
  std::vector<int> order(keyed.size());
  for (std::size_t k = 0; k < keyed.size(); ++k) order[k] = keyed[k].second;
  Permute(order, sorted_, &positions_);
  Permute(order, sorted_, &normals_);
  Permute(order, sorted_, &colors_);
  Permute(order, sorted_, &weights_);
  Permute(order, sorted_, &radii_);
  Permute(order, sorted_, &last_seen_);
  sorted_ = n;
}

void SurfelMap::MovePoints(const std::function<Pose(int frame_index)>& correction) {
  int frame = -1;
  Eigen::Matrix3f R = Eigen::Matrix3f::Identity();
  Vec3f t = Vec3f::Zero();
  for (std::size_t i = 0; i < positions_.size(); ++i) {
    if (last_seen_[i] != frame) {  // points of one frame often lie together
      frame = last_seen_[i];
      const Pose C = correction(frame);
      R = C.linear().cast<float>();
      t = C.translation().cast<float>();
    }
    positions_[i] = R * positions_[i] + t;
    normals_[i] = R * normals_[i];
  }
}

/// A frame's camera as the fusion's gates see it (single precision).
struct FusionCamera {
  FusionCamera(const FrameLevel& frame_in, const Pose& T_world_camera_in,
               const FusionOptions& options)
      : frame(frame_in),
        T_world_camera(T_world_camera_in),
        R(T_world_camera.linear().cast<float>()),
        R_cw(R.transpose()),
        t(T_world_camera.translation().cast<float>()),
        fx(static_cast<float>(frame.intrinsics.fx)),
        fy(static_cast<float>(frame.intrinsics.fy)),
        cx(static_cast<float>(frame.intrinsics.cx)),
        cy(static_cast<float>(frame.intrinsics.cy)),
        max_distance_sq(static_cast<float>(options.max_distance_m * options.max_distance_m)),
        min_cosine(static_cast<float>(std::cos(options.max_normal_angle_deg * kPi / 180.0))) {}

  /// The pixel the map point (p_w, n_w) projects to, when `usable` (checked before the gates:
  /// a pixel without a vertex has nothing to gate against) and within the pixel's distance
  /// and normal gates; -1 otherwise. *p_c: the point in the camera frame.
  template <typename Usable>
  int GatedPixel(const Vec3f& p_w, const Vec3f& n_w, const Usable& usable, Vec3f* p_c) const {
    *p_c = R_cw * (p_w - t);
    if (!(p_c->z() > 0.0f)) return -1;
    const int u = NearestPixel(fx * p_c->x() / p_c->z() + cx);
    const int v = NearestPixel(fy * p_c->y() / p_c->z() + cy);
    if (u < 0 || v < 0 || u >= frame.width || v >= frame.height) return -1;
    const int j = v * frame.width + u;
    if (!usable(j)) return -1;
    if ((*p_c - frame.vertices[j]).squaredNorm() >= max_distance_sq) return -1;
    if ((R_cw * n_w).dot(frame.normals[j]) <= min_cosine) return -1;
    return j;
  }

  const FrameLevel& frame;
  Pose T_world_camera;
  Eigen::Matrix3f R;
  Eigen::Matrix3f R_cw;
  Vec3f t;
  float fx, fy, cx, cy;
  float max_distance_sq;
  float min_cosine;
};

FusionStats SurfelMap::FuseFrame(const FrameLevel& frame, const Pose& T_world_camera,
                                 int frame_index, const FusionOptions& options,
                                 const std::vector<std::uint8_t>& color,
                                 const FusionExecution& execution) {
  CheckFrame(frame, color);
  ++frames_;
  const FusionCamera camera(frame, T_world_camera, options);
  FusionStats stats;
  stats.projected = Associate(camera, options, execution);
  const std::vector<std::uint64_t>& match = zbuffer_.Merge();
  stats.input_points = static_cast<int>(frame.valid_pixels.size());
  input_points_ += stats.input_points;
  MergeMatched(camera, match, color, frame_index, execution.threads);
  if (options.fold_overlapping) {
    stats.folded = FoldOverlapping(camera, match, execution.threads);
  }
  AddUnmatched(camera, match, options, color, frame_index, &stats);
  // Every valid pixel merged, was covered or was added.
  stats.merged = stats.input_points - stats.covered - stats.added;
  // 4. Remove dormant unstable points (and the folded ones).
  if (options.dormant_frames > 0 || stats.folded > 0) RemoveDormant(frame_index, options, &stats);
  return stats;
}

void SurfelMap::CheckFrame(const FrameLevel& frame, const std::vector<std::uint8_t>& color) {
  const std::size_t pixels = static_cast<std::size_t>(frame.width) * frame.height;
  if (frame.width <= 0 || frame.height <= 0 || frame.vertices.size() != pixels ||
      frame.normals.size() != pixels) {
    throw std::invalid_argument("SurfelMap::FuseFrame: vertex and normal maps must hold " +
                                std::to_string(pixels) + " pixels");
  }
  const bool with_color = !color.empty();
  if (with_color && color.size() != 3 * pixels) {
    throw std::invalid_argument("SurfelMap::FuseFrame: colour must be [height, width, 3] (" +
                                std::to_string(3 * pixels) + " bytes), got " +
                                std::to_string(color.size()));
  }
  if (frames_ == 0) {
    has_color_ = with_color;
  } else if (with_color != has_color_) {
    throw std::invalid_argument(has_color_
                                    ? "SurfelMap::FuseFrame: the map has colours, the frame none"
                                    : "SurfelMap::FuseFrame: the map has no colours");
  }
}

/// 1. Association through projection: per pixel the candidate closest to the camera (each
/// thread projects its share of the points into its own z-buffer; rgbd/zbuffer.h). Returns the
/// number of map points projected.
int SurfelMap::Associate(const FusionCamera& camera, const FusionOptions& options,
                         const FusionExecution& execution) {
  const FrameLevel& frame = camera.frame;
  const MapView* view = execution.view;
  const bool use_view =
      view != nullptr && view->Covers(frame, camera.T_world_camera, size(), options.max_distance_m);
  // Through a view: one thread per part of it (the parts the rendering's threads collected).
  const int chunks =
      use_view ? static_cast<int>(view->parts.size()) : std::max(1, execution.threads);
  zbuffer_.Reset(frame.width * frame.height, chunks);
  const auto valid = [&](int j) { return frame.Valid(j); };
  const auto associate = [&](std::uint64_t* keys, int i) {
    Vec3f p_c;
    const int j = camera.GatedPixel(positions_[i], normals_[i], valid, &p_c);
    if (j >= 0) ZBuffer::Write(keys, j, ZBuffer::Key(p_c.z(), i));
  };
  if (!use_view) {
    ParallelForChunks(size(), chunks, [&](int c, int begin, int end) {
      std::uint64_t* keys = zbuffer_.Thread(c);
      for (int i = begin; i < end; ++i) associate(keys, i);
    });
    return size();
  }
  int projected = 0;
  for (const std::vector<int>& part : view->parts) projected += static_cast<int>(part.size());
  ParallelForChunks(chunks, chunks, [&](int c, int, int) {
    std::uint64_t* keys = zbuffer_.Thread(c);
    for (const int i : view->parts[c]) associate(keys, i);
  });
  return projected;
}
void SurfelMap::Prefetch(std::uint64_t key) const {
  if (key == ZBuffer::kEmpty) return;
  const int i = ZBuffer::Index(key);
  __builtin_prefetch(&positions_[i], 1);
  __builtin_prefetch(&normals_[i], 1);
  if (has_color_) __builtin_prefetch(&colors_[i], 1);
  __builtin_prefetch(&weights_[i], 1);
  __builtin_prefetch(&radii_[i], 1);
  __builtin_prefetch(&last_seen_[i], 1);
}

/// 2. Merge (in parallel: a map point is the candidate of one pixel at most). The points a
/// frame merges into lie all over the map's arrays: each is asked for kPrefetchAhead pixels
/// before it is updated, so that its cache lines arrive while the merges before it are done.
void SurfelMap::MergeMatched(const FusionCamera& camera, const std::vector<std::uint64_t>& match,
                             const std::vector<std::uint8_t>& color, int frame_index, int threads) {
  const FrameLevel& frame = camera.frame;
  const double focal_px = 0.5 * (frame.intrinsics.fx + frame.intrinsics.fy);
  const bool with_color = !color.empty();
  const int pixels = static_cast<int>(frame.valid_pixels.size());
  ParallelForChunks(pixels, threads, [&](int, int begin, int end) {
    for (int k = begin; k < end; ++k) {
      if (k + kPrefetchAhead < end) Prefetch(match[frame.valid_pixels[k + kPrefetchAhead]]);
      const int j = frame.valid_pixels[k];
      if (match[j] == ZBuffer::kEmpty) continue;
      const int i = ZBuffer::Index(match[j]);
      const Vec3f& q = frame.vertices[j];
      const Vec3f& n_q = frame.normals[j];
      const float w = weights_[i];
      positions_[i] = (w * positions_[i] + camera.R * q + camera.t) / (w + 1.0f);
      normals_[i] = (w * normals_[i] + camera.R * n_q).normalized();
      if (with_color) colors_[i] = (w * colors_[i] + PixelColor(color, j)) / (w + 1.0f);
      weights_[i] = w + 1.0f;
      radii_[i] = std::min(radii_[i], SurfelRadius(q.z(), n_q.z(), focal_px));
      last_seen_[i] = frame_index;
    }
  });
}

/// 2b. Fold: a map point B that projects to a pixel which merged into another point A, and
/// passes that pixel's gates, is folded into A when their discs overlap (|p_B - p_A| <
/// r_A + r_B) and their normals agree: the same piece of surface twice (Keller et al.,
/// section 4.3). Found in parallel, folded in index order (several B may fold into one A).
/// Returns the number folded (their weight set to 0, removed by RemoveDormant).
int SurfelMap::FoldOverlapping(const FusionCamera& camera, const std::vector<std::uint64_t>& match,
                               int threads) {
  const int map_size = size();
  fold_into_.assign(map_size, -1);
  const auto merged_into = [&](int j) { return match[j] != ZBuffer::kEmpty; };
  ParallelForChunks(map_size, threads, [&](int, int begin, int end) {
    for (int i = begin; i < end; ++i) {
      Vec3f p_c;
      const int j = camera.GatedPixel(positions_[i], normals_[i], merged_into, &p_c);
      if (j < 0) continue;
      const int a = ZBuffer::Index(match[j]);
      if (a == i) continue;
      const float overlap = radii_[a] + radii_[i];
      if ((positions_[i] - positions_[a]).squaredNorm() >= overlap * overlap) continue;
      if (normals_[i].dot(normals_[a]) <= camera.min_cosine) continue;
      fold_into_[i] = a;
    }
  });
  int folded = 0;
  for (int i = 0; i < map_size; ++i) {
    const int a = fold_into_[i];
    if (a < 0) continue;
    const float w_a = weights_[a];
    const float w_b = weights_[i];
    positions_[a] = (w_a * positions_[a] + w_b * positions_[i]) / (w_a + w_b);
    normals_[a] = (w_a * normals_[a] + w_b * normals_[i]).normalized();
    if (has_color_) colors_[a] = (w_a * colors_[a] + w_b * colors_[i]) / (w_a + w_b);
    weights_[a] = w_a + w_b;
    radii_[a] = std::min(radii_[a], radii_[i]);
    weights_[i] = 0.0f;  // removed by RemoveDormant
    ++folded;
  }
  return folded;
}

/// 3. Add each valid pixel that merged into no point, unless a 4-neighbour merged into a point
/// whose disc (radius scaled by cover_radius_scale) holds the pixel's vertex, with a normal
/// within the angle gate (covered).
void SurfelMap::AddUnmatched(const FusionCamera& camera, const std::vector<std::uint64_t>& match,
                             const FusionOptions& options, const std::vector<std::uint8_t>& color,
                             int frame_index, FusionStats* stats) {
  const FrameLevel& frame = camera.frame;
  const float cover_scale_sq =
      static_cast<float>(options.cover_radius_scale * options.cover_radius_scale);
  const auto covered = [&](int j) {
    if (!(cover_scale_sq > 0.0f)) return false;
    const int u = j % frame.width;
    const int v = j / frame.width;
    const int neighbours[4][2] = {{u - 1, v}, {u + 1, v}, {u, v - 1}, {u, v + 1}};
    for (const auto& [un, vn] : neighbours) {
      if (un < 0 || vn < 0 || un >= frame.width || vn >= frame.height) continue;
      const std::uint64_t key = match[vn * frame.width + un];
      if (key == ZBuffer::kEmpty) continue;
      const int i = ZBuffer::Index(key);
      const Vec3f p_c = camera.R_cw * (positions_[i] - camera.t);
      if ((p_c - frame.vertices[j]).squaredNorm() >= cover_scale_sq * radii_[i] * radii_[i]) {
        continue;
      }
      if ((camera.R_cw * normals_[i]).dot(frame.normals[j]) > camera.min_cosine) return true;
    }
    return false;
  };
  const double focal_px = 0.5 * (frame.intrinsics.fx + frame.intrinsics.fy);
  for (const int j : frame.valid_pixels) {
    if (match[j] != ZBuffer::kEmpty) continue;
    if (covered(j)) {
      ++stats->covered;
      continue;
    }
    const Vec3f& q = frame.vertices[j];
    const Vec3f& n_q = frame.normals[j];
    positions_.push_back(camera.R * q + camera.t);
    normals_.push_back(camera.R * n_q);
    if (!color.empty()) colors_.push_back(PixelColor(color, j));
    weights_.push_back(1.0f);
    radii_.push_back(SurfelRadius(q.z(), n_q.z(), focal_px));
    last_seen_.push_back(frame_index);
    ++stats->added;
  }
}

namespace {

/// Removes the elements at the `count` (> 0) increasing indices `gone` from v, keeping the
/// others' order: each run between two removed elements is moved down in one copy.
template <typename T>
void EraseIndices(const int* gone, int count, std::vector<T>* v) {
  std::size_t kept = gone[0];
  for (int r = 0; r < count; ++r) {
    const std::size_t begin = gone[r] + 1;
    const std::size_t end = r + 1 < count ? gone[r + 1] : v->size();
    std::copy(v->begin() + begin, v->begin() + end, v->begin() + kept);
    kept += end - begin;
  }
  v->resize(kept);
}

}  // namespace

void SurfelMap::RemoveDormant(int frame_index, const FusionOptions& options, FusionStats* stats) {
  // frame_index - last_seen > dormant_frames, and weight < min_stable_weight as a float
  // comparison: below the smallest float not below it.
  const int last_kept_seen = frame_index - std::max(0, options.dormant_frames);
  float stable = static_cast<float>(options.min_stable_weight);
  if (static_cast<double>(stable) < options.min_stable_weight) {
    stable = std::nextafter(stable, std::numeric_limits<float>::infinity());
  }
  const bool remove_dormant = options.dormant_frames > 0;
  // Without branches (whether a point goes is data, not a pattern): every index is written,
  // the count moves on past the ones that go.
  const int n = size();
  if (static_cast<int>(gone_.size()) < n) gone_.resize(n);
  const int* last_seen = last_seen_.data();
  const float* weights = weights_.data();
  int* gone = gone_.data();
  int count = 0;
  for (int i = 0; i < n; ++i) {
    const float w = weights[i];
    const bool dormant = remove_dormant & (last_seen[i] < last_kept_seen) & (w < stable);
    gone[count] = i;
    count += dormant | (w == 0.0f);  // weight 0: folded
  }
  stats->removed = count - stats->folded;
  if (count == 0) return;
  sorted_ -= static_cast<int>(std::lower_bound(gone, gone + count, sorted_) - gone);
  EraseIndices(gone, count, &positions_);
  EraseIndices(gone, count, &normals_);
  if (has_color_) EraseIndices(gone, count, &colors_);
  EraseIndices(gone, count, &weights_);
  EraseIndices(gone, count, &radii_);
  EraseIndices(gone, count, &last_seen_);
}

}  // namespace rigfit

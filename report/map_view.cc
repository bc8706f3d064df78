#include "report/map_view.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>

#include "core/format.h"
#include "core/geometry.h"
#include "report/canvas.h"
#include "report/html.h"
#include "report/plot_parts.h"
#include "report/refine_report.h"
#include "report/view3d_scenes.h"

namespace rigfit {
namespace {

constexpr int kSearchDirections = 2000;
constexpr size_t kMaxSampled = 100000;  ///< normals and positions of the up estimate
constexpr size_t kMaxWindowPoints = 200000;
constexpr int kMaxSplatPx = 25;
constexpr double kMarginFraction = 0.05;

/// Viridis (matplotlib's default colour map) at 0, 1/4, 1/2, 3/4 and 1.
constexpr Rgb kViridis[] = {
    {68, 1, 84}, {59, 82, 139}, {33, 145, 140}, {94, 201, 98}, {253, 231, 37}};

Rgb Viridis(double t) {
  const double s = std::clamp(t, 0.0, 1.0) * 4.0;
  const int k = std::min(3, static_cast<int>(s));
  return Mix(kViridis[k], kViridis[k + 1], s - k);
}

/// Every step-th element of `values` (step = ceil(size / max_count)), as doubles.
std::vector<Vec3> Sampled(const std::vector<Vec3f>& values, size_t max_count) {
  const size_t step = std::max<size_t>(1, (values.size() + max_count - 1) / max_count);
  std::vector<Vec3> out;
  out.reserve(values.size() / step + 1);
  for (size_t i = 0; i < values.size(); i += step) out.push_back(values[i].cast<double>());
  return out;
}

/// The direction of largest spread of the points in the plane perpendicular to `up`, or a
/// vector perpendicular to up when they have none.
Vec3 LargestSpreadAcross(const std::vector<Vec3>& points, const Vec3& up) {
  const Mat3 across = Mat3::Identity() - up * up.transpose();
  Vec3 mean = Vec3::Zero();
  for (const Vec3& p : points) mean += p;
  if (!points.empty()) mean /= static_cast<double>(points.size());
  Mat3 scatter = Mat3::Zero();
  for (const Vec3& p : points) {
    const Vec3 d = across * (p - mean);
    scatter += d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Mat3> eigen(scatter);  // eigenvalues ascending
  if (eigen.eigenvalues()(2) > 1e-12) return Signed(eigen.eigenvectors().col(2));
  return up.unitOrthogonal();
}

}  // namespace

MapViewAxes MapViewAxesFor(const Vec3& up, const Vec3& right_hint, std::string up_source) {
  MapViewAxes axes;
  axes.up = up.normalized();
  axes.right = (right_hint - right_hint.dot(axes.up) * axes.up).normalized();
  axes.forward = axes.up.cross(axes.right);
  axes.up_source = std::move(up_source);
  return axes;
}

MapViewAxes EstimateMapViewAxes(const std::vector<Vec3f>& positions,
                                const std::vector<Vec3f>& normals,
                                const std::vector<Pose>& T_world_cameras) {
  Vec3 image_up = Vec3::Zero();
  for (const Pose& T : T_world_cameras) image_up -= T.linear().col(1);
  const bool have_prior = image_up.norm() > 1e-6 * std::max<size_t>(1, T_world_cameras.size());
  const Vec3 prior = have_prior ? Vec3(image_up.normalized()) : Vec3::UnitY();
  const std::vector<Vec3> sampled = Sampled(normals, kMaxSampled);

  // Directions evenly spread on the sphere (a Fibonacci lattice), within the tilt of the prior.
  const double cone = std::cos(kUpConeDeg * kDegToRad);
  const double max_tilt = have_prior ? std::cos(kMaxUpTiltDeg * kDegToRad) : -1.0;
  const double golden_angle = M_PI * (3.0 - std::sqrt(5.0));
  Vec3 best = prior;
  int best_count = -1;
  for (int k = 0; k < kSearchDirections; ++k) {
    const double z = 1.0 - (2.0 * k + 1.0) / kSearchDirections;
    const double r = std::sqrt(1.0 - z * z);
    const Vec3 d(r * std::cos(golden_angle * k), r * std::sin(golden_angle * k), z);
    if (d.dot(prior) < max_tilt) continue;
    int count = 0;
    for (const Vec3& n : sampled) count += n.dot(d) >= cone ? 1 : 0;
    if (count > best_count) {
      best_count = count;
      best = d;
    }
  }
  Vec3 up = prior;
  std::string source = have_prior ? "the cameras' mean image up (no horizontal surface found)"
                                  : "world +Y (no cameras, no horizontal surface found)";
  if (!sampled.empty() && best_count >= kMinUpShare * sampled.size()) {
    Vec3 sum = Vec3::Zero();
    int count = 0;
    for (const Vec3& n : sampled) {
      if (n.dot(best) >= cone) {
        sum += n;
        ++count;
      }
    }
    up = sum.normalized();
    source = "the normal " + Fixed(100.0 * count / sampled.size(), 0) +
             "% of the points share (floors, tables)";
    if (have_prior) {
      source += ", " + Fixed(std::acos(std::clamp(up.dot(prior), -1.0, 1.0)) * kRadToDeg, 0) +
                " deg from the cameras' mean image up";
    }
  }
  return MapViewAxesFor(up, LargestSpreadAcross(Sampled(positions, kMaxSampled), up),
                        std::move(source));
}

namespace {

/// Where the map lands in the plot: metres along axes.right / axes.forward to pixels.
struct MapWindow {
  plot::Rect plot;
  MapViewAxes axes;
  double px_per_m = 1.0;
  double mid_x = 0.0, mid_y = 0.0;  ///< metres at the plot's centre
  double Column(const Vec3& p) const {
    return 0.5 * (plot.x0 + plot.x1 - 1) + (axes.right.dot(p) - mid_x) * px_per_m;
  }
  double Row(const Vec3& p) const {
    return 0.5 * (plot.y0 + plot.y1 - 1) - (axes.forward.dot(p) - mid_y) * px_per_m;
  }
};

/// The window: the points' robust extent and every overlay pose, with a margin.
MapWindow WindowFor(const MapPoints& map, const std::vector<MapOverlay>& overlays,
                    const MapViewAxes& axes, const plot::Rect& plot) {
  std::vector<double> xs, ys;
  for (const Vec3& p : Sampled(map.positions, kMaxWindowPoints)) {
    xs.push_back(axes.right.dot(p));
    ys.push_back(axes.forward.dot(p));
  }
  double min_x = INFINITY, max_x = -INFINITY, min_y = INFINITY, max_y = -INFINITY;
  if (!xs.empty()) {
    min_x = Quantile(&xs, 0.005);
    max_x = Quantile(&xs, 0.995);
    min_y = Quantile(&ys, 0.005);
    max_y = Quantile(&ys, 0.995);
  }
  for (const MapOverlay& overlay : overlays) {
    for (const Pose& T : overlay.poses) {
      const double x = axes.right.dot(T.translation()), y = axes.forward.dot(T.translation());
      min_x = std::min(min_x, x);
      max_x = std::max(max_x, x);
      min_y = std::min(min_y, y);
      max_y = std::max(max_y, y);
    }
  }
  if (!(min_x <= max_x)) min_x = max_x = min_y = max_y = 0.0;
  const double span = std::max({max_x - min_x, max_y - min_y, 0.1});
  const double margin = kMarginFraction * span;
  MapWindow window{plot, axes};
  window.px_per_m = std::min((plot.x1 - plot.x0 - 1) / (max_x - min_x + 2.0 * margin),
                             (plot.y1 - plot.y0 - 1) / (max_y - min_y + 2.0 * margin));
  window.mid_x = 0.5 * (min_x + max_x);
  window.mid_y = 0.5 * (min_y + max_y);
  return window;
}

/// The highest point over each pixel of the plot (row-major over the plot's width x height):
/// its height and index (-1: none).
struct TopView {
  std::vector<float> top;
  std::vector<int> winner;
};

TopView HighestPoints(const MapPoints& map, const MapWindow& window) {
  const plot::Rect& plot = window.plot;
  const int width = plot.x1 - plot.x0, height = plot.y1 - plot.y0;
  TopView view{std::vector<float>(static_cast<size_t>(width) * height,
                                  -std::numeric_limits<float>::infinity()),
               {}};
  view.winner.assign(view.top.size(), -1);
  for (size_t i = 0; i < map.positions.size(); ++i) {
    const Vec3 p = map.positions[i].cast<double>();
    const auto h = static_cast<float>(window.axes.up.dot(p));
    const double footprint =
        map.radii.empty()
            ? 0.0
            : 2.0 * map.radii[i] * std::abs(window.axes.up.dot(map.normals[i].cast<double>()));
    const int side =
        std::clamp(static_cast<int>(std::lround(footprint * window.px_per_m)), 1, kMaxSplatPx);
    // The side x side pixels whose centres are nearest (side 1: the nearest pixel).
    const int c0 = static_cast<int>(std::floor(window.Column(p) + 1.0 - 0.5 * side)) - plot.x0;
    const int r0 = static_cast<int>(std::floor(window.Row(p) + 1.0 - 0.5 * side)) - plot.y0;
    for (int r = std::max(r0, 0); r < std::min(r0 + side, height); ++r) {
      for (int c = std::max(c0, 0); c < std::min(c0 + side, width); ++c) {
        const size_t k = static_cast<size_t>(r) * width + c;
        if (h > view.top[k]) {
          view.top[k] = h;
          view.winner[k] = static_cast<int>(i);
        }
      }
    }
  }
  return view;
}

/// The heights the colours span: the 1% and 99% quantiles of the drawn points' (none: empty).
struct HeightRange {
  bool any = false;
  double low = 0.0, high = 1.0;
};

HeightRange HeightRangeOf(const TopView& view) {
  std::vector<double> heights;
  for (size_t k = 0; k < view.top.size(); ++k) {
    if (view.winner[k] >= 0) heights.push_back(view.top[k]);
  }
  HeightRange range;
  if (heights.empty()) return range;
  range.any = true;
  range.low = Quantile(&heights, 0.01);
  range.high = std::max(Quantile(&heights, 0.99), range.low + 1e-3);
  return range;
}

/// Paints each pixel's highest point: in its colour, or by height when the map has none.
void PaintPoints(const MapPoints& map, const TopView& view, const plot::Rect& plot,
                 const HeightRange& range, Canvas* canvas) {
  const int width = plot.x1 - plot.x0, height = plot.y1 - plot.y0;
  const auto byte = [](float v) {
    return static_cast<std::uint8_t>(std::lround(std::clamp(v, 0.0f, 255.0f)));
  };
  Image image = canvas->ToImage();
  for (int r = 0; r < height; ++r) {
    for (int c = 0; c < width; ++c) {
      const size_t k = static_cast<size_t>(r) * width + c;
      if (view.winner[k] < 0) continue;
      Rgb color;
      if (map.colors.empty()) {
        color = Viridis((view.top[k] - range.low) / (range.high - range.low));
      } else {
        const Vec3f& rgb = map.colors[view.winner[k]];
        color = {byte(rgb.x()), byte(rgb.y()), byte(rgb.z())};
      }
      image.Set(plot.x0 + c, plot.y0 + r, color);
    }
  }
  canvas->SetImage(image);
}

/// The overlays: paths with a white rim and a disc at the start; cameras as in DrawTopDown.
void DrawOverlays(const std::vector<MapOverlay>& overlays, const MapWindow& window,
                  Canvas* canvas) {
  for (const MapOverlay& overlay : overlays) {
    if (overlay.cameras) {
      constexpr double kHeadingPx = 40.0;
      for (const Pose& T : overlay.poses) {
        const double cx = window.Column(T.translation()), cy = window.Row(T.translation());
        const Vec3 ahead = T.translation() + T.linear().col(2);
        const double dx = window.Column(ahead) - cx, dy = window.Row(ahead) - cy;
        const double norm = std::hypot(dx, dy);
        if (norm > 1e-9) {
          canvas->Line(cx, cy, cx + kHeadingPx * dx / norm, cy + kHeadingPx * dy / norm, kBlack, 3);
        }
        canvas->Disc(cx, cy, 10.0, kBlack);
        canvas->Disc(cx, cy, 7.0, overlay.color);
      }
      continue;
    }
    std::vector<std::pair<double, double>> path;
    for (const Pose& T : overlay.poses) {
      path.emplace_back(window.Column(T.translation()), window.Row(T.translation()));
    }
    if (path.empty()) continue;
    canvas->Polyline(path, kWhite, overlay.line_width + 4);
    canvas->Polyline(path, overlay.color, overlay.line_width);
    canvas->Disc(path.front().first, path.front().second, overlay.line_width + 4, kWhite);
    canvas->Disc(path.front().first, path.front().second, overlay.line_width + 2, overlay.color);
  }
}

/// Legend: the overlays, then what the colours mean.
void DrawMapLegend(const std::vector<MapOverlay>& overlays, bool by_height,
                   const HeightRange& range, const plot::Rect& plot, Canvas* canvas) {
  const int legend_x = kMapPlotRight + 20;
  int y = plot.y0;
  for (const MapOverlay& overlay : overlays) {
    y = plot::LegendRow(canvas, legend_x, y, overlay.color, overlay.label);
  }
  y += 16;
  if (!by_height) {
    canvas->Text(legend_x, y, "points in their colour", plot::kMuted, plot::kTextSize);
    return;
  }
  if (!range.any) return;
  canvas->Text(legend_x, y, "height (m)", kBlack, plot::kTextSize);
  y += plot::kTextHeight + 14;
  constexpr int kBarWidth = 28, kBarHeight = 300;
  for (int r = 0; r < kBarHeight; ++r) {
    canvas->FillRect(legend_x, y + r, legend_x + kBarWidth, y + r + 1,
                     Viridis(1.0 - r / (kBarHeight - 1.0)));
  }
  const double extent = range.high - range.low;
  const double step = plot::NiceStep(extent, 5);
  for (double v : plot::Ticks(0.0, extent, step)) {
    const double r = y + (kBarHeight - 1) * (1.0 - v / extent);
    canvas->Line(legend_x + kBarWidth, r, legend_x + kBarWidth + 6, r, kBlack);
    plot::TextCentredOn(canvas, legend_x + kBarWidth + 12, r, plot::TickLabel(v, step), kBlack);
  }
}

}  // namespace

Image DrawMapFromAbove(const MapPoints& map, const std::vector<MapOverlay>& overlays,
                       const MapViewAxes& axes, const std::string& title,
                       const std::string& subtitle) {
  Canvas canvas(kMapViewWidth, kMapViewHeight, kWhite);
  plot::DrawTitles(&canvas, title, subtitle);
  const plot::Rect plot{kMapPlotLeft, kMapPlotTop, kMapPlotRight, kMapPlotBottom};
  const MapWindow window = WindowFor(map, overlays, axes, plot);
  const TopView view = HighestPoints(map, window);
  const bool by_height = map.colors.empty();
  const HeightRange range = by_height ? HeightRangeOf(view) : HeightRange{};
  PaintPoints(map, view, plot, range, &canvas);
  DrawOverlays(overlays, window, &canvas);
  plot::DrawFrame(&canvas, plot, plot::kAxis);
  plot::DrawScaleBar(&canvas, plot, window.px_per_m, (plot.x1 - plot.x0) / window.px_per_m);
  DrawMapLegend(overlays, by_height, range, plot, &canvas);
  return canvas.ToImage();
}

std::vector<std::string> WriteMapReport(const std::string& dir, const std::string& title,
                                        const MapPoints& map,
                                        const std::vector<MapOverlay>& overlays,
                                        const MapViewAxes& axes, const std::string& summary) {
  CreateReportDirectory(dir);
  ReportDirectory report(dir);
  const std::string points = std::to_string(map.positions.size()) + " map points";
  const std::string colours = map.colors.empty() ? "coloured by height" : "in their colour";
  report.AddPicture(kMapTopFile,
                    DrawMapFromAbove(map, overlays, axes, "The map from above",
                                     points + ", " + colours + "; up: " + axes.up_source),
                    "The map seen from above, orthographic along the up axis (" + axes.up_source +
                        "), " + points + " " + colours + ", with a scale bar in metres");
  report.AddView3d(MapView3dScene(title, map, overlays, axes));
  return report.Finish(title, summary);
}

}  // namespace rigfit

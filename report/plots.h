// The report's plots, drawn with Cairo (report/canvas.h): a top-down (XZ) view of the
// cameras' points, a histogram of residuals, and curves (polylines) on metric or plain axes.
// Each returns an image of a fixed size.
#pragma once

#include <string>
#include <vector>

#include "core/types.h"
#include "report/image.h"

namespace rigfit {

inline constexpr int kTopDownWidth = 1400;  ///< pixels
inline constexpr int kTopDownHeight = 1000;
inline constexpr int kHistogramWidth = 1100;
inline constexpr int kHistogramHeight = 650;
/// In a top-down view, a pixel holding this many points (or more) has full colour.
inline constexpr int kSaturationPoints = 4;

/// One camera of a top-down view.
struct TopDownCamera {
  std::string label;  ///< legend text (the serial)
  Rgb color;
  PointCloud points_world;
  Pose T_world_camera = Pose::Identity();
};

/// The part of the ground plane (world x and z, metres) a top-down view shows.
struct GroundWindow {
  double min_x = -1.0;
  double max_x = 1.0;
  double min_z = -1.0;
  double max_z = 1.0;
};

/// The smallest window that holds, in every view given, each camera's points (between
/// their 0.5th and 99.5th percentiles per axis, prepare/region.h RobustGroundBox) and each
/// camera centre, with a margin of 5% of its size on every side. Views drawn in one window
/// can be compared pixel for pixel.
GroundWindow FitGroundWindow(const std::vector<const std::vector<TopDownCamera>*>& views);

/// The view from above (world +Y toward the viewer; x to the right, z downward) of the
/// cameras' points in `window`, at equal scale on both axes, kTopDownWidth x
/// kTopDownHeight pixels. Each point covers a square of point_size_m (e.g. the voxel size
/// of a downsampled cloud, so that a floor reads as a surface), at least a pixel. A pixel's
/// colour is the mix of the colours of the cameras whose
/// points fall in it, weighted by their counts, and its strength grows with the number of
/// points up to kSaturationPoints: a single floor point gives a pale tint, a vertical
/// surface (many points stacked over one spot of the ground) full colour. Each camera
/// centre is a disc of its colour with a line along its viewing direction. Grid and ticks in
/// metres, a scale bar, and a legend of the camera colours.
Image DrawTopDown(const std::vector<TopDownCamera>& cameras, const GroundWindow& window,
                  double point_size_m, const std::string& title, const std::string& subtitle);

/// One distribution of a histogram.
struct HistogramSeries {
  std::string label;  ///< legend text
  Rgb color;
  std::vector<double> values;
};

/// Histogram of each series over [-half_range, half_range] in bins of bin_width (values
/// outside are counted in the legend's total, not drawn), kHistogramWidth x
/// kHistogramHeight pixels. The first series is drawn as filled bars, the others as step
/// outlines over it, so that two distributions can be compared.
Image DrawHistogram(const std::vector<HistogramSeries>& series, double half_range, double bin_width,
                    const std::string& title, const std::string& x_label,
                    const std::string& y_label);

inline constexpr int kPlanViewWidth = 1200;  ///< pixels, curves at equal scale (FitPlotFrame)
inline constexpr int kPlanViewHeight = 1000;
inline constexpr int kTimePlotWidth = 1200;  ///< pixels, a quantity over time
inline constexpr int kTimePlotHeight = 600;

/// One curve of a plot: a polyline through (x[i], y[i]) in data units; a non-finite point
/// breaks it.
struct PlotCurve {
  std::string label;  ///< legend text
  Rgb color;
  int line_width = 3;  ///< pixels
  std::vector<double> x;
  std::vector<double> y;
};

/// Where the data of a plot goes: the plot rectangle [x0, x1) x [y0, y1) in pixels of an
/// image of width x height, and the data window it shows (y upward).
struct PlotFrame {
  int width = 0, height = 0;
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  double min_x = 0.0, max_x = 1.0, min_y = 0.0, max_y = 1.0;
  double Column(double x) const { return x0 + (x - min_x) / (max_x - min_x) * (x1 - x0 - 1); }
  double Row(double y) const { return y1 - 1 - (y - min_y) / (max_y - min_y) * (y1 - y0 - 1); }
};

/// The frame of an image of width x height holding every finite point of the curves with a
/// margin of 5% of the span on each side (a span of 0, or within 1e-9 of the values' size,
/// widened to 1). equal_scale: as many
/// pixels per unit on both axes (a map: the window of the shorter span widens about its
/// centre); y_from_zero: the y window holds 0 (a magnitude).
PlotFrame FitPlotFrame(const std::vector<PlotCurve>& curves, int width, int height,
                       bool equal_scale, bool y_from_zero);

/// The curves in `frame`, each a polyline of its colour and width, drawn in order (the last
/// on top), with grid, tick labels, axis labels, a title and subtitle, and a legend of the
/// curves' labels on the right.
Image DrawCurves(const std::vector<PlotCurve>& curves, const PlotFrame& frame,
                 const std::string& title, const std::string& subtitle, const std::string& x_label,
                 const std::string& y_label);

}  // namespace rigfit

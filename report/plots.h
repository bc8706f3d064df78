// The report's plots, drawn on report/image.h: a top-down (XZ) view of the cameras' points
// and a histogram of residuals. Each returns an image of a fixed size.
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
/// their 0.5th and 99.5th percentiles per axis, rig/region.h RobustGroundBox) and each
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

}  // namespace rigfit

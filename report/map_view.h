// The surfel map of `rigfit slam --report` and `rigfit fuse --report` seen from above
// (docs/usage.md): an orthographic picture along an up axis -- the world's when it is known
// (a rig's +Y), else estimated from the map's normals and the cameras -- the map's points in
// their colour or coloured by height, the trajectory (and its ground truth) or the cameras
// drawn over them, and a scale bar in metres.
#pragma once

#include <string>
#include <vector>

#include "core/pose.h"
#include "report/image.h"

namespace rigfit {

inline constexpr int kMapViewWidth = 1400;  ///< pixels
inline constexpr int kMapViewHeight = 1000;
/// The plot in the picture, [left, right) x [top, bottom) pixels; the legend is right of it.
inline constexpr int kMapPlotLeft = 20;
inline constexpr int kMapPlotTop = 110;
inline constexpr int kMapPlotRight = kMapViewWidth - 300;
inline constexpr int kMapPlotBottom = kMapViewHeight - 20;
/// The picture's file in a report directory.
inline constexpr const char* kMapTopFile = "map_top.png";

/// The axes of a view from above: `up` points toward the viewer, `right` is the picture's x
/// (to the right) and `forward` its y (upward in the picture), with right x forward = up, so
/// that the picture is not mirrored. Unit and orthogonal.
struct MapViewAxes {
  Vec3 up = Vec3::UnitY();
  Vec3 right = Vec3::UnitX();
  Vec3 forward = -Vec3::UnitZ();
  std::string up_source;  ///< how `up` was chosen, in words, for the caption
};

/// The axes of the view along `up` (normalised) with `right_hint` made perpendicular to it
/// (its component along up removed, normalised) and forward = up x right. right_hint must not
/// be parallel to up. MapViewAxesFor(+Y, +X, ...) is the rig reports' view (x to the right, z
/// downward; report/plots.h DrawTopDown).
MapViewAxes MapViewAxesFor(const Vec3& up, const Vec3& right_hint, std::string up_source);

/// Estimating "up" without gravity: the surface normal shared by the most map points,
/// counted in a cone of this half-angle around each candidate direction: horizontal surfaces
/// (floor, tables, counters) all share the up normal, vertical ones spread over every
/// azimuth.
inline constexpr double kUpConeDeg = 10.0;
/// ... among the directions within this angle of the cameras' mean image up (-y of each
/// camera in the world), so that a wall the cameras face is not taken for the floor (a
/// hand-held camera is not pitched by more than this).
inline constexpr double kMaxUpTiltDeg = 60.0;
/// ... and only when that cone holds at least this share of the points; otherwise up is the
/// cameras' mean image up.
inline constexpr double kMinUpShare = 0.02;

/// The view of a map without a known up axis. Up is the direction d within kMaxUpTiltDeg of
/// the cameras' mean image up that the most normals n (facing the camera, as the map's are:
/// a floor's points up) lie within kUpConeDeg of (n . d >= cos kUpConeDeg), searched over
/// 2000 directions evenly spread on the sphere, then refined to the mean of those normals;
/// with no cameras (or image-up axes that cancel) over the whole sphere. When no direction
/// holds kMinUpShare of the normals, up is the cameras' mean image up (world +Y without
/// cameras). Right is the direction of largest spread of the positions in the plane
/// perpendicular to up (signed so that its largest component is positive), so that a long
/// map lies along the picture's width. The normals and positions are subsampled to at most
/// 100000 each. MapViewAxes::up_source says which rule gave up.
MapViewAxes EstimateMapViewAxes(const std::vector<Vec3f>& positions,
                                const std::vector<Vec3f>& normals,
                                const std::vector<Pose>& T_world_cameras);

/// A map's points as rgbd/surfel_map.h holds them (not copied): positions and unit normals
/// (world), colours (RGB in [0, 255]; empty: none), radii (metres; empty: a pixel each).
struct MapPoints {
  const std::vector<Vec3f>& positions;
  const std::vector<Vec3f>& normals;
  const std::vector<Vec3f>& colors;
  const std::vector<float>& radii;
};

/// Drawn over the map: a path through the poses' positions, or each pose as a camera (a disc
/// and a line along its viewing direction).
struct MapOverlay {
  std::string label;  ///< legend text
  Rgb color;
  int line_width = 3;       ///< pixels
  std::vector<Pose> poses;  ///< T_world_camera
  bool cameras = false;
};

/// The map seen from above along axes.up, orthographic, at equal scale on both axes,
/// kMapViewWidth x kMapViewHeight pixels on white: the window holds the positions between
/// their 0.5th and 99.5th percentiles along right and forward (subsampled to at most 200000)
/// and every overlay pose, with a margin of 5%. Each point covers the footprint of its disc
/// seen from above, a square of side 2 r |n . up| (at least a pixel, at most 25), and where
/// points overlap the highest along up is drawn (what is seen from above): in its colour when
/// the map has colours, else by its height between the 1st and 99th percentiles of the drawn
/// points (viridis, with a colour bar in metres above the 1st percentile). The overlays are drawn
/// over the points in order (the last on top), each path with a white rim and a disc at its start;
/// a legend of their labels, and a scale bar.
Image DrawMapFromAbove(const MapPoints& map, const std::vector<MapOverlay>& overlays,
                       const MapViewAxes& axes, const std::string& title,
                       const std::string& subtitle);

/// Writes, in dir (created if missing; its parent must exist), kMapTopFile (DrawMapFromAbove
/// titled `title`, its subtitle and caption naming the map size and axes.up_source), the 3-D
/// view (report/view3d_scenes.h, MapView3dScene) and kReportIndexFile (report/html.h): one page
/// showing `summary` (the text the command printed; may be empty), a link to the 3-D view and
/// the picture. Returns the paths written, the page last. Throws InputError when dir or a file
/// cannot be written.
std::vector<std::string> WriteMapReport(const std::string& dir, const std::string& title,
                                        const MapPoints& map,
                                        const std::vector<MapOverlay>& overlays,
                                        const MapViewAxes& axes, const std::string& summary);

}  // namespace rigfit

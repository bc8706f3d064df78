#include "io/rgbd_sequence.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <regex>
#include <sstream>
#include <utility>

#include "core/errors.h"
#include "io/capture_h5.h"
#include "io/png.h"
#include "io/pose_matrix.h"
#include "io/read_file.h"
#include "io/text_table.h"
#include "io/trajectory_tum.h"

namespace rigfit {
namespace {

namespace fs = std::filesystem;

/// TUM RGB-D and ICL-NUIM depth PNGs: metres = value / 5000; 0 is no measurement.
constexpr double kTumMetresPerUnit = 1.0 / 5000.0;
/// 7-Scenes depth PNGs: millimetres; 0 and 65535 are no measurement.
constexpr double kSevenScenesMetresPerUnit = 1.0 / 1000.0;
constexpr std::uint16_t kSevenScenesNoDepth = 65535;
/// ICL-NUIM's camera (the dataset's web page and code): fy < 0, the y axis of its renderer
/// (POV-Ray, left-handed) pointing up the image.
constexpr PinholeIntrinsics kIclNuimIntrinsics{481.20, -480.00, 319.5, 239.5};
/// 7-Scenes' depth camera, when the folder has no camera-intrinsics.txt.
constexpr PinholeIntrinsics kSevenScenesIntrinsics{585.0, 585.0, 320.0, 240.0};

std::string Describe(const PinholeIntrinsics& k) {
  std::ostringstream s;
  s << "fx=" << k.fx << " fy=" << k.fy << " cx=" << k.cx << " cy=" << k.cy;
  return s.str();
}

/// The files of one frame.
struct FrameFiles {
  double timestamp = 0.0;
  std::string depth;
  std::string color;  ///< empty: none (or not registered to depth)
  std::optional<Pose> T_world_camera_gt;
};

/// A sequence of 16-bit PNG depth images, with optional 8-bit colour registered to them: what
/// TUM RGB-D, ICL-NUIM and 7-Scenes folders hold. The formats differ in how the folder lists
/// the images and the poses (the Read*Folder functions below), not in the images.
struct PngSequenceLayout {
  std::string format;
  std::string folder;
  std::vector<FrameFiles> frames;
  Trajectory ground_truth;
  /// As the dataset gives them; fy < 0 (ICL-NUIM) makes Frame flip the images (FlipRows).
  PinholeIntrinsics intrinsics;
  std::string intrinsics_source;
  double metres_per_unit = kTumMetresPerUnit;
  bool max_value_invalid = false;  ///< 65535 is no measurement (7-Scenes)
};

/// ICL-NUIM's images have their camera y axis pointing up: K has fy < 0, so that
/// v = cy + fy * y / z grows downwards while y grows upwards. rigfit's camera frames are
/// OpenCV's (x right, y down, z forward) with fx, fy > 0. The conversion is done once, here, on
/// the images: the rows are flipped (row v becomes row H - 1 - v) and K becomes fy' = -fy,
/// cy' = H - 1 - cy. A pixel of the flipped image then unprojects to exactly the camera point
/// (x, y, z) of ICL-NUIM's own convention (y' = (v' - cy') z / fy' = (v - cy) z / fy = y),
/// so the dataset's poses (*.gt.freiburg) apply unchanged and GroundTruth() is the file as it
/// is, comparable with every published result. (Flipping the poses instead would need the
/// world flipped as well, since ICL-NUIM's world is left-handed too, and would change the
/// ground truth.) The price: the flipped image shows the scene upside down.
void FlipRows(RgbdFrame* frame) {
  const size_t w = static_cast<size_t>(frame->width);
  for (int top = 0, bottom = frame->height - 1; top < bottom; ++top, --bottom) {
    std::swap_ranges(frame->depth_m.begin() + top * w, frame->depth_m.begin() + (top + 1) * w,
                     frame->depth_m.begin() + bottom * w);
    if (!frame->color.empty()) {
      std::swap_ranges(frame->color.begin() + 3 * top * w, frame->color.begin() + 3 * (top + 1) * w,
                       frame->color.begin() + 3 * bottom * w);
    }
  }
  frame->intrinsics.fy = -frame->intrinsics.fy;
  frame->intrinsics.cy = frame->height - 1 - frame->intrinsics.cy;
}

class PngSequence final : public RgbdSequence {
 public:
  explicit PngSequence(PngSequenceLayout layout) : layout_(std::move(layout)) {}

  int size() const override { return static_cast<int>(layout_.frames.size()); }

  RgbdFrame Frame(int index) const override {
    const FrameFiles& files = layout_.frames.at(static_cast<size_t>(index));
    RgbdFrame frame;
    frame.index = index;
    frame.timestamp = files.timestamp;
    frame.source = files.depth;
    const Grey16Raster depth = ReadPngGrey16(files.depth);
    frame.width = depth.width;
    frame.height = depth.height;
    frame.intrinsics = layout_.intrinsics;
    frame.depth_m = DepthMetres(depth.values);
    if (!files.color.empty()) {
      RgbRaster color = ReadPng(files.color);
      if (color.width != depth.width || color.height != depth.height) {
        throw InputError(files.color + ": colour image of " + std::to_string(color.width) + "x" +
                         std::to_string(color.height) + " for the depth image " + files.depth +
                         " of " + std::to_string(depth.width) + "x" + std::to_string(depth.height));
      }
      frame.color = std::move(color.rgb);
    }
    if (frame.intrinsics.fy < 0.0) FlipRows(&frame);
    frame.T_world_camera_gt = files.T_world_camera_gt;
    return frame;
  }

  Trajectory GroundTruth() const override { return layout_.ground_truth; }

  std::string Describe() const override {
    std::string text = layout_.format + " " + layout_.folder + ": " + std::to_string(size()) +
                       " frames, intrinsics " + rigfit::Describe(layout_.intrinsics) + " (" +
                       layout_.intrinsics_source + ")";
    if (layout_.intrinsics.fy < 0.0) text += ", images flipped upside down (fy < 0)";
    text +=
        layout_.ground_truth.poses.empty()
            ? ", no ground truth"
            : ", ground truth of " + std::to_string(layout_.ground_truth.poses.size()) + " poses";
    return text;
  }

 private:
  /// The depth in metres of the PNG's values, NaN for no measurement (0, and 65535 in
  /// 7-Scenes). The settings in locals: the loop then reads nothing but the values.
  std::vector<float> DepthMetres(const std::vector<std::uint16_t>& values) const {
    const double metres_per_unit = layout_.metres_per_unit;
    const std::uint16_t no_depth = layout_.max_value_invalid ? kSevenScenesNoDepth : 0;
    std::vector<float> depth_m(values.size());
    for (std::size_t i = 0; i < values.size(); ++i) {
      const std::uint16_t v = values[i];
      depth_m[i] = v == 0 || v == no_depth ? std::numeric_limits<float>::quiet_NaN()
                                           : static_cast<float>(v * metres_per_unit);
    }
    return depth_m;
  }

  PngSequenceLayout layout_;
};

/// The frames of a rig capture's depth burst [F, H, W] (io/capture_h5.h), read at once (a
/// burst is short), at k / kUnstampedFrameRateHz seconds: the capture format has no clock.
class BurstSequence final : public RgbdSequence {
 public:
  BurstSequence(std::string path, CameraBurst burst, std::vector<int> frames)
      : path_(std::move(path)), burst_(std::move(burst)), frames_(std::move(frames)) {}

  int size() const override { return static_cast<int>(frames_.size()); }

  RgbdFrame Frame(int index) const override {
    const int k = frames_.at(static_cast<size_t>(index));
    const CameraCapture& camera = burst_.camera;
    const size_t pixels = camera.depth_m.size();
    RgbdFrame frame;
    frame.index = index;
    frame.timestamp = k / kUnstampedFrameRateHz;
    frame.source = path_ + ": camera " + camera.serial + ": frame " + std::to_string(k);
    frame.width = camera.width;
    frame.height = camera.height;
    frame.intrinsics = camera.intrinsics;
    frame.depth_m.assign(burst_.frames_depth_m.begin() + k * pixels,
                         burst_.frames_depth_m.begin() + (k + 1) * pixels);
    return frame;
  }

  Trajectory GroundTruth() const override { return {}; }

  std::string Describe() const override {
    return "rig capture " + path_ + ": camera " + burst_.camera.serial + ", " +
           std::to_string(size()) + " of " + std::to_string(burst_.num_frames) +
           " depth frames, intrinsics " + rigfit::Describe(burst_.camera.intrinsics) +
           ", no ground truth";
  }

 private:
  std::string path_;
  CameraBurst burst_;
  std::vector<int> frames_;
};

/// The indices of the frames kept of `count`: every stride-th, at most max_frames.
std::vector<int> SelectFrames(int count, const SequenceOptions& options) {
  std::vector<int> kept;
  for (int k = 0; k < count; k += options.stride) {
    if (options.max_frames > 0 && static_cast<int>(kept.size()) == options.max_frames) break;
    kept.push_back(k);
  }
  return kept;
}

void CheckOptions(const SequenceOptions& o) {
  const std::string where = "sequence options: ";
  if (o.stride < 1) throw InputError(where + "stride must be >= 1");
  if (o.max_frames < 0) throw InputError(where + "max_frames must be >= 0 (0: all)");
  if (!(o.max_time_difference_s >= 0.0 && std::isfinite(o.max_time_difference_s))) {
    throw InputError(where + "max_time_difference_s must be >= 0 and finite");
  }
  if (o.depth_scale && !(*o.depth_scale > 0.0 && std::isfinite(*o.depth_scale))) {
    throw InputError(where + "depth_scale must be > 0 and finite");
  }
  if (o.intrinsics) {
    const PinholeIntrinsics& k = *o.intrinsics;
    if (!(k.fx > 0.0 && k.fy != 0.0 && std::isfinite(k.fx) && std::isfinite(k.fy) &&
          std::isfinite(k.cx) && std::isfinite(k.cy))) {
      throw InputError(where + "intrinsics must be finite with fx > 0 and fy != 0");
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Lists of images (TUM RGB-D, ICL-NUIM).

/// One image of a list file: `timestamp filename`, the file relative to the list's folder.
struct ListedImage {
  double timestamp = 0.0;
  std::string file;
};

/// Fails unless `timestamp` is after the previous one of the same list.
void CheckIncreasing(const std::vector<ListedImage>& images, double timestamp,
                     const std::string& token, const std::string& where) {
  if (!images.empty() && !(timestamp > images.back().timestamp)) {
    throw InputError(where + ": timestamp " + token + " does not increase");
  }
}

/// A list file of lines `timestamp filename` (rgb.txt, depth.txt), timestamps increasing.
std::vector<ListedImage> ReadImageList(const fs::path& list) {
  const std::string path = list.string();
  std::vector<ListedImage> images;
  for (const TextRow& row : ReadTextRows(path)) {
    const std::string where = LineWhere(path, row.line);
    ExpectFields(row, 2, "'timestamp filename'", path);
    const double t = ParseFiniteNumber(row.fields[0], where);
    CheckIncreasing(images, t, row.fields[0], where);
    images.push_back({t, (list.parent_path() / row.fields[1]).string()});
  }
  if (images.empty()) throw InputError(path + ": no images listed");
  return images;
}

std::vector<double> Timestamps(const std::vector<FrameFiles>& frames) {
  std::vector<double> t;
  for (const FrameFiles& f : frames) t.push_back(f.timestamp);
  return t;
}

/// Depth frames of depth.txt, with the colour of rgb.txt (when the folder has one) nearest in
/// time within max_dt; timestamps times seconds_per_unit.
std::vector<FrameFiles> ListedFrames(const fs::path& folder, double seconds_per_unit,
                                     double max_dt) {
  std::vector<FrameFiles> frames;
  for (const ListedImage& image : ReadImageList(folder / "depth.txt")) {
    frames.push_back({image.timestamp * seconds_per_unit, image.file, "", std::nullopt});
  }
  if (fs::exists(folder / "rgb.txt")) {
    const std::vector<ListedImage> colors = ReadImageList(folder / "rgb.txt");
    std::vector<double> color_times;
    for (const ListedImage& c : colors) color_times.push_back(c.timestamp * seconds_per_unit);
    for (const auto& [i, j] : AssociateByTimestamp(Timestamps(frames), color_times, max_dt)) {
      frames[static_cast<size_t>(i)].color = colors[static_cast<size_t>(j)].file;
    }
  }
  return frames;
}

/// Each frame's ground-truth pose: the one nearest in time, within max_dt.
void AttachGroundTruth(const Trajectory& gt, double max_dt, std::vector<FrameFiles>* frames) {
  for (const auto& [i, j] : AssociateByTimestamp(Timestamps(*frames), gt.timestamps, max_dt)) {
    (*frames)[static_cast<size_t>(i)].T_world_camera_gt = gt.poses[static_cast<size_t>(j)];
  }
}

/// "fr1", "fr2" or "fr3" from "freiburg1" etc. in `text`; empty if none.
std::string FreiburgCamera(const std::string& text) {
  static const std::regex kFreiburg("freiburg([123])");
  std::smatch match;
  return std::regex_search(text, match, kFreiburg) ? "fr" + match[1].str() : "";
}

/// The TUM camera of a folder: the option, else the folder's name, else depth.txt's header
/// comments ("# file: 'rgbd_dataset_freiburg1_xyz.bag'"), else "default".
std::pair<std::string, std::string> TumCamera(const fs::path& folder,
                                              const SequenceOptions& options) {
  if (!options.tum_camera.empty()) return {options.tum_camera, "option"};
  const std::string from_name = FreiburgCamera(folder.filename().string());
  if (!from_name.empty()) return {from_name, "folder name"};
  std::istringstream text(ReadWholeFile((folder / "depth.txt").string()));
  for (std::string line; std::getline(text, line) && !line.empty() && line[0] == '#';) {
    const std::string from_header = FreiburgCamera(line);
    if (!from_header.empty()) return {from_header, "depth.txt header"};
  }
  return {"default", "camera unknown"};
}

PngSequenceLayout ReadTumFolder(const fs::path& folder, const SequenceOptions& options) {
  PngSequenceLayout layout;
  layout.format = "TUM RGB-D";
  layout.folder = folder.string();
  layout.frames = ListedFrames(folder, 1.0, options.max_time_difference_s);
  const auto [camera, source] = TumCamera(folder, options);
  layout.intrinsics = TumIntrinsics(camera);
  layout.intrinsics_source = camera + ", " + source;
  if (fs::exists(folder / "groundtruth.txt")) {
    layout.ground_truth = ReadTumTrajectory((folder / "groundtruth.txt").string());
    AttachGroundTruth(layout.ground_truth, options.max_time_difference_s, &layout.frames);
  }
  return layout;
}

/// The files of `folder` whose name matches `pattern`, sorted by name.
std::vector<fs::path> FilesMatching(const fs::path& folder, const std::regex& pattern) {
  std::vector<fs::path> files;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(folder, ec)) {
    if (std::regex_match(entry.path().filename().string(), pattern)) files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

/// ICL-NUIM's associations.txt: lines `index file index file`, one file under depth/ and the
/// other (colour, registered) under rgb/, in either order; indices increasing.
std::vector<FrameFiles> IclNuimAssociations(const fs::path& list, double seconds_per_unit) {
  const std::string path = list.string();
  std::vector<FrameFiles> frames;
  std::vector<ListedImage> depths;
  for (const TextRow& row : ReadTextRows(path)) {
    const std::string where = LineWhere(path, row.line);
    ExpectFields(row, 4, "'timestamp filename timestamp filename'", path);
    const bool depth_first = row.fields[1].rfind("depth", 0) == 0;
    if (!depth_first && row.fields[3].rfind("depth", 0) != 0) {
      throw InputError(where + ": neither file is under depth/");
    }
    const int d = depth_first ? 0 : 2;
    const int c = depth_first ? 2 : 0;
    const double t = ParseFiniteNumber(row.fields[d], where);
    ParseFiniteNumber(row.fields[c], where);  // checked, not used: the colour is the depth's
    CheckIncreasing(depths, t, row.fields[d], where);
    depths.push_back({t, row.fields[d + 1]});
    frames.push_back({t * seconds_per_unit, (list.parent_path() / row.fields[d + 1]).string(),
                      (list.parent_path() / row.fields[c + 1]).string(), std::nullopt});
  }
  if (frames.empty()) throw InputError(path + ": no images listed");
  return frames;
}

PngSequenceLayout ReadIclNuimFolder(const fs::path& folder, const SequenceOptions& options) {
  // ICL-NUIM numbers its frames (0, 1, 2, ...) where TUM has timestamps: frame k is at
  // k / kUnstampedFrameRateHz seconds, in the lists and in the ground truth alike.
  const double seconds_per_index = 1.0 / kUnstampedFrameRateHz;
  PngSequenceLayout layout;
  layout.format = "ICL-NUIM";
  layout.folder = folder.string();
  layout.frames = fs::exists(folder / "associations.txt")
                      ? IclNuimAssociations(folder / "associations.txt", seconds_per_index)
                      : ListedFrames(folder, seconds_per_index, options.max_time_difference_s);
  layout.intrinsics = kIclNuimIntrinsics;
  layout.intrinsics_source = "ICL-NUIM";
  const std::vector<fs::path> gt_files = FilesMatching(folder, std::regex(R"(.*\.gt\.freiburg)"));
  if (gt_files.size() > 1) {
    throw InputError(folder.string() + ": " + std::to_string(gt_files.size()) +
                     " *.gt.freiburg files; keep one");
  }
  if (!gt_files.empty()) {
    layout.ground_truth = ReadTumTrajectory(gt_files.front().string());
    for (double& t : layout.ground_truth.timestamps) t *= seconds_per_index;
    AttachGroundTruth(layout.ground_truth, options.max_time_difference_s, &layout.frames);
  }
  return layout;
}

// ---------------------------------------------------------------------------------------------
// 7-Scenes.

/// The rows of numbers of a small matrix file (7-Scenes' pose.txt, camera-intrinsics.txt).
Eigen::MatrixXd ReadMatrixFile(const std::string& path, int rows, int cols) {
  const std::vector<TextRow> lines = ReadTextRows(path);
  if (static_cast<int>(lines.size()) != rows) {
    throw InputError(path + ": expected " + std::to_string(rows) + " rows of " +
                     std::to_string(cols) + " numbers, got " + std::to_string(lines.size()) +
                     " rows");
  }
  Eigen::MatrixXd M(rows, cols);
  for (int r = 0; r < rows; ++r) {
    const TextRow& row = lines[static_cast<size_t>(r)];
    const std::string where = LineWhere(path, row.line);
    ExpectFields(row, static_cast<size_t>(cols), std::to_string(cols) + " numbers", path);
    for (int c = 0; c < cols; ++c) {
      M(r, c) = ParseFiniteNumber(row.fields[static_cast<size_t>(c)], where);
    }
  }
  return M;
}

PngSequenceLayout ReadSevenScenesFolder(fs::path folder, const SequenceOptions& options,
                                        std::vector<std::string>* warnings) {
  static const std::regex kDepthFile(R"(frame-(\d+)\.depth\.png)");
  std::vector<fs::path> depths = FilesMatching(folder, kDepthFile);
  if (depths.empty()) {
    folder /= "frames";
    depths = FilesMatching(folder, kDepthFile);
  }
  PngSequenceLayout layout;
  if (depths.empty()) return layout;  // no 7-Scenes folder
  layout.format = "7-Scenes";
  layout.folder = folder.string();
  layout.metres_per_unit = kSevenScenesMetresPerUnit;
  layout.max_value_invalid = true;
  layout.intrinsics = kSevenScenesIntrinsics;
  layout.intrinsics_source = "7-Scenes default";
  for (const fs::path& k_file :
       {folder / "camera-intrinsics.txt", folder.parent_path() / "camera-intrinsics.txt"}) {
    if (!fs::exists(k_file)) continue;
    const Eigen::MatrixXd K = ReadMatrixFile(k_file.string(), 3, 3);
    layout.intrinsics = {K(0, 0), K(1, 1), K(0, 2), K(1, 2)};
    layout.intrinsics_source = k_file.string();
    break;
  }
  std::vector<std::string> pose_warnings;
  for (const fs::path& depth : depths) {
    // Colour (frame-XXXXXX.color.*) comes from the other Kinect camera, not registered to
    // depth: it is not attached.
    const std::string name = depth.filename().string();
    const std::string number = name.substr(6, name.size() - 6 - 10);  // frame-<number>.depth.png
    FrameFiles frame;
    frame.timestamp = std::stoi(number) / kUnstampedFrameRateHz;
    frame.depth = depth.string();
    const fs::path pose_file = folder / ("frame-" + number + ".pose.txt");
    // Poses for every frame or for none: the first frame decides.
    const bool has_pose = fs::exists(pose_file);
    const bool expect_pose =
        depth == depths.front() ? has_pose
                                : !layout.frames.empty() && layout.frames.front().T_world_camera_gt;
    if (has_pose != expect_pose) {
      throw InputError(pose_file.string() + (has_pose ? ": present, but the first frame has no pose"
                                                      : ": cannot open: no such file (the first "
                                                        "frame has a pose)"));
    }
    if (has_pose) {
      const Eigen::Matrix4d M = ReadMatrixFile(pose_file.string(), 4, 4);
      frame.T_world_camera_gt = PoseFromMatrix(M, pose_file.string(), &pose_warnings);
      layout.ground_truth.timestamps.push_back(frame.timestamp);
      layout.ground_truth.poses.push_back(*frame.T_world_camera_gt);
    }
    layout.frames.push_back(frame);
  }
  if (warnings != nullptr && !pose_warnings.empty()) {
    warnings->push_back(pose_warnings.front() +
                        (pose_warnings.size() > 1
                             ? " (and " + std::to_string(pose_warnings.size() - 1) +
                                   " more pose files of " + folder.string() + ")"
                             : ""));
  }
  return layout;
}

}  // namespace

void SetSequenceIntrinsics(const std::vector<double>& values, SequenceOptions* options) {
  if (values.empty()) return;
  if (values.size() != 4) throw SettingError("intrinsics", "takes fx,fy,cx,cy");
  options->intrinsics = PinholeIntrinsics{values[0], values[1], values[2], values[3]};
}

PinholeIntrinsics TumIntrinsics(const std::string& camera) {
  if (camera == "fr1") return {517.3, 516.5, 318.6, 255.3};
  if (camera == "fr2") return {520.9, 521.0, 325.1, 249.7};
  if (camera == "fr3") return {535.4, 539.2, 320.1, 247.6};
  if (camera == "default") return {525.0, 525.0, 319.5, 239.5};
  throw InputError("TUM camera '" + camera + "': expected fr1, fr2, fr3 or default");
}

std::unique_ptr<RgbdSequence> OpenRgbdSequence(const std::string& path,
                                               const SequenceOptions& options,
                                               std::vector<std::string>* warnings) {
  CheckOptions(options);
  std::error_code ec;
  if (fs::is_regular_file(path, ec)) {
    CameraBurst burst = ReadCaptureBurst(path, options.serial);
    std::vector<int> frames = SelectFrames(burst.num_frames, options);
    return std::make_unique<BurstSequence>(path, std::move(burst), std::move(frames));
  }
  if (!fs::is_directory(path, ec)) {
    throw InputError(path + ": cannot open: no such file or folder");
  }
  const fs::path folder(path);
  const auto has = [&](const char* name) { return fs::exists(folder / name, ec); };
  PngSequenceLayout layout;
  if (!FilesMatching(folder, std::regex(R"(.*\.gt\.freiburg)")).empty() ||
      (has("associations.txt") && !has("rgb.txt"))) {
    layout = ReadIclNuimFolder(folder, options);
  } else if (has("depth.txt")) {
    layout = ReadTumFolder(folder, options);
  } else {
    layout = ReadSevenScenesFolder(folder, options, warnings);
    if (layout.frames.empty()) {
      throw InputError(path +
                       ": no RGB-D sequence of a known format: expected depth.txt (TUM RGB-D; "
                       "rgb.txt optional), a *.gt.freiburg file or associations.txt (ICL-NUIM), "
                       "frame-XXXXXX.depth.png files here or in frames/ (7-Scenes), or a rig "
                       "capture file");
    }
  }
  if (options.intrinsics) {
    layout.intrinsics = *options.intrinsics;
    layout.intrinsics_source = "option";
  }
  if (options.depth_scale) layout.metres_per_unit = *options.depth_scale;
  std::vector<FrameFiles> kept;
  for (const int k : SelectFrames(static_cast<int>(layout.frames.size()), options)) {
    kept.push_back(std::move(layout.frames[static_cast<size_t>(k)]));
  }
  layout.frames = std::move(kept);
  return std::make_unique<PngSequence>(std::move(layout));
}

}  // namespace rigfit

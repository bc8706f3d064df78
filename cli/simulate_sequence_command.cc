// `rigfit simulate-sequence`: a synthetic RGB-D sequence of a hand-held Kinect-like camera in
// the simulated room, with exact ground truth, written in the TUM RGB-D layout
// (sim/simulate_sequence.h; docs/usage.md, "rigfit simulate-sequence reference").
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/simulate_common.h"
#include "core/errors.h"
#include "io/atomic_file.h"
#include "io/png.h"
#include "io/trajectory_tum.h"
#include "sim/simulate_rig.h"
#include "sim/simulate_sequence.h"

namespace rigfit::cli {
namespace {

namespace fs = std::filesystem;

constexpr int kMaxFrames = 1000000;
constexpr double kMaxSpeedMps = 5.0;
constexpr double kMaxStereoBaselineM = 1.0;
constexpr int kMaxStereoUpsample = 4;  // the pair is rendered at up to 4x the resolution
/// TUM RGB-D depth PNGs: metres x 5000 in 16 bits, 0 invalid.
constexpr double kTumDepthScale = 5000.0;
constexpr int kProgressEvery = 30;  // frames

struct SimulateSequenceArgs {
  std::string out_dir;
  bool force = false;
  bool no_color = false;
  bool flat_color = false;
  std::string noise = "kinect";
  std::string lone_plane = "none";
  SimSequenceOptions sequence;
};

void CheckArgs(const SimulateSequenceArgs& a) {
  const SimSequenceOptions& o = a.sequence;
  auto fail = [](const std::string& what) { throw InputError("simulate-sequence: " + what); };
  if (o.frames < 1 || o.frames > kMaxFrames) {
    fail("--frames must be in [1, " + std::to_string(kMaxFrames) + "], got " +
         std::to_string(o.frames));
  }
  CheckSimImageSize(o.width, o.height);
  if (!(o.rate_hz > 0.0) || !std::isfinite(o.rate_hz)) fail("--rate must be a finite number > 0");
  if (!(o.speed_mps > 0.0 && o.speed_mps <= kMaxSpeedMps)) {
    fail("--speed must be in (0, " + std::to_string(static_cast<int>(kMaxSpeedMps)) + "] m/s");
  }
  if (o.closed_loop && o.frames < 2) fail("--closed-loop needs --frames of at least 2");
  const LonePlaneStretch& l = o.lone_plane;
  if (!(l.start_s >= 0.0 && std::isfinite(l.start_s))) {
    fail("--lone-plane-start must be a finite number >= 0 (seconds)");
  }
  if (!(l.seconds > 0.0 && std::isfinite(l.seconds))) {
    fail("--lone-plane-seconds must be a finite number > 0");
  }
  if (!(l.turn_s > 0.0 && std::isfinite(l.turn_s))) {
    fail("--lone-plane-turn must be a finite number > 0");
  }
  const StereoOptions& st = o.stereo;
  if (!(st.baseline_m > 0.0 && st.baseline_m <= kMaxStereoBaselineM)) {
    fail("--stereo-baseline-m must be in (0, " + std::to_string(kMaxStereoBaselineM) + "] metres");
  }
  if (st.upsample < 1 || st.upsample > kMaxStereoUpsample) {
    fail("--stereo-upsample must be in [1, " + std::to_string(kMaxStereoUpsample) + "]");
  }
}

/// "%.6f": the TUM layout's timestamps and file names.
std::string Stamp(double t) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.6f", t);
  return text;
}

/// The TUM depth image: round(z x 5000), 0 where invalid or beyond 16 bits.
std::vector<std::uint16_t> TumDepth(const std::vector<float>& depth_m) {
  std::vector<std::uint16_t> values(depth_m.size(), 0);
  for (size_t i = 0; i < depth_m.size(); ++i) {
    const double v = std::round(depth_m[i] * kTumDepthScale);
    if (std::isfinite(v) && v > 0.0 && v <= UINT16_MAX) values[i] = static_cast<std::uint16_t>(v);
  }
  return values;
}

int RunSimulateSequence(SimulateSequenceArgs a) {
  a.sequence.noise = a.noise == "none"     ? SequenceNoise::kNone
                     : a.noise == "stereo" ? SequenceNoise::kStereo
                                           : SequenceNoise::kKinect;
  a.sequence.color = !a.no_color;
  a.sequence.texture = !a.flat_color;
  a.sequence.lone_plane.plane = a.lone_plane == "floor"  ? LonePlane::kFloor
                                : a.lone_plane == "wall" ? LonePlane::kWall
                                                         : LonePlane::kNone;
  CheckArgs(a);
  // Any earlier content: the frames of an earlier, longer run would stay beside new ones.
  PrepareOutputDir("simulate-sequence", a.out_dir, a.force, {});
  const fs::path dir(a.out_dir);
  std::error_code ec;
  for (const char* sub : {"depth", "rgb"}) {
    if (std::string(sub) == "rgb" && !a.sequence.color) continue;
    fs::create_directories(dir / sub, ec);
    if (ec) {
      throw InputError("simulate-sequence: cannot create " + (dir / sub).string() + ": " +
                       ec.message());
    }
  }

  const SimulatedSequence sequence(a.sequence);
  const SimSequenceOptions& o = a.sequence;
  const std::string header = "# rigfit simulate-sequence, seed " + std::to_string(o.seed) +
                             ", noise " + a.noise + "\n# timestamp filename\n";
  std::string depth_list = "# depth maps\n" + header;
  std::string rgb_list = "# color images\n" + header;
  for (int i = 0; i < sequence.size(); ++i) {
    const RgbdFrame frame = sequence.Frame(i);
    const std::string stamp = Stamp(frame.timestamp);
    const std::string depth_name = "depth/" + stamp + ".png";
    WritePngGrey16((dir / depth_name).string(),
                   Grey16Raster{frame.width, frame.height, TumDepth(frame.depth_m)});
    depth_list += stamp + " " + depth_name + "\n";
    if (o.color) {
      const std::string rgb_name = "rgb/" + stamp + ".png";
      WritePng((dir / rgb_name).string(), RgbRaster{frame.width, frame.height, frame.color});
      rgb_list += stamp + " " + rgb_name + "\n";
    }
    if ((i + 1) % kProgressEvery == 0 || i + 1 == sequence.size()) {
      std::cerr << "simulate-sequence: frame " << i + 1 << " of " << sequence.size() << "\n";
    }
  }
  WriteTextFileAtomically((dir / "depth.txt").string(), depth_list);
  if (o.color) WriteTextFileAtomically((dir / "rgb.txt").string(), rgb_list);
  const Trajectory gt = sequence.GroundTruth();
  WriteTumTrajectory((dir / "groundtruth.txt").string(), gt);

  double path_m = 0.0;
  for (size_t i = 1; i < gt.poses.size(); ++i) {
    path_m += (gt.poses[i].translation() - gt.poses[i - 1].translation()).norm();
  }
  const PinholeIntrinsics K = SequenceIntrinsics(o.width, o.height);
  std::printf(
      "simulate-sequence: %d frames, %dx%d at %g Hz (fx %g, fy %g, cx %g, cy %g), seed %llu, "
      "noise %s%s%s%s, path %.2f m -> %s\n",
      o.frames, o.width, o.height, o.rate_hz, K.fx, K.fy, K.cx, K.cy,
      static_cast<unsigned long long>(o.seed), a.noise.c_str(), o.bare ? ", bare room" : "",
      o.closed_loop ? ", one closed loop" : "",
      a.lone_plane == "none" ? "" : (", lone " + a.lone_plane + " stretch").c_str(), path_m,
      a.out_dir.c_str());
  return kExitOk;
}

}  // namespace

Command AddSimulateSequenceCommand(CLI::App& app) {
  auto args = std::make_shared<SimulateSequenceArgs>();
  SimSequenceOptions& o = args->sequence;
  CLI::App* sub = app.add_subcommand(
      "simulate-sequence",
      "Write a synthetic RGB-D sequence in the TUM RGB-D layout: a hand-held Kinect-like "
      "camera (fx = fy = 525, cx = 319.5, cy = 239.5 at 640x480, scaled with the width) walking "
      "a smooth loop through the simulated room at 1.2-1.6 m, looking toward the room centre; "
      "DIR/depth/*.png (16-bit, metres x 5000, 0 invalid), DIR/rgb/*.png, DIR/depth.txt, "
      "DIR/rgb.txt and DIR/groundtruth.txt (exact poses, TUM format). Depth is ray cast, with "
      "the ICL-NUIM Kinect noise (pixel shift, disparity noise, 1/8 px disparity "
      "quantisation), by stereo block matching with --noise stereo, exact with --noise none. "
      "Deterministic for a given seed.");
  sub->add_option("--out", args->out_dir, "Output directory (created if missing; must be empty)")
      ->required();
  sub->add_option("--frames", o.frames, "Number of frames")->capture_default_str();
  sub->add_option("--rate", o.rate_hz, "Frame rate, Hz")->capture_default_str();
  sub->add_option("--speed", o.speed_mps, "Mean speed of the camera, m/s")->capture_default_str();
  AddSeedOption(sub, &o.seed, "Random seed (0 to 2^64 - 1): room, path and noise");
  sub->add_option("--width", o.width, "Image width, pixels")->capture_default_str();
  sub->add_option("--height", o.height, "Image height, pixels")->capture_default_str();
  sub->add_option("--noise", args->noise,
                  "Depth noise: kinect (ICL-NUIM's model, docs/usage.md), stereo (block "
                  "matching of a rendered, textured left/right pair, OpenCV StereoSGBM, as "
                  "`rigfit simulate --depth-model stereo`) or none (exact depth)")
      ->check(CLI::IsMember({"none", "kinect", "stereo"}))
      ->capture_default_str();
  sub->add_option("--stereo-baseline-m", o.stereo.baseline_m,
                  "--noise stereo: the baseline, metres (disparity = fx x baseline / z)")
      ->capture_default_str();
  sub->add_option("--stereo-upsample", o.stereo.upsample,
                  "--noise stereo: render and match the pair at this many times the resolution, "
                  "the disparity averaged down (as ZED HD modes do)")
      ->capture_default_str();
  sub->add_flag("--no-color", args->no_color, "Depth only: no rgb/ and rgb.txt");
  sub->add_flag("--flat-color", args->flat_color,
                "Colour each surface flat (its shaded albedo) instead of textured");
  sub->add_flag("--bare", o.bare, "Floor and walls only");
  sub->add_flag("--closed-loop", o.closed_loop,
                "Walk exactly one loop: the speed is set so that the last frame is back at the "
                "first frame's pose (--speed ignored)");
  sub->add_option("--lone-plane", args->lone_plane,
                  "A stretch that sees one plane only: none, floor (the camera turns to look 75 "
                  "deg down, only the floor rendered) or wall (it turns to face the nearest "
                  "wall, only that wall rendered)")
      ->check(CLI::IsMember({"none", "floor", "wall"}))
      ->capture_default_str();
  sub->add_option("--lone-plane-start", o.lone_plane.start_s,
                  "Seconds from which the camera sees only the lone plane (it turns toward it "
                  "--lone-plane-turn seconds before and back after)")
      ->capture_default_str();
  sub->add_option("--lone-plane-seconds", o.lone_plane.seconds,
                  "How long the camera sees only the lone plane, seconds")
      ->capture_default_str();
  sub->add_option("--lone-plane-turn", o.lone_plane.turn_s,
                  "Seconds the camera takes to turn toward the lone plane, and back")
      ->capture_default_str();
  sub->add_flag("--force", args->force, "Write into DIR even if it is not empty");
  return {sub, [args] { return RunSimulateSequence(*args); }};
}

}  // namespace rigfit::cli

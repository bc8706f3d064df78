// io/rgbd_sequence.h: each format from a small folder or file written here (depth in metres,
// invalid pixels NaN, intrinsics, timestamps, associated colour and ground truth, the ICL-NUIM
// sign convention, errors naming file and line), then the real TUM fr1/xyz and 7-Scenes
// frames of ../shared/data when present.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "io/png.h"
#include "io/rgbd_sequence.h"
#include "io_h5_builder.h"
#include "io_test_util.h"

namespace rigfit {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::StartsWith;

/// Depth in metres from 16-bit units (float precision).
constexpr double kDepthTolerance = 1e-6;
/// Poses compared after a text round trip with 17 digits.
constexpr double kPoseTolerance = 1e-9;
/// 7-Scenes-like rotations re-orthonormalised from a deviation of about 3e-4 move by about
/// as much.
constexpr double kReorthonormalisedTolerance = 1e-3;

class RgbdSequenceTest : public io_test::TempDirTest {
 protected:
  /// A folder under the temporary directory (created), with depth/ and rgb/ inside.
  std::string Folder(const std::string& name) {
    const fs::path folder = dir_ / name;
    fs::create_directories(folder / "depth");
    fs::create_directories(folder / "rgb");
    return folder.string();
  }
};

void WriteDepth(const std::string& path, int width, int height,
                const std::vector<std::uint16_t>& values) {
  WritePngGrey16(path, Grey16Raster{width, height, values});
}

RgbRaster Colour(int width, int height, std::uint8_t seed) {
  RgbRaster image;
  image.width = width;
  image.height = height;
  for (int i = 0; i < 3 * width * height; ++i) {
    image.rgb.push_back(static_cast<std::uint8_t>(seed + i));
  }
  return image;
}

Pose MakePose(const Vec3& axis, double angle, const Vec3& t) {
  Pose T = Pose::Identity();
  T.linear() = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
  T.translation() = t;
  return T;
}

std::string TumLine(double t, const Pose& T) {
  const Eigen::Quaterniond q(T.linear());
  std::ostringstream s;
  s.precision(17);
  s << t << ' ' << T.translation().x() << ' ' << T.translation().y() << ' ' << T.translation().z()
    << ' ' << q.x() << ' ' << q.y() << ' ' << q.z() << ' ' << q.w() << '\n';
  return s.str();
}

void ExpectPoseNear(const Pose& a, const Pose& b, double tolerance) {
  EXPECT_LT((a.matrix() - b.matrix()).cwiseAbs().maxCoeff(), tolerance) << a.matrix() << "\n\n"
                                                                        << b.matrix();
}

// ---------------------------------------------------------------------------------------------
// TUM RGB-D.

/// A 4x3 TUM folder: depth at 1.00, 1.10, 1.20 s; colour at 1.01 (-> frame 0), 1.13 (0.03 s
/// from frame 1: not associated), 1.205 (-> frame 2); ground truth at 0.995 (-> frame 0),
/// 1.105 (-> frame 1) and 1.5 (none).
std::string WriteTumFolder(const std::string& folder, const std::vector<Pose>& gt) {
  const std::vector<std::uint16_t> depth = {0, 5000, 12345, 65535, 1, 0, 0, 0, 0, 0, 0, 2500};
  for (const char* name : {"1.00", "1.10", "1.20"}) {
    WriteDepth(folder + "/depth/" + name + ".png", 4, 3, depth);
  }
  for (const auto& [name, seed] :
       std::vector<std::pair<std::string, int>>{{"1.01", 10}, {"1.13", 20}, {"1.205", 30}}) {
    WritePng(folder + "/rgb/" + name + ".png", Colour(4, 3, static_cast<std::uint8_t>(seed)));
  }
  io_test::WriteText(folder + "/depth.txt",
                     "# depth maps\n# timestamp filename\n1.00 depth/1.00.png\n"
                     "1.10 depth/1.10.png\n\n1.20 depth/1.20.png\n");
  io_test::WriteText(folder + "/rgb.txt",
                     "# colour\n1.01 rgb/1.01.png\n1.13 rgb/1.13.png\n1.205 rgb/1.205.png\n");
  io_test::WriteText(folder + "/groundtruth.txt", "# timestamp tx ty tz qx qy qz qw\n" +
                                                      TumLine(0.995, gt[0]) +
                                                      TumLine(1.105, gt[1]) + TumLine(1.5, gt[2]));
  return folder;
}

std::vector<Pose> ThreePoses() {
  return {MakePose(Vec3(0, 1, 0), 0.1, Vec3(1, 2, 3)), MakePose(Vec3(1, 0, 1), -0.4, Vec3(0, 0, 1)),
          MakePose(Vec3(1, 1, 1), 2.0, Vec3(-1, 0, 0))};
}

TEST_F(RgbdSequenceTest, TumFolderDepthColourGroundTruthAndIntrinsicsFromTheName) {
  const std::vector<Pose> gt = ThreePoses();
  const std::string folder = WriteTumFolder(Folder("rgbd_dataset_freiburg2_desk"), gt);
  const auto sequence = OpenRgbdSequence(folder);
  ASSERT_EQ(sequence->size(), 3);
  EXPECT_THAT(sequence->Describe(), HasSubstr("TUM RGB-D"));
  EXPECT_THAT(sequence->Describe(), HasSubstr("fr2, folder name"));

  const RgbdFrame f0 = sequence->Frame(0);
  EXPECT_EQ(f0.index, 0);
  EXPECT_DOUBLE_EQ(f0.timestamp, 1.00);
  EXPECT_EQ(f0.source, folder + "/depth/1.00.png");
  ASSERT_EQ(f0.width, 4);
  ASSERT_EQ(f0.height, 3);
  EXPECT_TRUE(std::isnan(f0.Depth(0, 0)));  // 0: no measurement
  EXPECT_NEAR(f0.Depth(1, 0), 1.0, kDepthTolerance);
  EXPECT_NEAR(f0.Depth(2, 0), 12345 / 5000.0, kDepthTolerance);
  EXPECT_NEAR(f0.Depth(3, 0), 65535 / 5000.0, kDepthTolerance);  // valid in TUM
  EXPECT_NEAR(f0.Depth(3, 2), 0.5, kDepthTolerance);
  EXPECT_EQ(f0.intrinsics.fx, 520.9);
  EXPECT_EQ(f0.intrinsics.fy, 521.0);
  EXPECT_EQ(f0.intrinsics.cx, 325.1);
  EXPECT_EQ(f0.intrinsics.cy, 249.7);
  EXPECT_EQ(f0.color, Colour(4, 3, 10).rgb);
  ASSERT_TRUE(f0.T_world_camera_gt.has_value());
  ExpectPoseNear(*f0.T_world_camera_gt, gt[0], kPoseTolerance);

  const RgbdFrame f1 = sequence->Frame(1);
  EXPECT_TRUE(f1.color.empty());  // nearest colour 0.03 s away
  ASSERT_TRUE(f1.T_world_camera_gt.has_value());
  ExpectPoseNear(*f1.T_world_camera_gt, gt[1], kPoseTolerance);

  const RgbdFrame f2 = sequence->Frame(2);
  EXPECT_EQ(f2.color, Colour(4, 3, 30).rgb);
  EXPECT_FALSE(f2.T_world_camera_gt.has_value());  // nearest pose 0.3 s away

  const Trajectory trajectory = sequence->GroundTruth();
  EXPECT_EQ(trajectory.timestamps, (std::vector<double>{0.995, 1.105, 1.5}));

  SequenceOptions wide;
  wide.max_time_difference_s = 0.05;
  EXPECT_EQ(OpenRgbdSequence(folder, wide)->Frame(1).color, Colour(4, 3, 20).rgb);
}

TEST_F(RgbdSequenceTest, TumCameraFromOptionHeaderOrDefaultAndOverrides) {
  const std::string folder = WriteTumFolder(Folder("plain"), ThreePoses());
  EXPECT_EQ(OpenRgbdSequence(folder)->Frame(0).intrinsics.fx, 525.0);
  EXPECT_THAT(OpenRgbdSequence(folder)->Describe(), HasSubstr("default, camera unknown"));
  io_test::WriteText(folder + "/depth.txt",
                     "# depth maps\n# file: 'rgbd_dataset_freiburg1_xyz.bag'\n"
                     "1.00 depth/1.00.png\n1.10 depth/1.10.png\n1.20 depth/1.20.png\n");
  EXPECT_EQ(OpenRgbdSequence(folder)->Frame(0).intrinsics.cy, 255.3);
  SequenceOptions options;
  options.tum_camera = "fr3";
  EXPECT_EQ(OpenRgbdSequence(folder, options)->Frame(0).intrinsics.fy, 539.2);
  options.tum_camera = "fr9";
  EXPECT_EQ(io_test::InputErrorMessage([&] { OpenRgbdSequence(folder, options); }),
            "TUM camera 'fr9': expected fr1, fr2, fr3 or default");

  options = {};
  options.intrinsics = PinholeIntrinsics{100, 101, 1.5, 1.0};
  options.depth_scale = 0.001;
  options.stride = 2;
  const auto strided = OpenRgbdSequence(folder, options);
  ASSERT_EQ(strided->size(), 2);
  const RgbdFrame f1 = strided->Frame(1);
  EXPECT_EQ(f1.index, 1);
  EXPECT_DOUBLE_EQ(f1.timestamp, 1.20);
  EXPECT_EQ(f1.intrinsics.fy, 101.0);
  EXPECT_NEAR(f1.Depth(1, 0), 5.0, kDepthTolerance);
  options.max_frames = 1;
  EXPECT_EQ(OpenRgbdSequence(folder, options)->size(), 1);
  options.stride = 0;
  EXPECT_EQ(io_test::InputErrorMessage([&] { OpenRgbdSequence(folder, options); }),
            "sequence options: stride must be >= 1");
}

TEST_F(RgbdSequenceTest, TumListErrorsNameTheFileAndTheLine) {
  const std::string folder = WriteTumFolder(Folder("tum"), ThreePoses());
  const std::string depth_txt = folder + "/depth.txt";
  const auto message = [&](const std::string& text) {
    io_test::WriteText(depth_txt, text);
    return io_test::InputErrorMessage([&] { OpenRgbdSequence(folder); });
  };
  EXPECT_EQ(message("# x\n1.0 depth/1.00.png extra\n"),
            depth_txt + ": line 2: expected 'timestamp filename', got 3 fields");
  EXPECT_EQ(message("depth/1.00.png\n"),
            depth_txt + ": line 1: expected 'timestamp filename', got 1 fields");
  EXPECT_EQ(message("one depth/1.00.png\n"), depth_txt + ": line 1: 'one' is not a number");
  EXPECT_EQ(message("1.1 depth/1.10.png\n1.1 depth/1.00.png\n"),
            depth_txt + ": line 2: timestamp 1.1 does not increase");
  EXPECT_EQ(message("# nothing\n"), depth_txt + ": no images listed");

  io_test::WriteText(depth_txt, "1.0 depth/missing.png\n1.1 rgb/1.01.png\n");
  const auto sequence = OpenRgbdSequence(folder);
  EXPECT_THAT(io_test::InputErrorMessage([&] { sequence->Frame(0); }),
              StartsWith(folder + "/depth/missing.png: cannot open: "));
  EXPECT_EQ(io_test::InputErrorMessage([&] { sequence->Frame(1); }),
            folder +
                "/rgb/1.01.png: cannot read PNG: expected a 16-bit greyscale PNG (depth), got "
                "8-bit RGB");

  const std::string gt = folder + "/groundtruth.txt";
  io_test::WriteText(depth_txt, "1.0 depth/1.00.png\n");
  io_test::WriteText(gt, "1 0 0 0 0 0 0 1\n0.5 0 0 0 0 0 0 1\n");
  EXPECT_EQ(io_test::InputErrorMessage([&] { OpenRgbdSequence(folder); }),
            gt + ": line 2: timestamp 0.5 does not increase");
}

TEST_F(RgbdSequenceTest, MissingFolderAndUnknownFormatNameThePath) {
  const std::string missing = Path("nowhere");
  EXPECT_EQ(io_test::InputErrorMessage([&] { OpenRgbdSequence(missing); }),
            missing + ": cannot open: no such file or folder");
  const std::string empty = Folder("empty");
  EXPECT_THAT(io_test::InputErrorMessage([&] { OpenRgbdSequence(empty); }),
              StartsWith(empty + ": no RGB-D sequence of a known format"));
}

// ---------------------------------------------------------------------------------------------
// ICL-NUIM.

TEST_F(RgbdSequenceTest, IclNuimImagesAreFlippedSoThatItsPosesProjectAKnownPoint) {
  constexpr int kWidth = 640;
  constexpr int kHeight = 480;
  // A point of ICL-NUIM's camera frame (y up) and the pixel ICL-NUIM's K (fx 481.2,
  // fy -480, cx 319.5, cy 239.5) projects it to: u = 400, v = 100.
  const double z = 2.0;
  const Vec3 p_camera_icl((400 - 319.5) * z / 481.2, (100 - 239.5) * z / -480.0, z);
  const Pose T_world_camera = MakePose(Vec3(0.2, 1, 0.1), 0.7, Vec3(0.5, -1.0, 2.0));
  const Vec3 p_world = T_world_camera * p_camera_icl;

  const std::string folder = Folder("living_room_traj0_frei_png");
  std::vector<std::uint16_t> depth(kWidth * kHeight, 0);
  depth[100 * kWidth + 400] = static_cast<std::uint16_t>(z * 5000);
  RgbRaster colour = Colour(kWidth, kHeight, 0);
  std::fill(colour.rgb.begin(), colour.rgb.end(), 0);
  colour.rgb[3 * (100 * kWidth + 400)] = 255;
  for (const char* k : {"0", "1"}) {
    WriteDepth(folder + "/depth/" + k + ".png", kWidth, kHeight, depth);
    WritePng(folder + "/rgb/" + k + ".png", colour);
  }
  // Both orders of the two files occur in the wild (ORB-SLAM's `t rgb t depth`).
  io_test::WriteText(folder + "/associations.txt",
                     "0 rgb/0.png 0 depth/0.png\n1 depth/1.png 1 rgb/1.png\n");
  io_test::WriteText(folder + "/livingRoom0.gt.freiburg",
                     TumLine(0, T_world_camera) + TumLine(1, Pose::Identity()));

  const auto sequence = OpenRgbdSequence(folder);
  ASSERT_EQ(sequence->size(), 2);
  EXPECT_THAT(sequence->Describe(), HasSubstr("ICL-NUIM"));
  EXPECT_THAT(sequence->Describe(), HasSubstr("flipped"));
  const RgbdFrame frame = sequence->Frame(0);
  EXPECT_EQ(frame.intrinsics.fx, 481.2);
  EXPECT_EQ(frame.intrinsics.fy, 480.0);
  EXPECT_EQ(frame.intrinsics.cx, 319.5);
  EXPECT_EQ(frame.intrinsics.cy, 239.5);  // 479 - 239.5
  // Row 100 of the file is row 479 - 100 = 379 of the frame.
  const int u = 400;
  const int v = kHeight - 1 - 100;
  EXPECT_NEAR(frame.Depth(u, v), z, kDepthTolerance);
  EXPECT_TRUE(std::isnan(frame.Depth(u, 100)));
  EXPECT_EQ(frame.color[3 * (v * kWidth + u)], 255);
  // Unprojected with the frame's (OpenCV) intrinsics and moved by the file's pose, the pixel
  // is the world point.
  const double d = frame.Depth(u, v);
  const Vec3 p_camera((u - frame.intrinsics.cx) * d / frame.intrinsics.fx,
                      (v - frame.intrinsics.cy) * d / frame.intrinsics.fy, d);
  ASSERT_TRUE(frame.T_world_camera_gt.has_value());
  EXPECT_LT((*frame.T_world_camera_gt * p_camera - p_world).norm(), 1e-6);
  // Frame numbers are indices: k / 30 s, in the frames and the ground truth alike.
  EXPECT_DOUBLE_EQ(sequence->Frame(1).timestamp, 1.0 / 30.0);
  EXPECT_EQ(sequence->GroundTruth().timestamps, (std::vector<double>{0.0, 1.0 / 30.0}));
  ASSERT_TRUE(sequence->Frame(1).T_world_camera_gt.has_value());
  ExpectPoseNear(*sequence->Frame(1).T_world_camera_gt, Pose::Identity(), kPoseTolerance);

  io_test::WriteText(folder + "/associations.txt", "0 rgb/0.png 0 depth/0.png\n0 a.png 1 b.png\n");
  EXPECT_EQ(io_test::InputErrorMessage([&] { OpenRgbdSequence(folder); }),
            folder + "/associations.txt: line 2: neither file is under depth/");
  io_test::WriteText(folder + "/associations.txt", "0 rgb/0.png 0\n");
  EXPECT_EQ(io_test::InputErrorMessage([&] { OpenRgbdSequence(folder); }),
            folder +
                "/associations.txt: line 1: expected 'timestamp filename timestamp filename', "
                "got 3 fields");
}

// ---------------------------------------------------------------------------------------------
// 7-Scenes.

/// The 4x4 matrix of T as 7-Scenes prints it, with the rotation block perturbed by `noise`.
std::string PoseText(const Pose& T, double noise) {
  Eigen::Matrix4d M = T.matrix();
  M(0, 1) += noise;
  std::ostringstream s;
  s.precision(17);
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) s << M(r, c) << (c == 3 ? "\n" : " ");
  }
  return s.str();
}

TEST_F(RgbdSequenceTest, SevenScenesMillimetresPosesAndIntrinsicsFile) {
  const fs::path root = dir_ / "kitchen";
  const fs::path frames = root / "frames";
  fs::create_directories(frames);
  io_test::WriteText((root / "camera-intrinsics.txt").string(),
                     "5.0e+02 0 2.0e+00\n0 5.1e+02 1.5e+00\n0 0 1\n");
  const std::vector<Pose> poses = ThreePoses();
  for (int k = 0; k < 2; ++k) {
    const std::string stem = (frames / ("frame-00001" + std::to_string(k))).string();
    WriteDepth(stem + ".depth.png", 4, 3, {0, 65535, 1500, 1, 0, 0, 0, 0, 0, 0, 0, 2000});
    WritePng(stem + ".color.png", Colour(4, 3, 0));  // not registered: not read
    io_test::WriteText(stem + ".pose.txt", PoseText(poses[k], k == 1 ? 3e-4 : 0.0));
  }
  std::vector<std::string> warnings;
  for (const fs::path& path : {root, frames}) {
    warnings.clear();
    const auto sequence = OpenRgbdSequence(path.string(), {}, &warnings);
    ASSERT_EQ(sequence->size(), 2);
    EXPECT_THAT(sequence->Describe(), HasSubstr("7-Scenes"));
    const RgbdFrame f0 = sequence->Frame(0);
    EXPECT_DOUBLE_EQ(f0.timestamp, 10 / 30.0);
    EXPECT_TRUE(std::isnan(f0.Depth(0, 0)));
    EXPECT_TRUE(std::isnan(f0.Depth(1, 0)));  // 65535: no measurement
    EXPECT_NEAR(f0.Depth(2, 0), 1.5, kDepthTolerance);
    EXPECT_NEAR(f0.Depth(3, 2), 2.0, kDepthTolerance);
    EXPECT_TRUE(f0.color.empty());
    EXPECT_EQ(f0.intrinsics.fx, 500.0);
    EXPECT_EQ(f0.intrinsics.fy, 510.0);
    EXPECT_EQ(f0.intrinsics.cx, 2.0);
    EXPECT_EQ(f0.intrinsics.cy, 1.5);
    ASSERT_TRUE(f0.T_world_camera_gt.has_value());
    ExpectPoseNear(*f0.T_world_camera_gt, poses[0], kPoseTolerance);
    const RgbdFrame f1 = sequence->Frame(1);
    EXPECT_DOUBLE_EQ(f1.timestamp, 11 / 30.0);
    ASSERT_TRUE(f1.T_world_camera_gt.has_value());
    ExpectPoseNear(*f1.T_world_camera_gt, poses[1], kReorthonormalisedTolerance);
    const Mat3 R = f1.T_world_camera_gt->linear();
    EXPECT_LT((R.transpose() * R - Mat3::Identity()).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_EQ(sequence->GroundTruth().poses.size(), 2u);
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_THAT(warnings[0], HasSubstr("frame-000011.pose.txt: rotation re-orthonormalised"));
  }

  const std::string pose1 = (frames / "frame-000011.pose.txt").string();
  io_test::WriteText(pose1, PoseText(poses[1], 5e-3));
  EXPECT_THAT(io_test::InputErrorMessage([&] { OpenRgbdSequence(root.string()); }),
              StartsWith(pose1 + ": rotation block is not a rotation"));
  io_test::WriteText(pose1, "1 0 0 0\n0 1 0\n0 0 1 0\n0 0 0 1\n");
  EXPECT_EQ(io_test::InputErrorMessage([&] { OpenRgbdSequence(root.string()); }),
            pose1 + ": line 2: expected 4 numbers, got 3 fields");
  fs::remove(pose1);
  EXPECT_THAT(io_test::InputErrorMessage([&] { OpenRgbdSequence(root.string()); }),
              StartsWith(pose1 + ": cannot open"));
}

// ---------------------------------------------------------------------------------------------
// Rig-capture bursts.

TEST_F(RgbdSequenceTest, RigCaptureBurstIsASequenceOfItsFrames) {
  const std::string path = Path("burst.h5");
  io_test::WriteBurstCapture(path);
  const auto cam = OpenRgbdSequence(path);
  ASSERT_EQ(cam->size(), 3);
  EXPECT_THAT(cam->Describe(), HasSubstr("camera cam"));
  const RgbdFrame f1 = cam->Frame(1);
  EXPECT_EQ(f1.index, 1);
  EXPECT_DOUBLE_EQ(f1.timestamp, 1 / 30.0);
  EXPECT_EQ(f1.width, 3);
  EXPECT_EQ(f1.height, 2);
  EXPECT_EQ(f1.intrinsics.fx, 5.0);
  EXPECT_EQ(f1.intrinsics.cy, 1.0);
  // Frame 1 is {2, 1, NaN; -1, 2, 7}: -1 is invalid.
  EXPECT_EQ(f1.Depth(0, 0), 2.0f);
  EXPECT_EQ(f1.Depth(1, 0), 1.0f);
  EXPECT_TRUE(std::isnan(f1.Depth(2, 0)));
  EXPECT_TRUE(std::isnan(f1.Depth(0, 1)));
  EXPECT_EQ(f1.Depth(2, 1), 7.0f);
  EXPECT_TRUE(std::isnan(cam->Frame(0).Depth(1, 1)));  // +inf: invalid
  EXPECT_EQ(cam->Frame(2).Depth(0, 1), 5.0f);
  EXPECT_TRUE(cam->GroundTruth().poses.empty());

  SequenceOptions options;
  options.serial = "mm";
  options.stride = 2;
  const auto mm = OpenRgbdSequence(path, options);
  ASSERT_EQ(mm->size(), 1);
  EXPECT_NEAR(mm->Frame(0).Depth(0, 0), 1.0, kDepthTolerance);
  EXPECT_TRUE(std::isnan(mm->Frame(0).Depth(1, 0)));
  options.serial = "c";
  EXPECT_EQ(io_test::InputErrorMessage([&] { OpenRgbdSequence(path, options); }),
            path + ": camera c: not in the file (cameras: cam, mm)");
}

// ---------------------------------------------------------------------------------------------
// Real data.

TEST(RgbdSequenceRealData, TumFr1XyzSubset) {
  const std::string folder = io_test::SharedDataPath("tum_fr1_xyz_subset");
  RIGFIT_NEED_SHARED_DATA(folder);
  const auto sequence = OpenRgbdSequence(folder);
  ASSERT_EQ(sequence->size(), 37);
  EXPECT_THAT(sequence->Describe(), HasSubstr("fr1, depth.txt header"));
  EXPECT_EQ(sequence->GroundTruth().poses.size(), 3000u);
  const RgbdFrame f0 = sequence->Frame(0);
  EXPECT_DOUBLE_EQ(f0.timestamp, 1305031102.160407);
  EXPECT_EQ(f0.width, 640);
  EXPECT_EQ(f0.height, 480);
  EXPECT_EQ(f0.intrinsics.fx, 517.3);
  // Values of depth/1305031102.160407.png decoded by an independent PNG reader (Python's
  // zlib and the PNG filters by hand): a byte-order mistake would show here.
  EXPECT_NEAR(f0.Depth(320, 240), 5287 / 5000.0, kDepthTolerance);
  EXPECT_NEAR(f0.Depth(100, 400), 5237 / 5000.0, kDepthTolerance);
  EXPECT_TRUE(std::isnan(f0.Depth(0, 0)));
  EXPECT_EQ(f0.color.size(), 640u * 480u * 3u);
  // groundtruth.txt's nearest line, 1305031102.1558 (4.6 ms before the depth image).
  ASSERT_TRUE(f0.T_world_camera_gt.has_value());
  EXPECT_NEAR((f0.T_world_camera_gt->translation() - Vec3(1.3452, 0.6273, 1.6627)).norm(), 0.0,
              1e-12);
  const Eigen::Quaterniond q(f0.T_world_camera_gt->linear());
  EXPECT_NEAR(std::abs(q.dot(Eigen::Quaterniond(-0.3265, 0.6582, 0.6109, -0.2950).normalized())),
              1.0, 1e-12);
  for (int i = 0; i < sequence->size(); i += 12) {
    EXPECT_TRUE(sequence->Frame(i).T_world_camera_gt.has_value()) << i;
  }
}

TEST(RgbdSequenceRealData, SevenScenesKitchen) {
  const std::string frames = io_test::SharedDataPath("sevenscenes_kitchen/frames");
  RIGFIT_NEED_SHARED_DATA(frames);
  std::vector<std::string> warnings;
  const auto sequence = OpenRgbdSequence(frames, {}, &warnings);
  ASSERT_EQ(sequence->size(), 400);
  EXPECT_EQ(warnings.size(), 1u);  // one line for the limited-precision rotations
  const RgbdFrame f0 = sequence->Frame(0);
  EXPECT_EQ(f0.source, frames + "/frame-000200.depth.png");
  EXPECT_DOUBLE_EQ(f0.timestamp, 200 / 30.0);
  EXPECT_EQ(f0.intrinsics.fx, 585.0);
  EXPECT_EQ(f0.intrinsics.cy, 240.0);
  EXPECT_TRUE(f0.color.empty());
  // Decoded independently, as for TUM.
  EXPECT_NEAR(f0.Depth(320, 240), 2.201, kDepthTolerance);
  EXPECT_NEAR(f0.Depth(600, 50), 2.289, kDepthTolerance);
  // frame-000200.pose.txt.
  Eigen::Matrix4d M;
  M << 9.7225642e-01, 1.6427894e-01, -1.6609631e-01, -7.0353621e-01, -1.8066891e-01, 9.7945935e-01,
      -8.8809885e-02, -3.773796e-01, 1.4809746e-01, 1.1636292e-01, 9.8201954e-01, 7.3030251e-01, 0,
      0, 0, 1;
  ASSERT_TRUE(f0.T_world_camera_gt.has_value());
  EXPECT_LT((f0.T_world_camera_gt->matrix() - M).cwiseAbs().maxCoeff(),
            kReorthonormalisedTolerance);
  EXPECT_LT((f0.T_world_camera_gt->translation() - M.topRightCorner<3, 1>()).norm(), 1e-12);
  const Trajectory gt = sequence->GroundTruth();
  ASSERT_EQ(gt.poses.size(), 400u);
  EXPECT_DOUBLE_EQ(gt.timestamps.back(), 599 / 30.0);
}

}  // namespace
}  // namespace rigfit

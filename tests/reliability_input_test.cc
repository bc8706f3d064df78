// Issue 7, bad input: every kind of bad input the issue lists, run through the built
// `rigfit refine` (and `rigfit evaluate`) as a subprocess. Each must give exit code 2, exactly
// one line on stderr naming the file and the field at fault, and no output file.
// Kinds already covered by tests/cli_refine_test.cc and tests/cli_evaluate_test.cc are not
// repeated: a missing capture or evaluate file, malformed JSON, a camera in the extrinsics but
// not in the capture or the reverse, an unknown config key, --out onto the extrinsics, an output
// directory that does not exist, bad flags. The readers' own messages for every malformed
// dataset are tests/io_*_test.cc's job; here each kind is checked end to end.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli_test_util.h"

namespace rigfit {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;
using namespace cli_test;  // NOLINT: RunRigfit and friends
using ::testing::HasSubstr;

/// The simulated cameras (sim/simulate_rig.h SimSerial).
const char* kCamera0 = "31000000";
const char* kCamera1 = "31001117";

void WriteText(const fs::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

/// Replaces dataset `name` of an open HDF5 file by one of the given type, shape and values.
template <typename T>
void ReplaceDataset(hid_t file, const std::string& name, hid_t file_type, hid_t memory_type,
                    const std::vector<hsize_t>& dims, const std::vector<T>& values) {
  ASSERT_GE(H5Ldelete(file, name.c_str(), H5P_DEFAULT), 0) << name;
  const hid_t space = H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr);
  const hid_t d =
      H5Dcreate2(file, name.c_str(), file_type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(d, 0) << name;
  EXPECT_GE(H5Dwrite(d, memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()), 0) << name;
  H5Dclose(d);
  H5Sclose(space);
}

/// The values of a float dataset as float32, with its shape.
std::vector<float> ReadFloats(hid_t file, const std::string& name, std::vector<hsize_t>* dims) {
  const hid_t d = H5Dopen2(file, name.c_str(), H5P_DEFAULT);
  const hid_t space = H5Dget_space(d);
  dims->resize(H5Sget_simple_extent_ndims(space));
  H5Sget_simple_extent_dims(space, dims->data(), nullptr);
  std::vector<float> values(H5Sget_simple_extent_npoints(space));
  EXPECT_GE(H5Dread(d, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()), 0);
  H5Sclose(space);
  H5Dclose(d);
  return values;
}

std::string Depth(const std::string& serial) { return "/cameras/" + serial + "/depth"; }
std::string Intrinsics(const std::string& serial) { return "/cameras/" + serial + "/intrinsics"; }

/// Overwrites the intrinsics of `serial` with K (row-major 3x3).
void SetIntrinsics(hid_t file, const std::string& serial, const std::vector<double>& K) {
  ReplaceDataset(file, Intrinsics(serial), H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {3, 3}, K);
}

/// A 4x4 row-major matrix as JSON.
Json Matrix(const std::vector<std::vector<double>>& rows) { return Json(rows); }

class ReliabilityInputTest : public SimulatedRigSuite<ReliabilityInputTest> {
 protected:
  /// One tiny simulated rig (3 cameras, 64 x 36: every case fails before the solver runs).
  static void SetUpTestSuite() {
    SimulateRig("rigfit_reliability_input", {"--cameras", "3", "--width", "64", "--height", "36"});
  }

  void SetUp() override {
    SimulatedRigSuite::SetUp();
    const std::string name = ::testing::UnitTest::GetInstance()->current_test_info()->name();
    inputs_ = root_ / (name + "_inputs");
    out_dir_ = root_ / (name + "_out");
    fs::create_directories(inputs_);
    fs::create_directories(out_dir_);
  }

  static std::string Capture() { return Rig("capture.h5"); }
  static std::string Init() { return Rig("init.json"); }
  std::string Out() const { return (out_dir_ / "out.json").string(); }

  /// A copy of the capture, changed through the HDF5 C API.
  std::string MutatedCapture(const std::string& name, const std::function<void(hid_t)>& change) {
    const fs::path path = inputs_ / name;
    fs::copy_file(Capture(), path, fs::copy_options::overwrite_existing);
    const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    EXPECT_GE(file, 0);
    change(file);
    EXPECT_GE(H5Fclose(file), 0);
    return path.string();
  }

  /// A copy of the initial extrinsics, changed as JSON.
  std::string MutatedExtrinsics(const std::string& name, const std::function<void(Json&)>& change) {
    Json init = Json::parse(ReadText(Init()));
    change(init);
    const fs::path path = inputs_ / name;
    WriteText(path, init.dump(2));
    return path.string();
  }

  std::string Config(const std::string& name, const std::string& yaml) {
    const fs::path path = inputs_ / name;
    WriteText(path, yaml);
    return path.string();
  }

  RunResult Refine(const std::string& capture, const std::string& extrinsics,
                   std::vector<std::string> extra = {}) const {
    std::vector<std::string> args = {"refine",   "--capture", capture, "--extrinsics",
                                     extrinsics, "--out",     Out(),   "--quiet"};
    args.insert(args.end(), extra.begin(), extra.end());
    return RunRigfit(args, root_);
  }

  /// Exit code 2, stderr exactly one line "rigfit: error: ..." containing every one of
  /// `expected` (the file, the field), and nothing written.
  void ExpectRejected(const RunResult& r, const std::vector<std::string>& expected) const {
    EXPECT_EQ(r.exit_code, 2) << Describe(r);
    EXPECT_THAT(r.err, ::testing::StartsWith("rigfit: error: ")) << Describe(r);
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "one line\n" << Describe(r);
    for (const std::string& text : expected) EXPECT_THAT(r.err, HasSubstr(text)) << Describe(r);
    for (const auto& entry : fs::directory_iterator(out_dir_)) {
      ADD_FAILURE() << "unexpected output " << entry.path();
    }
  }

  fs::path inputs_;
  fs::path out_dir_;
};

// --- Files that cannot be read at all. ---------------------------------------------------------

TEST_F(ReliabilityInputTest, UnreadableInputsNameTheFile) {
  // Directories stand for unreadable files (permissions do not stop root, who may run CI).
  const std::string dir = inputs_.string();
  ExpectRejected(Refine(dir, Init()), {dir, "cannot open"});
  ExpectRejected(Refine(Capture(), dir), {dir, "cannot open"});
  ExpectRejected(Refine(Capture(), Init(), {"--config", dir}), {dir, "cannot open"});
  const std::string missing = (inputs_ / "missing.yaml").string();
  ExpectRejected(Refine(Capture(), Init(), {"--config", missing}), {missing, "cannot open"});
}

TEST_F(ReliabilityInputTest, TruncatedCaptureIsRejected) {
  const std::string bytes = ReadText(Capture());
  const fs::path truncated = inputs_ / "truncated.h5";
  WriteText(truncated, bytes.substr(0, bytes.size() / 2));
  ExpectRejected(Refine(truncated.string(), Init()), {truncated.string()});
}

TEST_F(ReliabilityInputTest, CorruptCaptureIsRejected) {
  // The HDF5 signature, then garbage: HDF5 recognises the file but cannot open it.
  std::string bytes = ReadText(Capture());
  for (size_t i = 8; i < bytes.size(); ++i) bytes[i] = static_cast<char>((i * 7919) % 251);
  const fs::path corrupt = inputs_ / "corrupt.h5";
  WriteText(corrupt, bytes);
  ExpectRejected(Refine(corrupt.string(), Init()), {corrupt.string(), "HDF5"});
  // A text file is no HDF5 file at all.
  const fs::path text = inputs_ / "text.h5";
  WriteText(text, ReadText(Init()));
  ExpectRejected(Refine(text.string(), Init()), {text.string(), "not an HDF5 file"});
}

TEST_F(ReliabilityInputTest, CaptureOnWhichLibhdf5CrashesIsAnError) {
  // A fuzzed file on which libhdf5 1.10.8 itself faults: a memcpy inside H5HG_read while the
  // variable-length string attribute 'format' is read (docs/reliability.md). The command line
  // reads a capture first in a child process (ReadCaptureGuarded), so the fault kills the
  // child and rigfit reports it: exit 2, a last line naming the file, nothing written, the
  // previous output and the input as they were. (Under ASan the child's report precedes it.)
  const fs::path finding = fs::path(RIGFIT_SOURCE_DIR) / "fuzz" / "regressions" /
                           "capture_h5_libhdf5_crash" /
                           "memcpy_overlap_H5HG_read_vlen_attribute.h5";
  const std::string input = ReadText(finding.string());
  ASSERT_FALSE(input.empty());
  WriteText(Out(), "previous output");
  const RunResult r = Refine(finding.string(), Init());
  EXPECT_EQ(r.exit_code, 2) << Describe(r);
  const size_t last = r.err.rfind('\n', r.err.size() >= 2 ? r.err.size() - 2 : 0);
  const std::string last_line = r.err.substr(last == std::string::npos ? 0 : last + 1);
  EXPECT_THAT(last_line, ::testing::StartsWith("rigfit: error: " + finding.string() + ": "))
      << Describe(r);
  EXPECT_THAT(last_line, HasSubstr("damaged file?")) << Describe(r);
  EXPECT_EQ(ReadText(Out()), "previous output");
  EXPECT_EQ(ReadText(finding.string()), input);
  int files = 0;
  for (const auto& entry : fs::directory_iterator(out_dir_)) files += entry.exists() ? 1 : 0;
  EXPECT_EQ(files, 1) << "no temporary file left";
}

// --- HDF5 files that are not a rig capture. ----------------------------------------------------

TEST_F(ReliabilityInputTest, WrongFormatAttributeIsRejected) {
  const std::string capture = MutatedCapture("format.h5", [](hid_t file) {
    ASSERT_GE(H5Adelete(file, "format"), 0);
    const hid_t type = H5Tcopy(H5T_C_S1);
    H5Tset_size(type, 11);
    const hid_t space = H5Screate(H5S_SCALAR);
    const hid_t a = H5Acreate2(file, "format", type, space, H5P_DEFAULT, H5P_DEFAULT);
    EXPECT_GE(H5Awrite(a, type, "point-cloud"), 0);
    H5Aclose(a);
    H5Sclose(space);
    H5Tclose(type);
  });
  ExpectRejected(Refine(capture, Init()), {capture, "root attribute 'format'", "point-cloud"});
}

TEST_F(ReliabilityInputTest, MissingCamerasGroupIsRejected) {
  const std::string capture = MutatedCapture(
      "no_cameras.h5", [](hid_t file) { ASSERT_GE(H5Ldelete(file, "/cameras", H5P_DEFAULT), 0); });
  ExpectRejected(Refine(capture, Init()), {capture, "missing group /cameras"});
}

TEST_F(ReliabilityInputTest, DepthOfTheWrongRankIsRejected) {
  const std::string capture = MutatedCapture("rank1.h5", [](hid_t file) {
    ReplaceDataset(file, Depth(kCamera1), H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, {64 * 36},
                   std::vector<float>(64 * 36, 2.0f));
  });
  ExpectRejected(Refine(capture, Init()),
                 {capture, "camera 31001117", "depth", "expected rank 2 or 3, got 1"});
}

TEST_F(ReliabilityInputTest, DepthOfTheWrongDtypeIsRejected) {
  const std::string capture = MutatedCapture("int32.h5", [](hid_t file) {
    ReplaceDataset(file, Depth(kCamera1), H5T_STD_I32LE, H5T_NATIVE_INT32, {36, 64},
                   std::vector<std::int32_t>(64 * 36, 2000));
  });
  ExpectRejected(Refine(capture, Init()), {capture, "camera 31001117", "depth", "got int32"});
}

TEST_F(ReliabilityInputTest, DepthInTheWrongUnitIsRejected) {
  // Millimetres written as float metres: 2000 "m" is no depth camera's measurement.
  const std::string capture = MutatedCapture("millimetres.h5", [](hid_t file) {
    std::vector<hsize_t> dims;
    std::vector<float> depth = ReadFloats(file, Depth(kCamera1), &dims);
    for (float& z : depth) z *= 1000.0f;
    ReplaceDataset(file, Depth(kCamera1), H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, dims, depth);
  });
  ExpectRejected(Refine(capture, Init()), {capture, "camera 31001117", "depth",
                                           "median valid depth", "is beyond 100 m", "metres"});
}

TEST_F(ReliabilityInputTest, DepthGlitchesAreDroppedCountedAndReported) {
  // A sensor glitch: three pixels at 1e7 m in an otherwise sound depth image.
  const std::string capture = MutatedCapture("glitch.h5", [](hid_t file) {
    std::vector<hsize_t> dims;
    std::vector<float> depth = ReadFloats(file, Depth(kCamera1), &dims);
    for (const size_t i : {size_t{5}, size_t{77}, size_t{301}}) depth[i] = 1e7f;
    ReplaceDataset(file, Depth(kCamera1), H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, dims, depth);
  });
  const RunResult r = Refine(capture, Init(), {"--no-icp"});
  ASSERT_EQ(r.exit_code, 0) << Describe(r);
  const std::string warning = std::string("camera ") + kCamera1 +
                              ": 3 depth samples beyond 1000 m read as invalid (sensor glitches)";
  EXPECT_THAT(r.err, HasSubstr(warning)) << Describe(r);
  const Json out = Json::parse(ReadText(Out()));
  EXPECT_THAT(out["_meta"]["icp_refined"]["warnings"].dump(), HasSubstr(warning));
}

TEST_F(ReliabilityInputTest, BadFocalLengthsAreRejected) {
  const double kNaN = std::numeric_limits<double>::quiet_NaN();
  const double kInf = std::numeric_limits<double>::infinity();
  for (const double f : {0.0, -300.0, kNaN, kInf, 1e-200}) {
    SCOPED_TRACE(f);
    const std::string capture = MutatedCapture("focal.h5", [f](hid_t file) {
      SetIntrinsics(file, kCamera0, {f, 0, 31.5, 0, 40.0, 17.5, 0, 0, 1});
    });
    ExpectRejected(Refine(capture, Init()), {capture, "camera 31000000", "intrinsics"});
  }
}

// --- Extrinsics. -------------------------------------------------------------------------------

TEST_F(ReliabilityInputTest, DuplicatedSerialIsRejected) {
  // nlohmann::json keeps the last of two equal keys; rigfit refuses to guess.
  const Json init = Json::parse(ReadText(Init()));
  const std::string camera = init[kCamera0].dump();
  std::string text = init.dump();
  text.insert(1, "\"" + std::string(kCamera0) + "\": " + camera + ", ");
  const fs::path path = inputs_ / "duplicate.json";
  WriteText(path, text);
  ExpectRejected(Refine(Capture(), path.string()),
                 {path.string(), "duplicate key \"31000000\"", "serials must be unique"});
}

TEST_F(ReliabilityInputTest, EmptySerialIsRejected) {
  const std::string path =
      MutatedExtrinsics("empty_serial.json", [](Json& j) { j[""] = j[kCamera0]; });
  ExpectRejected(Refine(Capture(), path), {path, "empty camera serial"});
}

TEST_F(ReliabilityInputTest, NonRigidMatricesAreRejected) {
  const std::vector<std::pair<std::string, Json>> cases = {
      {"scaled", Matrix({{1.01, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}})},
      {"sheared", Matrix({{1, 0.1, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}})},
      {"mirrored", Matrix({{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, -1, 0}, {0, 0, 0, 1}})},
  };
  for (const auto& [name, matrix] : cases) {
    SCOPED_TRACE(name);
    const std::string path =
        MutatedExtrinsics(name + ".json", [&](Json& j) { j[kCamera1]["T_world_camera"] = matrix; });
    ExpectRejected(Refine(Capture(), path),
                   {path, "camera 31001117", "T_world_camera", "rotation block is not a rotation"});
  }
  const std::string projective = MutatedExtrinsics("projective.json", [](Json& j) {
    j[kCamera1]["T_world_camera"][3] = Json::array({0, 0, 0.5, 1});
  });
  ExpectRejected(Refine(Capture(), projective),
                 {projective, "camera 31001117", "T_world_camera", "last row"});
  const std::string huge = (inputs_ / "overflow.json").string();
  WriteText(huge, "{\"31000000\": {\"T_world_camera\": [[1e999, 0, 0, 0]]}}");
  ExpectRejected(Refine(Capture(), huge), {huge, "malformed JSON"});
}

// --- Config. -----------------------------------------------------------------------------------

TEST_F(ReliabilityInputTest, ConfigOfTheWrongTypeOrOutOfRangeIsRejected) {
  struct Case {
    std::string yaml;
    std::string line;  ///< the message names the line of the key, to point at what to fix
    std::string what;
  };
  for (const Case& c : std::vector<Case>{
           {"icp:\n  voxel_size: fine\n", "2", "icp.voxel_size: expected a number"},
           {"region:\n  pixel_stride: 1.5\n", "2", "region.pixel_stride: expected an integer"},
           {"ground:\n  enabled: [true]\n", "2", "ground.enabled: expected true or false"},
           {"icp:\n  scales: 4\n", "2", "icp.scales: expected a list"},
           {"icp: 0.02\n", "1", "icp: expected a map"},
           {"icp:\n  voxel_size: -0.02\n", "2", "icp.voxel_size must be > 0"},
           {"region:\n  band_height: -0.1\n", "2", "region.band_height must be >= 0"},
           {"icp:\n  gravity_weight: -500\n", "2", "icp.gravity_weight must be >= 0"},
           {"icp:\n  robust_loss_scale: 0\n", "2", "icp.robust_loss_scale must be > 0"},
           {"icp:\n  min_fitness: 1.5\n", "2", "icp.min_fitness must be in [0, 1]"},
           {"ground:\n  max_rotation_deg: .inf\n", "2", "ground.max_rotation_deg"}}) {
    SCOPED_TRACE(c.yaml);
    const std::string config = Config("config.yaml", c.yaml);
    ExpectRejected(Refine(Capture(), Init(), {"--config", config}),
                   {config + ":" + c.line + ": ", c.what});
  }
}

TEST_F(ReliabilityInputTest, ConfigSyntaxErrorNamesTheLine) {
  const std::string config = Config("syntax.yaml", "icp:\n  voxel_size: [0.02\n");
  ExpectRejected(Refine(Capture(), Init(), {"--config", config}), {config + ":", "YAML syntax"});
}

// --- Outputs. ----------------------------------------------------------------------------------

TEST_F(ReliabilityInputTest, OutputOntoAnyInputIsRefusedAndTheInputIsUnchanged) {
  const fs::path capture = inputs_ / "capture.h5";
  const fs::path config = inputs_ / "rig.yaml";
  fs::copy_file(Capture(), capture);
  WriteText(config, "icp:\n  voxel_size: 0.05\n");
  const fs::path link = inputs_ / "link.json";
  fs::create_symlink(capture, link);
  const std::string capture_bytes = ReadText(capture);
  for (const fs::path& out : {capture, config, link}) {
    SCOPED_TRACE(out);
    const RunResult r = RunRigfit({"refine", "--capture", capture.string(), "--extrinsics", Init(),
                                   "--config", config.string(), "--out", out.string(), "--quiet"},
                                  root_);
    ExpectRejected(r, {out.string(), "it is an input file"});
  }
  EXPECT_EQ(ReadText(capture), capture_bytes);
  EXPECT_EQ(ReadText(config), "icp:\n  voxel_size: 0.05\n");
}

TEST_F(ReliabilityInputTest, OutputThatIsADirectoryIsRefused) {
  const RunResult r = RunRigfit(
      {"refine", "--capture", Capture(), "--extrinsics", Init(), "--out", out_dir_.string()},
      root_);
  ExpectRejected(r, {out_dir_.string(), "is a directory"});
}

// --- rigfit evaluate. --------------------------------------------------------------------------

TEST_F(ReliabilityInputTest, EvaluateRejectsBadExtrinsicsAndBadJsonOutput) {
  const std::string gt = Rig("gt.json");
  const std::string json = (out_dir_ / "errors.json").string();
  const std::string non_rigid = MutatedExtrinsics(
      "non_rigid.json", [](Json& j) { j[kCamera1]["T_world_camera"][0][0] = 2.0; });
  ExpectRejected(RunRigfit({"evaluate", non_rigid, gt, "--json", json}, root_),
                 {non_rigid, "camera 31001117", "T_world_camera"});
  ExpectRejected(RunRigfit({"evaluate", Init(), non_rigid, "--json", json}, root_),
                 {non_rigid, "camera 31001117", "T_world_camera"});
  const std::string missing_dir = (out_dir_ / "no_such_dir" / "errors.json").string();
  ExpectRejected(RunRigfit({"evaluate", Init(), gt, "--json", missing_dir}, root_),
                 {missing_dir, "does not exist"});
  const std::string gt_copy = (inputs_ / "gt.json").string();
  fs::copy_file(gt, gt_copy);
  ExpectRejected(RunRigfit({"evaluate", Init(), gt_copy, "--json", gt_copy}, root_),
                 {gt_copy, "it is an input file"});
  EXPECT_EQ(ReadText(gt_copy), ReadText(gt));
}

}  // namespace
}  // namespace rigfit

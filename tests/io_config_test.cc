#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <regex>
#include <sstream>

#include "io/config_yaml.h"
#include "io_test_util.h"

namespace rigfit {
namespace {

using ::testing::AllOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;
using ::testing::Not;

/// Field-by-field equality of two option sets (every key, doubles exactly).
void ExpectSameOptions(const RefineOptions& a, const RefineOptions& b) {
  EXPECT_EQ(ConfigToJson(a), ConfigToJson(b)) << ConfigToJson(a).dump(2) << "\nvs\n"
                                              << ConfigToJson(b).dump(2);
}

std::string ParseError(const std::string& yaml) {
  return io_test::InputErrorMessage([&] { ParseConfig(yaml, "config.yaml"); });
}

RefineOptions NonDefaultOptions() {
  RefineOptions o;
  o.ground.enabled = false;
  o.ground.max_normal_angle_deg = 12.5;
  o.ground.ransac_distance_m = 0.015;
  o.ground.ransac_iterations = 1234;
  o.ground.search_height_m = 0.25;
  o.ground.min_inliers = 77;
  o.ground.max_rotation_deg = 3.0;
  o.ground.max_translation_m = 0.05;
  o.ground.seed = 18446744073709551615ull;
  o.region.band_below = 0.1;
  o.region.band_height = 0.0;
  o.region.pixel_stride = 3;
  o.region.min_depth_m = 0.3;
  o.region.max_depth_m = 6.5;
  o.region.edge_margin_px = 2;
  o.region.stereo_edge_margin_px = 3;
  o.region.stereo_edge_min_width_px = 800;
  o.region.edge_jump = 0.08;
  o.icp.mode = RefineMode::kPairwise;
  o.icp.method = RegistrationMethod::kGicp;
  o.icp.surface_bundle = !IcpOptions{}.surface_bundle;  // the other value than the default
  o.icp.voxel_size = 0.1 + 0.2;                         // 0.30000000000000004: needs 17 digits
  o.icp.scales = {8.0, 1.0 / 3.0};
  o.icp.max_iterations = {5, 7};
  o.icp.max_correspondence_distance_factor = 2.5;
  o.icp.max_normal_angle_deg = 45.0;
  o.icp.normal_neighbors = 9;
  o.icp.depth_noise = 0.0025;
  o.icp.min_noise_m = 0.002;
  o.icp.plane_noise_share = 1.5;
  o.icp.gravity_weight = 0.0;
  o.icp.degeneracy_threshold = 0.01;
  o.icp.hold_weak_directions = true;
  o.icp.depth_noise_model = DepthNoiseModel::kDisparity;
  o.icp.surface_rounds = 2;
  o.icp.surface_faces = SurfaceFaces::kImage;
  o.icp.depth_model = CameraDepthModel::kScaleOffset;
  o.icp.depth_scale_sigma = 0.005;
  o.icp.depth_offset_sigma_px = 0.1;
  o.icp.surface_bias_px = 0.25;
  o.icp.robust_loss = RobustLoss::kTukey;
  o.icp.robust_loss_scale = 4.685;
  o.icp.min_fitness = 1.0;
  o.icp.overlap_margin = 0.0;
  o.icp.min_overlap_area = 2.0;
  o.icp.reference = "31002234";
  o.icp.max_rotation_deg = 2.0;
  o.icp.max_translation_m = 0.02;
  return o;
}

TEST(Config, DefaultYamlFileIsExactlyTheDefaults) {
  ExpectSameOptions(LoadConfig(RIGFIT_SOURCE_DIR "/configs/default.yaml"), RefineOptions{});
}

/// Member names of `struct <name> { ... };` in a header: declarations "type name [= value];".
std::vector<std::string> StructMembers(const std::string& header, const std::string& name) {
  const size_t begin = header.find("struct " + name + " {");
  const size_t end = header.find("\n};", begin);
  EXPECT_NE(begin, std::string::npos) << name;
  std::istringstream body(header.substr(begin, end - begin));
  const std::regex declaration(R"(^\s+[\w:<>, ]+?\s+(\w+)(\s*=[^;]*)?;)");
  std::vector<std::string> members;
  std::smatch match;
  for (std::string line; std::getline(body, line);) {
    if (std::regex_search(line, match, declaration)) members.push_back(match[1]);
  }
  std::sort(members.begin(), members.end());
  return members;
}

TEST(Config, EveryMemberOfTheOptionStructsIsAConfigKey) {
  const std::string header = io_test::ReadText(RIGFIT_SOURCE_DIR "/options/refine_options.h");
  const nlohmann::json config = ConfigToJson(RefineOptions{});
  for (const auto& [section, type] :
       {std::pair<std::string, std::string>{"ground", "GroundOptions"},
        {"region", "RegionOptions"},
        {"icp", "IcpOptions"}}) {
    std::vector<std::string> keys;
    for (const auto& [key, value] : config[section].items()) keys.push_back(key);
    std::vector<std::string> members = StructMembers(header, type);
    // Set in code only, never read from a file: the surface bundle's diagnostics copy.
    members.erase(std::remove(members.begin(), members.end(), "keep_surface_diagnostics"),
                  members.end());
    EXPECT_EQ(keys, members) << section;  // both sorted
  }
}

TEST(Config, YamlRoundTripOfEveryKey) {
  const RefineOptions o = NonDefaultOptions();
  // Every key differs from its default, so a key that ConfigToYaml or the parser skips fails.
  const nlohmann::json defaults = ConfigToJson(RefineOptions{});
  const nlohmann::json changed = ConfigToJson(o);
  for (const auto& [section, values] : defaults.items()) {
    for (const auto& [key, value] : values.items()) {
      EXPECT_NE(changed[section][key], value) << section << "." << key;
    }
  }
  ExpectSameOptions(ParseConfig(ConfigToYaml(o), "echo.yaml"), o);
  ExpectSameOptions(ParseConfig(ConfigToYaml(RefineOptions{}), "echo.yaml"), RefineOptions{});
}

TEST(Config, OnlyKeysPresentOverride) {
  const RefineOptions o = ParseConfig(
      "# comment\nicp:\n  voxel_size: 0.05\n  method: gicp\n  scales: [3, 1]\n"
      "  max_iterations:\n    - 10\n    - 5\nground:\nregion: {pixel_stride: 4}\n",
      "config.yaml");
  RefineOptions expected;
  expected.icp.voxel_size = 0.05;
  expected.icp.method = RegistrationMethod::kGicp;
  expected.icp.scales = {3.0, 1.0};
  expected.icp.max_iterations = {10, 5};
  expected.region.pixel_stride = 4;
  ExpectSameOptions(o, expected);
  ExpectSameOptions(ParseConfig("", "empty.yaml"), RefineOptions{});
  ExpectSameOptions(ParseConfig("# nothing but a comment\n", "empty.yaml"), RefineOptions{});
}

TEST(Config, JsonUsesConfigNames) {
  const nlohmann::json j = ConfigToJson(NonDefaultOptions());
  EXPECT_EQ(j["icp"]["mode"], "pairwise");
  EXPECT_EQ(j["icp"]["method"], "gicp");
  EXPECT_EQ(j["icp"]["robust_loss"], "tukey");
  EXPECT_EQ(j["icp"]["scales"], nlohmann::json({8.0, 1.0 / 3.0}));
  EXPECT_EQ(j["ground"]["seed"].get<std::uint64_t>(), 18446744073709551615ull);
  EXPECT_EQ(j["icp"]["reference"], "31002234");
}

TEST(Config, UnknownKeysSuggestNearMissesAndOtherSections) {
  EXPECT_THAT(ParseError("icp:\n  method: gicp\n  voxl_size: 0.1\n"),
              HasSubstr("config.yaml:3: icp.voxl_size: unknown key (did you mean 'voxel_size'?)"));
  EXPECT_THAT(ParseError("ground:\n  voxel_size: 0.1\n"),
              HasSubstr("config.yaml:2: ground.voxel_size: unknown key (did you mean "
                        "'icp.voxel_size'?)"));
  EXPECT_THAT(ParseError("region:\n  max_rotation_deg: 3\n"),
              HasSubstr("did you mean 'ground.max_rotation_deg' or 'icp.max_rotation_deg'?"));
  EXPECT_THAT(ParseError("icpp:\n  voxel_size: 0.1\n"),
              HasSubstr("config.yaml:1: icpp: unknown key (did you mean 'icp'?)"));
  EXPECT_THAT(ParseError("voxel_size: 0.1\n"), HasSubstr("did you mean 'icp.voxel_size'?"));
  EXPECT_THAT(ParseError("icp:\n  colour: red\n"),
              AllOf(HasSubstr("icp.colour: unknown key"), Not(HasSubstr("did you mean"))));
}

TEST(Config, WrongTypesNameLineAndKey) {
  EXPECT_THAT(ParseError("icp:\n  voxel_size: \"0.1\"\n"),
              HasSubstr("config.yaml:2: icp.voxel_size: expected a number, got the string "
                        "\"0.1\""));
  EXPECT_THAT(ParseError("icp:\n  voxel_size: abc\n"),
              HasSubstr("config.yaml:2: icp.voxel_size: expected a number, got 'abc'"));
  EXPECT_THAT(ParseError("icp:\n  voxel_size: [0.1]\n"),
              HasSubstr("icp.voxel_size: expected a number, got a list"));
  EXPECT_THAT(ParseError("icp:\n  voxel_size: .nan\n"),
              HasSubstr("icp.voxel_size: expected a finite number"));
  EXPECT_THAT(ParseError("ground:\n\n  ransac_iterations: 2.5\n"),
              HasSubstr("config.yaml:3: ground.ransac_iterations: expected an integer, got '2.5'"));
  EXPECT_THAT(ParseError("ground:\n  ransac_iterations: 99999999999\n"),
              HasSubstr("ground.ransac_iterations: integer out of range"));
  EXPECT_THAT(ParseError("ground:\n  seed: -1\n"),
              HasSubstr("ground.seed: expected a non-negative integer"));
  EXPECT_THAT(ParseError("ground:\n  enabled: maybe\n"),
              HasSubstr("ground.enabled: expected true or false, got 'maybe'"));
  EXPECT_THAT(ParseError("icp:\n  scales: 2\n"),
              HasSubstr("config.yaml:2: icp.scales: expected a list of numbers"));
  EXPECT_THAT(ParseError("icp:\n  scales: [4, x, 1]\n"),
              HasSubstr("config.yaml:2: icp.scales[1]: expected a number, got 'x'"));
  EXPECT_THAT(ParseError("icp:\n  max_iterations: [4, 2.5, 1]\n"),
              HasSubstr("icp.max_iterations[1]: expected an integer"));
  EXPECT_THAT(ParseError("icp:\n  reference: [a, b]\n"),
              HasSubstr("icp.reference: expected a string, got a list"));
  EXPECT_THAT(ParseError("icp: 3\n"), HasSubstr("config.yaml:1: icp: expected a map of keys"));
  EXPECT_THAT(ParseError("- icp\n"), HasSubstr("expected a map with the sections"));
}

TEST(Config, UnknownEnumValuesListTheValidOnes) {
  EXPECT_THAT(ParseError("icp:\n  method: icp\n"),
              HasSubstr("config.yaml:2: icp.method: unknown value 'icp'; valid: point_to_plane, "
                        "gicp"));
  EXPECT_THAT(ParseError("icp:\n  mode: jont\n"),
              HasSubstr("valid: joint, pairwise (did you mean 'joint'?)"));
  EXPECT_THAT(ParseError("icp:\n  robust_loss: l2\n"),
              HasSubstr("valid: huber, cauchy, tukey, none"));
}

TEST(Config, RangeProblemsCarryTheLineOfTheKey) {
  EXPECT_THAT(ParseError("icp:\n  method: gicp\n  voxel_size: -1\n"),
              HasSubstr("config.yaml:3: icp.voxel_size must be > 0, got -1"));
  EXPECT_THAT(ParseError("icp:\n  scales: [1, 2]\n  max_iterations: [3, 3]\n"),
              HasSubstr("config.yaml:2: icp.scales[1] must be < icp.scales[0]"));
  EXPECT_THAT(ParseError("icp:\n  scales: [2, 1]\n"),
              HasSubstr("config.yaml:2: icp.max_iterations must have one entry per icp.scales "
                        "entry (2), got 3"));
  // A cross-key problem is reported at the key the file sets.
  EXPECT_THAT(ParseError("region:\n  min_depth_m: 20\n"),
              HasSubstr("config.yaml:2: region.min_depth_m must be < region.max_depth_m"));
}

TEST(Config, ReportsEveryProblemAtOnceAndSyntaxErrorsWithLines) {
  const std::string all =
      ParseError("ground:\n  enabled: 3\nicp:\n  voxl_size: 1\n  method: x\n  method: gicp\n");
  EXPECT_THAT(all, HasSubstr("config.yaml:2: ground.enabled"));
  EXPECT_THAT(all, HasSubstr("config.yaml:4: icp.voxl_size"));
  EXPECT_THAT(all, HasSubstr("config.yaml:5: icp.method: unknown value 'x'"));
  EXPECT_THAT(all, HasSubstr("config.yaml:6: icp.method: duplicate key"));
  EXPECT_THAT(ParseError("icp:\n  voxel_size: 0.1\n  scales: [1, 2\n"),
              HasSubstr("YAML syntax error"));
  EXPECT_THAT(ParseError("icp:\n  voxel_size: 0.1\n bad: indentation\n"),
              HasSubstr("config.yaml:3: YAML syntax error"));
}

TEST(Config, LoadConfigNamesTheFile) {
  EXPECT_THAT(io_test::InputErrorMessage([] { LoadConfig("/nonexistent/rigfit.yaml"); }),
              HasSubstr("/nonexistent/rigfit.yaml: cannot open"));
}

TEST(OptionProblems, DefaultsAreValidAndEachRuleNamesItsKey) {
  EXPECT_THAT(OptionProblems(RefineOptions{}), IsEmpty());
  const auto problems_of = [](auto change) {
    RefineOptions o;
    change(o);
    return OptionProblems(o);
  };
  EXPECT_THAT(problems_of([](RefineOptions& o) { o.icp.voxel_size = 0.0; }),
              ElementsAre("icp.voxel_size must be > 0, got 0"));
  EXPECT_THAT(problems_of([](RefineOptions& o) {
                o.icp.voxel_size = std::numeric_limits<double>::quiet_NaN();
              }),
              ElementsAre("icp.voxel_size must be > 0, got nan"));
  EXPECT_THAT(problems_of([](RefineOptions& o) { o.region.band_height = -0.1; }),
              ElementsAre("region.band_height must be >= 0, got -0.1"));
  EXPECT_THAT(problems_of([](RefineOptions& o) { o.region.band_below = -0.1; }),
              ElementsAre("region.band_below must be >= 0, got -0.1"));
  EXPECT_THAT(problems_of([](RefineOptions& o) { o.region.pixel_stride = 0; }),
              ElementsAre("region.pixel_stride must be >= 1, got 0"));
  EXPECT_THAT(problems_of([](RefineOptions& o) { o.region.min_depth_m = 0.0; }),
              ElementsAre("region.min_depth_m must be > 0, got 0"));
  EXPECT_THAT(problems_of([](RefineOptions& o) { o.icp.min_fitness = 1.5; }),
              ElementsAre("icp.min_fitness must be in [0, 1], got 1.5"));
  EXPECT_THAT(problems_of([](RefineOptions& o) { o.icp.gravity_weight = -1.0; }),
              ElementsAre("icp.gravity_weight must be >= 0, got -1"));
  EXPECT_THAT(problems_of([](RefineOptions& o) { o.icp.surface_bias_px = -0.1; }),
              ElementsAre("icp.surface_bias_px must be >= 0, got -0.1"));
  EXPECT_THAT(problems_of([](RefineOptions& o) { o.icp.degeneracy_threshold = 1.0; }),
              ElementsAre("icp.degeneracy_threshold must be in [0, 1), got 1"));
  EXPECT_THAT(problems_of([](RefineOptions& o) { o.ground.max_normal_angle_deg = 95.0; }),
              ElementsAre("ground.max_normal_angle_deg must be in (0, 90], got 95"));
  EXPECT_THAT(problems_of([](RefineOptions& o) { o.icp.max_rotation_deg = 0.0; }),
              ElementsAre("icp.max_rotation_deg must be in (0, 180], got 0"));
  EXPECT_THAT(problems_of([](RefineOptions& o) { o.ground.min_inliers = 2; }),
              ElementsAre("ground.min_inliers must be >= 3, got 2"));
  EXPECT_THAT(problems_of([](RefineOptions& o) { o.icp.normal_neighbors = 2; }),
              ElementsAre("icp.normal_neighbors must be >= 3, got 2"));
  EXPECT_THAT(problems_of([](RefineOptions& o) { o.icp.min_noise_m = 0.0; }),
              ElementsAre("icp.min_noise_m must be > 0, got 0"));
  EXPECT_THAT(problems_of([](RefineOptions& o) { o.icp.plane_noise_share = -0.5; }),
              ElementsAre("icp.plane_noise_share must be >= 0, got -0.5"));
  EXPECT_THAT(problems_of([](RefineOptions& o) { o.icp.robust_loss_scale = 0.0; }),
              ElementsAre("icp.robust_loss_scale must be > 0, got 0"));
  EXPECT_THAT(problems_of([](RefineOptions& o) { o.icp.depth_noise = -1e-3; }),
              ElementsAre("icp.depth_noise must be >= 0, got -0.001"));
  EXPECT_THAT(problems_of([](RefineOptions& o) {
                o.icp.scales.clear();
                o.icp.max_iterations.clear();
              }),
              ElementsAre("icp.scales must not be empty"));
  EXPECT_THAT(problems_of([](RefineOptions& o) {
                o.icp.max_iterations = {50, 0, 14};
              }),
              ElementsAre("icp.max_iterations[1] must be >= 1, got 0"));
  EXPECT_THAT(problems_of([](RefineOptions& o) { o.icp.mode = static_cast<RefineMode>(7); }),
              ElementsAre("icp.mode must be joint or pairwise, got 7"));
}

}  // namespace
}  // namespace rigfit

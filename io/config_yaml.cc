#include "io/config_yaml.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <type_traits>
#include <utility>
#include <variant>

#include "core/errors.h"
#include "core/format.h"
#include "io/read_file.h"

namespace rigfit {
namespace {

// ---------------------------------------------------------------------------------------------
// The schema: one table of every key, driving parsing, ConfigToYaml and ConfigToJson alike, so
// the three can never disagree. Field pointers point into the RefineOptions being read/written.
// Every member of the structs in options/refine_options.h must have its row here, in struct order.

template <typename E>
using EnumNames = std::vector<std::pair<E, std::string>>;

const EnumNames<RefineMode> kModeNames = {{RefineMode::kJoint, "joint"},
                                          {RefineMode::kPairwise, "pairwise"}};
const EnumNames<RegistrationMethod> kMethodNames = {
    {RegistrationMethod::kPointToPlane, "point_to_plane"}, {RegistrationMethod::kGicp, "gicp"}};
/// What an earlier value of icp.method is now: the surface bundle became a stage of its own.
constexpr const char* kSurfaceBundleMoved =
    "the surface bundle is no longer a method but the stage after registration: set "
    "icp.surface_bundle: true and keep icp.method point_to_plane or gicp";
const EnumNames<DepthNoiseModel> kNoiseModelNames = {
    {DepthNoiseModel::kGaussianDepth, "gaussian_depth"},
    {DepthNoiseModel::kDisparity, "disparity"}};
const EnumNames<CameraDepthModel> kDepthModelNames = {
    {CameraDepthModel::kNone, "none"},
    {CameraDepthModel::kOffset, "offset"},
    {CameraDepthModel::kScaleOffset, "scale_offset"}};
const EnumNames<SurfaceFaces> kSurfaceFacesNames = {{SurfaceFaces::kRays, "rays"},
                                                    {SurfaceFaces::kImage, "image"}};
const EnumNames<RobustLoss> kLossNames = {{RobustLoss::kHuber, "huber"},
                                          {RobustLoss::kCauchy, "cauchy"},
                                          {RobustLoss::kTukey, "tukey"},
                                          {RobustLoss::kNone, "none"}};

const EnumNames<RefineMode>& NamesOf(const RefineMode*) { return kModeNames; }
const EnumNames<RegistrationMethod>& NamesOf(const RegistrationMethod*) { return kMethodNames; }
const EnumNames<RobustLoss>& NamesOf(const RobustLoss*) { return kLossNames; }
const EnumNames<DepthNoiseModel>& NamesOf(const DepthNoiseModel*) { return kNoiseModelNames; }
const EnumNames<CameraDepthModel>& NamesOf(const CameraDepthModel*) { return kDepthModelNames; }
const EnumNames<SurfaceFaces>& NamesOf(const SurfaceFaces*) { return kSurfaceFacesNames; }

using FieldRef =
    std::variant<bool*, int*, double*, std::uint64_t*, std::string*, std::vector<double>*,
                 std::vector<int>*, RefineMode*, RegistrationMethod*, RobustLoss*, DepthNoiseModel*,
                 CameraDepthModel*, SurfaceFaces*>;

struct Field {
  std::string name;
  FieldRef ref;
  std::string help;
};

struct Section {
  std::string name;
  std::string help;
  std::vector<Field> fields;
};

std::vector<Section> Schema(RefineOptions& o) {
  GroundOptions& g = o.ground;
  RegionOptions& r = o.region;
  IcpOptions& i = o.icp;
  return {
      {"ground",
       "Ground leveling: RANSAC floor per camera, pose corrected so the floor is y = 0, +Y up.",
       {
           {"enabled", &g.enabled, "Run ground leveling (true/false)."},
           {"max_normal_angle_deg", &g.max_normal_angle_deg,
            "Only planes whose normal is within this angle of world +Y count (0, 90]."},
           {"ransac_distance_m", &g.ransac_distance_m,
            "RANSAC inlier distance to the plane (> 0)."},
           {"ransac_iterations", &g.ransac_iterations, "RANSAC iterations (>= 1)."},
           {"search_height_m", &g.search_height_m,
            "The floor is searched among points at most this far above the lowest ones (> 0)."},
           {"min_inliers", &g.min_inliers, "A floor needs at least this many inliers (>= 3)."},
           {"max_rotation_deg", &g.max_rotation_deg,
            "Larger corrections are rejected for that camera (0, 180]."},
           {"max_translation_m", &g.max_translation_m,
            "Larger corrections are rejected for that camera (> 0)."},
           {"seed", &g.seed, "RANSAC random seed (unsigned integer)."},
       }},
      {"region",
       "Which points take part in registration.",
       {
           {"band_below", &r.band_below, "Near-floor band: metres below the floor (>= 0)."},
           {"band_height", &r.band_height,
            "Near-floor band: metres above the floor; 0 = whole cloud (>= 0)."},
           {"pixel_stride", &r.pixel_stride, "Use every n-th depth pixel in u and v (>= 1)."},
           {"min_depth_m", &r.min_depth_m, "Closer depth samples are dropped (> 0)."},
           {"max_depth_m", &r.max_depth_m, "Farther depth samples are dropped (> min_depth_m)."},
           {"edge_margin_px", &r.edge_margin_px,
            "Depth pixels within this many pixels of a depth jump or a hole's rim are dropped; "
            "0 keeps them (>= 0)."},
           {"stereo_edge_margin_px", &r.stereo_edge_margin_px,
            "The same for stereo cameras (a baseline_m in the capture) when larger: block "
            "matching fattens the near side of depth jumps (>= 0)."},
           {"stereo_edge_min_width_px", &r.stereo_edge_min_width_px,
            "stereo_edge_margin_px applies to stereo images at least this wide (>= 0)."},
           {"edge_jump", &r.edge_jump,
            "A depth jump: a neighbour farther by more than this times the depth (> 0)."},
       }},
      {"icp",
       "Registration refinement.",
       {
           {"mode", &i.mode, "joint (one problem) or pairwise (pairwise ICP + pose graph)."},
           {"method", &i.method, "Registration residual: point_to_plane or gicp."},
           {"surface_bundle", &i.surface_bundle,
            "After the registration, the surface bundle: every camera and the planes they see in "
            "one problem (true/false)."},
           {"voxel_size", &i.voxel_size, "Finest voxel size in metres (> 0)."},
           {"scales", &i.scales,
            "Voxel size multipliers, coarse to fine (positive, strictly decreasing)."},
           {"max_iterations", &i.max_iterations, "Iteration cap per scale (one per scale, >= 1)."},
           {"max_correspondence_distance_factor", &i.max_correspondence_distance_factor,
            "Correspondences farther than factor x voxel size are dropped (> 0)."},
           {"max_normal_angle_deg", &i.max_normal_angle_deg,
            "Correspondences whose two normals differ by more, plus their expected error under the "
            "depth noise (up to 60), are dropped (0, 180]."},
           {"normal_neighbors", &i.normal_neighbors,
            "Neighbours for normals and covariances (>= 3)."},
           {"depth_noise", &i.depth_noise,
            "Depth noise k of sigma_z = k z^2 in 1/m; 0 = measured per camera on its floor "
            "(>= 0)."},
           {"min_noise_m", &i.min_noise_m,
            "Noise floor of every correspondence residual in metres (> 0)."},
           {"plane_noise_share", &i.plane_noise_share,
            "Share of each point's depth noise k z^2 counted whatever the surface's "
            "orientation: local-plane error of noisy neighbourhoods (>= 0)."},
           {"gravity_weight", &i.gravity_weight,
            "Pitch/roll gravity prior weight, 1 / sigma_tilt in 1/rad; 0 disables it (>= 0)."},
           {"degeneracy_threshold", &i.degeneracy_threshold,
            "Joint: pose directions with less than this fraction of the information of the "
            "best-constrained one are reported; 0 = off [0, 1)."},
           {"hold_weak_directions", &i.hold_weak_directions,
            "Joint: hold weakly constrained directions at the leveled pose (true/false)."},
           {"depth_noise_model", &i.depth_noise_model,
            "Surface bundle: depth noise Gaussian in depth (gaussian_depth) or in disparity "
            "(disparity)."},
           {"surface_rounds", &i.surface_rounds,
            "Surface bundle: rounds of plane segmentation and solve (>= 1)."},
           {"surface_faces", &i.surface_faces,
            "Surface bundle: the last round's faces other than the floor: the segmentation's "
            "planes, pixels by their rays (rays), or faces found in each depth image (image)."},
           {"depth_model", &i.depth_model,
            "Surface bundle: per-camera depth model estimated with the poses: none, offset "
            "(inverse depth) or scale_offset."},
           {"depth_scale_sigma", &i.depth_scale_sigma,
            "Surface bundle: prior 1-sigma of a camera's depth scale about 1 (> 0)."},
           {"depth_offset_sigma_px", &i.depth_offset_sigma_px,
            "Surface bundle: prior 1-sigma of a camera's depth offset about 0, in pixels of "
            "disparity (> 0)."},
           {"surface_bias_px", &i.surface_bias_px,
            "Stereo cameras (baseline_m in the capture): 1-sigma of each surface's disparity "
            "offset, pixels, in the reported 1-sigma (>= 0; 0: none)."},
           {"robust_loss", &i.robust_loss, "huber, cauchy, tukey or none."},
           {"robust_loss_scale", &i.robust_loss_scale,
            "Robust loss scale on whitened residuals, in standard deviations (> 0)."},
           {"min_fitness", &i.min_fitness,
            "Pairwise: overlap a pair needs (fraction of its points near the other camera's) "
            "[0, 1]."},
           {"overlap_margin", &i.overlap_margin,
            "Candidate pairs: metres added around each camera's world XZ box (>= 0)."},
           {"min_overlap_area", &i.min_overlap_area,
            "Candidate pairs: square metres the inflated boxes must share (>= 0)."},
           {"reference", &i.reference, "Camera held fixed (gauge); \"\" = the first serial."},
           {"max_rotation_deg", &i.max_rotation_deg,
            "A camera changing more against the rig keeps its leveled pose (0, 180]."},
           {"max_translation_m", &i.max_translation_m,
            "A camera moving more against the rig keeps its leveled pose (> 0)."},
       }},
  };
}

// ---------------------------------------------------------------------------------------------
// Near-miss suggestions.

size_t Levenshtein(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t substitution = diagonal + (a[i - 1] == b[j - 1] ? 0 : 1);
      diagonal = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, substitution});
    }
  }
  return row[b.size()];
}

/// A key counts as a near miss within 2 edits, fewer for short keys ("mode" is not "seed").
bool IsNearMiss(const std::string& typed, const std::string& candidate) {
  const size_t limit = std::clamp<size_t>(typed.size() / 3, 1, 2);
  return Levenshtein(typed, candidate) <= limit;
}

std::string DidYouMean(const std::vector<std::string>& candidates) {
  if (candidates.empty()) return "";
  std::string text = " (did you mean ";
  for (size_t k = 0; k < candidates.size(); ++k) {
    if (k > 0) text += " or ";
    text += "'" + candidates[k] + "'";
  }
  return text + "?)";
}

/// Suggestions for an unknown key inside `own` (nullptr: at the top level): the same key in
/// another section first, then near misses in the own section, then near misses elsewhere.
std::string SuggestKey(const std::string& typed, const Section* own,
                       const std::vector<Section>& schema) {
  std::vector<std::string> exact_elsewhere, near_own, near_elsewhere;
  for (const Section& section : schema) {
    if (own == nullptr && IsNearMiss(typed, section.name)) near_own.push_back(section.name);
    for (const Field& field : section.fields) {
      const bool is_own = &section == own;
      const std::string qualified = section.name + "." + field.name;
      if (!is_own && field.name == typed) {
        exact_elsewhere.push_back(qualified);
      } else if (IsNearMiss(typed, field.name)) {
        (is_own ? near_own : near_elsewhere).push_back(is_own ? field.name : qualified);
      }
    }
  }
  if (!exact_elsewhere.empty()) return DidYouMean(exact_elsewhere);
  if (!near_own.empty()) return DidYouMean(near_own);
  return DidYouMean(near_elsewhere);
}

// ---------------------------------------------------------------------------------------------
// Scalar parsing: strict, never yaml-cpp's as<T>(fallback).

std::string StripPlus(const std::string& text) {
  return !text.empty() && text[0] == '+' ? text.substr(1) : text;
}

template <typename T>
bool ParseWhole(const std::string& text, T& value) {
  const std::string t = StripPlus(text);
  if (t.empty()) return false;
  const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), value);
  return ec == std::errc() && end == t.data() + t.size();
}

/// YAML 1.2's spellings of infinity and NaN (.inf, -.Inf, .NAN, ...).
bool IsYamlNonFinite(const std::string& text) {
  std::string t = !text.empty() && (text[0] == '-' || text[0] == '+') ? text.substr(1) : text;
  for (const char* special : {".inf", ".Inf", ".INF", ".nan", ".NaN", ".NAN"}) {
    if (t == special) return true;
  }
  return false;
}

/// Collects every error of a config, each "<source>:<line>: <key>: <what>".
class ConfigParser {
 public:
  explicit ConfigParser(std::string source) : source_(std::move(source)) {}

  void ParseRoot(const YAML::Node& root, std::vector<Section>& schema) {
    if (root.IsNull()) return;
    if (!root.IsMap()) {
      Error(root.Mark(), "config", "expected a map with the sections ground:, region:, icp:");
      return;
    }
    std::set<std::string> seen;
    for (const auto& entry : root) {
      const std::string name = KeyName(entry.first, "");
      if (name.empty()) continue;
      if (!seen.insert(name).second) {
        Error(entry.first.Mark(), name, "duplicate key");
        continue;
      }
      const auto section = std::find_if(schema.begin(), schema.end(),
                                        [&](const Section& s) { return s.name == name; });
      if (section == schema.end()) {
        Error(entry.first.Mark(), name, "unknown key" + SuggestKey(name, nullptr, schema));
        continue;
      }
      key_lines_[name] = entry.first.Mark().line + 1;
      ParseSection(entry.first.Mark(), entry.second, *section, schema);
    }
  }

  /// Prefixes each OptionProblems() line with the line of the key it names.
  void AddProblems(const std::vector<std::string>& problems) {
    for (const std::string& problem : problems) {
      int line = 0;
      size_t first = std::string::npos;
      for (const auto& [key, key_line] : key_lines_) {
        const size_t pos = FindKey(problem, key);
        if (pos < first || (pos == first && pos != std::string::npos)) {
          first = pos;
          line = key_line;
        }
      }
      errors_.push_back(source_ + (line > 0 ? ":" + std::to_string(line) : "") + ": " + problem);
    }
  }

  void AddSyntaxError(const YAML::ParserException& e) {
    errors_.push_back(source_ + ":" + std::to_string(e.mark.line + 1) + ": YAML syntax error: " +
                      e.msg + " (column " + std::to_string(e.mark.column + 1) + ")");
  }

  void ThrowIfErrors() const {
    if (errors_.empty()) return;
    std::string message;
    for (const std::string& e : errors_) message += (message.empty() ? "" : "\n") + e;
    throw InputError(message);
  }

 private:
  /// Position of key in text as a whole key ("icp.scales" matches "icp.scales[1]", not
  /// "icp.scales_x"), npos if absent.
  static size_t FindKey(const std::string& text, const std::string& key) {
    for (size_t pos = text.find(key); pos != std::string::npos; pos = text.find(key, pos + 1)) {
      const size_t end = pos + key.size();
      const bool whole =
          end == text.size() || !(std::isalnum(static_cast<unsigned char>(text[end])) ||
                                  text[end] == '_' || text[end] == '.');
      if (whole) return pos;
    }
    return std::string::npos;
  }

  std::string KeyName(const YAML::Node& key, const std::string& prefix) {
    if (!key.IsScalar() || key.Scalar().empty()) {
      Error(key.Mark(), prefix.empty() ? "config" : prefix, "keys must be non-empty names");
      return "";
    }
    return key.Scalar();
  }

  void ParseSection(const YAML::Mark& section_mark, const YAML::Node& node, Section& section,
                    const std::vector<Section>& schema) {
    if (node.IsNull()) return;  // "icp:" with nothing below: no overrides
    if (!node.IsMap()) {
      Error(section_mark, section.name, "expected a map of keys, got " + Describe(node));
      return;
    }
    std::set<std::string> seen;
    for (const auto& entry : node) {
      const std::string name = KeyName(entry.first, section.name);
      if (name.empty()) continue;
      const std::string key = section.name + "." + name;
      const YAML::Mark mark = entry.first.Mark();
      if (!seen.insert(name).second) {
        Error(mark, key, "duplicate key");
        continue;
      }
      const auto field = std::find_if(section.fields.begin(), section.fields.end(),
                                      [&](const Field& f) { return f.name == name; });
      if (field == section.fields.end()) {
        Error(mark, key, "unknown key" + SuggestKey(name, &section, schema));
        continue;
      }
      key_lines_[key] = mark.line + 1;
      std::visit([&](auto* target) { Parse(mark, key, entry.second, target); }, field->ref);
    }
  }

  static std::string Describe(const YAML::Node& node) {
    if (node.IsSequence()) return "a list";
    if (node.IsMap()) return "a map";
    if (node.IsNull()) return "nothing";
    return (node.Tag() == "!" ? "the string \"" : "'") + node.Scalar() +
           (node.Tag() == "!" ? "\"" : "'");
  }

  void Error(const YAML::Mark& mark, const std::string& key, const std::string& what) {
    const std::string line = mark.is_null() ? "" : ":" + std::to_string(mark.line + 1);
    errors_.push_back(source_ + line + ": " + key + ": " + what);
  }

  /// A plain (unquoted) scalar, as numbers and booleans must be; reports and returns false else.
  bool PlainScalar(const YAML::Mark& mark, const std::string& key, const YAML::Node& node,
                   const std::string& expected) {
    if (node.IsScalar() && node.Tag() == "?") return true;
    Error(mark, key, "expected " + expected + ", got " + Describe(node));
    return false;
  }

  void Parse(const YAML::Mark& mark, const std::string& key, const YAML::Node& node, bool* out) {
    if (!PlainScalar(mark, key, node, "true or false")) return;
    const std::string& s = node.Scalar();
    if (s == "true" || s == "True" || s == "TRUE") {
      *out = true;
    } else if (s == "false" || s == "False" || s == "FALSE") {
      *out = false;
    } else {
      Error(mark, key, "expected true or false, got " + Describe(node));
    }
  }

  void Parse(const YAML::Mark& mark, const std::string& key, const YAML::Node& node, double* out) {
    if (!PlainScalar(mark, key, node, "a number")) return;
    double value = 0.0;
    if (IsYamlNonFinite(node.Scalar())) {
      Error(mark, key, "expected a finite number, got " + Describe(node));
    } else if (!ParseWhole(node.Scalar(), value)) {
      Error(mark, key, "expected a number, got " + Describe(node));
    } else if (!std::isfinite(value)) {
      Error(mark, key, "expected a finite number, got " + Describe(node));
    } else {
      *out = value;
    }
  }

  void Parse(const YAML::Mark& mark, const std::string& key, const YAML::Node& node, int* out) {
    if (!PlainScalar(mark, key, node, "an integer")) return;
    long long value = 0;
    if (!ParseWhole(node.Scalar(), value)) {
      Error(mark, key, "expected an integer, got " + Describe(node));
    } else if (value < std::numeric_limits<int>::min() || value > std::numeric_limits<int>::max()) {
      Error(mark, key, "integer out of range, got " + Describe(node));
    } else {
      *out = static_cast<int>(value);
    }
  }

  void Parse(const YAML::Mark& mark, const std::string& key, const YAML::Node& node,
             std::uint64_t* out) {
    if (!PlainScalar(mark, key, node, "a non-negative integer")) return;
    unsigned long long value = 0;
    if (node.Scalar().rfind('-', 0) == 0 || !ParseWhole(node.Scalar(), value)) {
      Error(mark, key, "expected a non-negative integer, got " + Describe(node));
    } else {
      *out = value;
    }
  }

  void Parse(const YAML::Mark& mark, const std::string& key, const YAML::Node& node,
             std::string* out) {
    if (node.IsNull()) {
      out->clear();
    } else if (!node.IsScalar()) {
      Error(mark, key, "expected a string, got " + Describe(node));
    } else {
      *out = node.Scalar();
    }
  }

  template <typename T>
  void Parse(const YAML::Mark& mark, const std::string& key, const YAML::Node& node,
             std::vector<T>* out) {
    const std::string item = std::is_same_v<T, int> ? "integers" : "numbers";
    if (!node.IsSequence()) {
      Error(mark, key, "expected a list of " + item + " like [4, 2, 1], got " + Describe(node));
      return;
    }
    std::vector<T> values(node.size());
    const size_t errors_before = errors_.size();
    for (size_t k = 0; k < node.size(); ++k) {
      const YAML::Node element = node[k];
      Parse(element.Mark().is_null() ? mark : element.Mark(), key + "[" + std::to_string(k) + "]",
            element, &values[k]);
    }
    if (errors_.size() == errors_before) *out = std::move(values);
  }

  template <typename E>
  void Parse(const YAML::Mark& mark, const std::string& key, const YAML::Node& node, E* out) {
    const EnumNames<E>& names = NamesOf(out);
    std::string valid, near;
    for (const auto& [value, name] : names) valid += (valid.empty() ? "" : ", ") + name;
    if (!node.IsScalar()) {
      Error(mark, key, "expected one of " + valid + ", got " + Describe(node));
      return;
    }
    for (const auto& [value, name] : names) {
      if (node.Scalar() == name) {
        *out = value;
        return;
      }
      if (near.empty() && IsNearMiss(node.Scalar(), name)) near = " (did you mean '" + name + "'?)";
    }
    if (std::is_same_v<E, RegistrationMethod> && node.Scalar() == "surface_bundle") {
      near = " (" + std::string(kSurfaceBundleMoved) + ")";
    }
    Error(mark, key, "unknown value '" + node.Scalar() + "'; valid: " + valid + near);
  }

  std::string source_;
  std::vector<std::string> errors_;
  std::map<std::string, int> key_lines_;  ///< "icp.voxel_size" -> 1-based line where it is set
};

// ---------------------------------------------------------------------------------------------
// Writing.

/// The shortest decimal text that reads back as exactly x, always with a '.' or an exponent
/// so that it reads as a float.
std::string FormatDouble(double x) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), x);
  std::string text(buffer, result.ptr);
  if (text.find_first_of(".eEn") == std::string::npos) text += ".0";
  return text;
}

std::string QuoteYaml(const std::string& s) {
  std::string out = "\"";
  for (const char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char escaped[8];
      std::snprintf(escaped, sizeof(escaped), "\\x%02x", static_cast<unsigned char>(c));
      out += escaped;
    } else {
      out += c;
    }
  }
  return out + "\"";
}

std::string YamlValue(const bool* v) { return *v ? "true" : "false"; }
std::string YamlValue(const int* v) { return std::to_string(*v); }
std::string YamlValue(const std::uint64_t* v) { return std::to_string(*v); }
std::string YamlValue(const double* v) { return FormatDouble(*v); }
std::string YamlValue(const std::string* v) { return QuoteYaml(*v); }
template <typename T>
std::string YamlValue(const std::vector<T>* v) {
  std::string text = "[";
  for (size_t k = 0; k < v->size(); ++k) text += (k ? ", " : "") + YamlValue(&(*v)[k]);
  return text + "]";
}
template <typename E>
std::string YamlValue(const E* v) {
  for (const auto& [value, name] : NamesOf(v)) {
    if (value == *v) return name;
  }
  return std::to_string(static_cast<int>(*v));  // out-of-range enum: OptionProblems names it
}

template <typename T>
nlohmann::json JsonValue(const T* v) {
  if constexpr (std::is_enum_v<T>) {
    return YamlValue(v);
  } else {
    return *v;
  }
}

}  // namespace

RefineOptions ParseConfig(const std::string& yaml_text, const std::string& source_name) {
  ConfigParser parser(source_name);
  RefineOptions options;
  std::vector<Section> schema = Schema(options);
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::ParserException& e) {
    parser.AddSyntaxError(e);
    parser.ThrowIfErrors();
  }
  parser.ParseRoot(root, schema);
  parser.ThrowIfErrors();
  parser.AddProblems(OptionProblems(options));
  parser.ThrowIfErrors();
  return options;
}

RefineOptions LoadConfig(const std::string& path) { return ParseConfig(ReadWholeFile(path), path); }

std::string ConfigToYaml(const RefineOptions& options) {
  RefineOptions copy = options;
  std::ostringstream out;
  bool first = true;
  for (const Section& section : Schema(copy)) {
    if (!first) out << "\n";
    first = false;
    out << "# " << section.help << "\n" << section.name << ":\n";
    for (const Field& field : section.fields) {
      out << "  # " << field.help << "\n  " << field.name << ": "
          << std::visit([](const auto* v) { return YamlValue(v); }, field.ref) << "\n";
    }
  }
  return out.str();
}

nlohmann::json ConfigToJson(const RefineOptions& options) {
  RefineOptions copy = options;
  nlohmann::json json = nlohmann::json::object();
  for (const Section& section : Schema(copy)) {
    nlohmann::json& values = json[section.name] = nlohmann::json::object();
    for (const Field& field : section.fields) {
      values[field.name] = std::visit([](const auto* v) { return JsonValue(v); }, field.ref);
    }
  }
  return json;
}

std::vector<std::string> RegistrationMethodNames() {
  std::vector<std::string> names;
  for (const auto& [method, name] : kMethodNames) names.push_back(name);
  return names;
}

RegistrationMethod RegistrationMethodNamed(const std::string& name) {
  for (const auto& [method, method_name] : kMethodNames) {
    if (method_name == name) return method;
  }
  throw InputError("unknown method '" + name + "' (valid: " + Join(RegistrationMethodNames()) +
                   ")" + (name == "surface_bundle" ? std::string("; ") + kSurfaceBundleMoved : ""));
}

std::string RegistrationMethodName(RegistrationMethod method) { return YamlValue(&method); }

}  // namespace rigfit

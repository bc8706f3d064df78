#include "report/view3d.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <nlohmann/json.hpp>

#include "core/errors.h"
#include "io/atomic_file.h"
#include "report/html.h"
#include "report/view3d_page_js.h"

namespace rigfit {
namespace {

namespace fs = std::filesystem;

/// Positions are int16 steps around a centre: at most this long (metres)...
constexpr double kMaxStepM = 1e-3;
/// ... or longer when the cloud spans more than this many of them.
constexpr double kMaxSteps = 32000.0;
/// A residual byte: 0-254 over [0, residual_range_m], this one for "none".
constexpr int kNoResidual = 255;

std::string Base64(const void* data, size_t size) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  const auto* bytes = static_cast<const std::uint8_t*>(data);
  std::string out;
  out.reserve((size + 2) / 3 * 4);
  for (size_t i = 0; i < size; i += 3) {
    const std::uint32_t b0 = bytes[i];
    const std::uint32_t b1 = i + 1 < size ? bytes[i + 1] : 0;
    const std::uint32_t b2 = i + 2 < size ? bytes[i + 2] : 0;
    const std::uint32_t triple = (b0 << 16) | (b1 << 8) | b2;
    out += kAlphabet[(triple >> 18) & 63];
    out += kAlphabet[(triple >> 12) & 63];
    out += i + 1 < size ? kAlphabet[(triple >> 6) & 63] : '=';
    out += i + 2 < size ? kAlphabet[triple & 63] : '=';
  }
  return out;
}

template <typename T>
std::string Base64(const std::vector<T>& values) {
  return Base64(values.data(), values.size() * sizeof(T));
}

nlohmann::json ColorJson(const Rgb& c) { return {c.r, c.g, c.b}; }

nlohmann::json VecJson(const Vec3& v) { return {v.x(), v.y(), v.z()}; }

/// The cloud's finite points as int16 steps around the centre of their bounding box, with
/// the centre and the step; `kept` gets the indices of the points written.
nlohmann::json QuantisedPositions(const std::vector<Vec3f>& points, std::vector<size_t>* kept) {
  Eigen::Array3d low = Eigen::Array3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Array3d high = -low;
  for (size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite()) continue;
    kept->push_back(i);
    low = low.min(points[i].cast<double>().array());
    high = high.max(points[i].cast<double>().array());
  }
  if (kept->empty()) low = high = Eigen::Array3d::Zero();
  const Eigen::Array3d centre = 0.5 * (low + high);
  const double step = std::max(kMaxStepM, 0.5 * (high - low).maxCoeff() / kMaxSteps);
  std::vector<std::int16_t> steps;
  steps.reserve(3 * kept->size());
  for (size_t i : *kept) {
    const Eigen::Array3d q = ((points[i].cast<double>().array() - centre) / step).round();
    for (int k = 0; k < 3; ++k) steps.push_back(static_cast<std::int16_t>(q[k]));
  }
  return {{"count", kept->size()},
          {"origin", VecJson(centre.matrix())},
          {"step", step},
          {"positions", Base64(steps)}};
}

nlohmann::json CloudJson(const ViewCloud& cloud, double residual_range_m) {
  std::vector<size_t> kept;
  nlohmann::json json = QuantisedPositions(cloud.points, &kept);
  json["layer"] = cloud.layer;
  json["camera"] = cloud.camera;
  json["rgb"] = nullptr;
  if (!cloud.rgb.empty()) {
    std::vector<std::uint8_t> rgb;
    rgb.reserve(3 * kept.size());
    for (size_t i : kept) rgb.insert(rgb.end(), &cloud.rgb[3 * i], &cloud.rgb[3 * i] + 3);
    json["rgb"] = Base64(rgb);
  }
  json["residuals"] = nlohmann::json::array();
  for (const std::vector<float>& residuals : cloud.residuals_m) {
    std::vector<std::uint8_t> bytes;
    bytes.reserve(kept.size());
    for (size_t i : kept) {
      const double r = std::abs(residuals[i]) / residual_range_m;
      bytes.push_back(std::isfinite(r) ? static_cast<std::uint8_t>(
                                             std::lround(std::min(r, 1.0) * (kNoResidual - 1)))
                                       : kNoResidual);
    }
    json["residuals"].push_back(Base64(bytes));
  }
  return json;
}

nlohmann::json SceneJson(const View3dScene& scene) {
  nlohmann::json json = {
      {"title", scene.title},
      {"up", VecJson(scene.up.normalized())},
      {"floor_m", scene.floor_m},
      {"residual_range_m", scene.residual_range_m},
      {"has_rgb", std::any_of(scene.clouds.begin(), scene.clouds.end(),
                              [](const ViewCloud& c) { return !c.rgb.empty(); })},
      {"cameras", nlohmann::json::array()},
      {"pose_sets", nlohmann::json::array()},
      {"clouds", nlohmann::json::array()},
      {"paths", nlohmann::json::array()},
      {"planes", nlohmann::json::array()}};
  for (const ViewCamera& c : scene.cameras) {
    const PinholeIntrinsics& K = c.intrinsics;
    json["cameras"].push_back({{"serial", c.serial},
                               {"color", ColorJson(c.color)},
                               {"K", {K.fx, K.fy, K.cx, K.cy}},
                               {"width", c.width},
                               {"height", c.height}});
  }
  for (const ViewPoseSet& set : scene.pose_sets) {
    nlohmann::json poses = nlohmann::json::array();
    for (const Pose& T : set.T_world_camera) {
      const Eigen::Matrix4d M = T.matrix();
      poses.push_back(std::vector<double>(M.data(), M.data() + 16));  // column-major
    }
    json["pose_sets"].push_back({{"name", set.name}, {"poses", poses}});
  }
  for (const ViewCloud& cloud : scene.clouds) {
    if (cloud.layer == kWholeLayer) {
      json["deferred"][kWholeLayer] = kView3dWholeFile;
    } else {
      json["clouds"].push_back(CloudJson(cloud, scene.residual_range_m));
    }
  }
  for (const ViewPath& path : scene.paths) {
    std::vector<float> xyz;
    for (const Vec3& p : path.positions)
      xyz.insert(xyz.end(), {float(p.x()), float(p.y()), float(p.z())});
    json["paths"].push_back(
        {{"label", path.label}, {"color", ColorJson(path.color)}, {"positions", Base64(xyz)}});
  }
  for (const ViewPlane& plane : scene.planes) {
    std::vector<float> xyz;
    for (const Vec3& p : plane.corners)
      xyz.insert(xyz.end(), {float(p.x()), float(p.y()), float(p.z())});
    json["planes"].push_back(
        {{"color", ColorJson(plane.color)}, {"floor", plane.floor}, {"corners", Base64(xyz)}});
  }
  return json;
}

std::string ReadBinary(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw InputError("report: three.js is missing: cannot read " + path.string() +
                     " (install Debian's libjs-three, scripts/setup.sh)");
  }
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

}  // namespace

const char* ThreeJsDirectory() { return RIGFIT_THREE_JS_DIR; }

std::string View3dHtml(const std::string& title) {
  // Every error and console error or warning, of three.js too, lands in the body's
  // data-errors, which a test reads with --dump-dom.
  const char* error_catcher =
      "<script>\n(function () {\n"
      "  const errors = [];\n"
      "  const note = m => { errors.push(String(m)); if (document.body) "
      "document.body.setAttribute('data-errors', errors.join(' | ')); };\n"
      "  window.addEventListener('error', e => note(e.message));\n"
      "  for (const level of ['error', 'warn']) {\n"
      "    const original = console[level];\n"
      "    console[level] = function () { note(Array.from(arguments).join(' ')); "
      "original.apply(console, arguments); };\n"
      "  }\n"
      "})();\n</script>\n";
  return "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>" +
         HtmlEscape(title) + " - 3-D view</title>\n" + error_catcher +
         "</head>\n<body>\n<script src=\"" + std::string(kThreeJsFile) +
         "\"></script>\n<script src=\"" + kOrbitControlsFile + "\"></script>\n<script src=\"" +
         kView3dDataFile + "\"></script>\n<script>\n" + kView3dPageJs +
         "</script>\n</body>\n</html>\n";
}

std::string View3dDataScript(const View3dScene& scene) {
  return "var RIGFIT_VIEW = " + SceneJson(scene).dump() + ";\n";
}

std::string View3dWholeScript(const View3dScene& scene) {
  nlohmann::json clouds = nlohmann::json::array();
  for (const ViewCloud& cloud : scene.clouds) {
    if (cloud.layer == kWholeLayer) clouds.push_back(CloudJson(cloud, scene.residual_range_m));
  }
  return "var RIGFIT_VIEW_WHOLE = " + clouds.dump() + ";\n";
}

std::vector<std::string> WriteView3d(const std::string& dir, const View3dScene& scene) {
  const fs::path three(ThreeJsDirectory());
  const std::vector<std::pair<fs::path, const char*>> copies = {
      {three / "three.min.js", kThreeJsFile},
      {three / "examples" / "js" / "controls" / "OrbitControls.js", kOrbitControlsFile}};
  std::vector<std::string> files;
  for (const auto& [source, name] : copies) {
    files.push_back((fs::path(dir) / name).string());
    WriteTextFileAtomically(files.back(), ReadBinary(source));
  }
  files.push_back((fs::path(dir) / kView3dDataFile).string());
  WriteTextFileAtomically(files.back(), View3dDataScript(scene));
  const auto whole = [](const ViewCloud& c) { return c.layer == kWholeLayer; };
  if (std::any_of(scene.clouds.begin(), scene.clouds.end(), whole)) {
    files.push_back((fs::path(dir) / kView3dWholeFile).string());
    WriteTextFileAtomically(files.back(), View3dWholeScript(scene));
  }
  files.push_back((fs::path(dir) / kView3dFile).string());
  WriteTextFileAtomically(files.back(), View3dHtml(scene.title));
  return files;
}

}  // namespace rigfit

#include "report/refine_meta.h"

#include <cmath>
#include <string>
#include <utility>

#include "core/evaluate.h"
#include "io/config_yaml.h"
#include "io/extrinsics_json.h"

namespace rigfit {
namespace {

using Json = nlohmann::json;

Json PlaneJson(const PlanarFace& plane) {
  return {plane.normal.x(), plane.normal.y(), plane.normal.z(), plane.offset};
}

Json GroundMeta(const RefineResult& result, const RefineOptions& options,
                const RefineMetaFlags& flags) {
  if (!options.ground.enabled) {
    return {{"skipped", true},
            {"message", flags.no_ground ? "ground leveling skipped (--no-ground)"
                                        : "ground leveling skipped (ground.enabled: false)"}};
  }
  Json cameras = Json::object();
  for (const CameraReport& camera : result.cameras) {
    const GroundResult& g = camera.ground;
    cameras[camera.serial] = {
        {"found", g.found},
        {"accepted", g.accepted},
        {"message", g.message},
        {"points", camera.points},
        {"plane_camera", g.found ? PlaneJson(g.plane_camera) : Json()},
        {"inliers", g.inliers},
        {"inlier_rms_m", g.inlier_rms_m},
        {"depth_noise", g.depth_noise},
        {"correction",
         {{"T_leveled_input", PoseToJson(g.correction)},
          {"rotation_deg", g.correction_rotation_deg},
          {"translation_m", g.correction_translation_m}}},
    };
  }
  return {{"skipped", false}, {"cameras", cameras}};
}

/// The config names of the mode and method that ran (io/config_yaml.h holds the names).
std::pair<Json, Json> ModeAndMethodNames(const RefineResult& result) {
  if (!result.icp_ran) return {nullptr, nullptr};
  RefineOptions ran;
  ran.icp.mode = result.mode;
  ran.icp.method = result.method;
  const Json icp = ConfigToJson(ran)["icp"];
  return {icp["mode"], icp["method"]};
}

Json SigmaJson(const PoseSigma& s) {
  return {{"yaw_deg", s.yaw_deg},
          {"tilt_deg", s.tilt_deg},
          {"x_mm", s.x_mm},
          {"y_mm", s.y_mm},
          {"z_mm", s.z_mm}};
}

/// `value`, or null when it was not measured.
Json NumberOrNull(bool measured, double value) { return measured ? Json(value) : Json(); }

/// A camera's surface-bundle depth model, as estimated and as judged observable.
Json DepthModelMeta(const DepthModelEstimate& d) {
  Json meta = Json::object();
  ForEachDepthModelField(d, [&](const char* name, auto value) { meta[name] = value; });
  return meta;
}

Json IcpMeta(const RefineResult& result, const RefineOptions& options,
             const std::vector<std::string>& warnings, const RefineMetaFlags& flags) {
  const auto [mode, method] = ModeAndMethodNames(result);
  Json meta = {{"skipped", flags.no_icp},
               {"mode", mode},
               {"method", method},
               {"config", ConfigToJson(options)},
               {"reference", result.reference},
               {"warnings", warnings},
               {"success", result.success},
               {"message", flags.no_icp ? "registration skipped (--no-icp)" : result.message}};
  if (flags.no_icp) return meta;
  Json pairs = Json::array();
  for (const PairReport& p : result.pairs) {
    pairs.push_back({{"serial_a", p.serial_a},
                     {"serial_b", p.serial_b},
                     {"overlap_area_m2", p.overlap_area_m2},
                     {"fitness", p.fitness},
                     {"rmse_before_m", p.rmse_before_m},
                     {"rmse_after_m", p.rmse_after_m},
                     {"correspondences", p.correspondences},
                     {"iterations", p.iterations},
                     {"accepted", p.accepted},
                     {"message", p.message}});
  }
  Json cameras = Json::object();
  for (const CameraReport& c : result.cameras) {
    const bool measured = ChangeMeasured(result, c);
    cameras[c.serial] = {{"reference", c.reference},
                         {"band_points", c.band_points},
                         {"connected", c.connected},
                         {"accepted", c.accepted},
                         {"delta_rotation_deg", NumberOrNull(measured, c.delta_rotation_deg)},
                         {"delta_translation_m", NumberOrNull(measured, c.delta_translation_m)},
                         {"own_rotation_deg", NumberOrNull(measured, c.own_rotation_deg)},
                         {"own_translation_m", NumberOrNull(measured, c.own_translation_m)},
                         {"message", c.message}};
    if (c.has_covariance) {
      cameras[c.serial]["sigma"] = SigmaJson(SigmaOf(c.covariance));
      cameras[c.serial]["sigma_inflation"] = {{"rotation", c.sigma_inflation.rotation},
                                              {"translation", c.sigma_inflation.translation}};
    }
    if (c.connected && !c.reference && result.mode == RefineMode::kJoint) {
      cameras[c.serial]["surfaces"] = c.surfaces;
      cameras[c.serial]["few_surfaces"] = c.few_surfaces;
    }
    if (!c.weak_directions.empty()) {
      Json weak = Json::array();
      for (const WeakDirection& d : c.weak_directions) {
        weak.push_back(
            {{"direction", d.name}, {"information_fraction", d.strength}, {"reason", d.reason}});
      }
      cameras[c.serial]["weak_directions"] = weak;
    }
  }
  meta["pairs"] = pairs;
  meta["cameras"] = cameras;
  if (result.surface.ran) {
    const SurfaceBundleReport& sb = result.surface;
    Json thickness = Json::object();
    for (const CameraReport& c : result.cameras) {
      thickness[c.serial] = {{"before", c.surface_thickness_before},
                             {"after", c.surface_thickness_after},
                             {"noise_correlation", c.surface_noise_correlation},
                             {"kept_joint_pose", c.surface_fallback},
                             {"surface_leveled", c.surface_leveled}};
      if (c.depth_model.offset_prior_sigma > 0.0) {  // a free depth camera, icp.depth_model on
        thickness[c.serial]["depth_model"] = DepthModelMeta(c.depth_model);
      }
    }
    meta["surface_bundle"] = {{"planes", sb.planes},
                              {"pixels", sb.pixels},
                              {"rounds", sb.rounds},
                              {"noise_scale", sb.noise_scale},
                              {"thickness", thickness}};
  }
  return meta;
}

}  // namespace

bool ChangeMeasured(const RefineResult& result, const CameraReport& c) {
  return result.icp_ran && (c.accepted || !c.message.empty());
}

Json RefineMetaJson(const RefineResult& result, const RefineOptions& options,
                    const std::vector<std::string>& warnings, const RefineMetaFlags& flags) {
  return {{"ground_refined", GroundMeta(result, options, flags)},
          {"icp_refined", IcpMeta(result, options, warnings, flags)}};
}

std::vector<std::string> ReplaceNonFinite(Json& value, const std::string& path) {
  std::vector<std::string> where;
  if (value.is_number_float() && !std::isfinite(value.get<double>())) {
    value = nullptr;
    where.push_back(path);
  } else if (value.is_object()) {
    for (auto& [key, item] : value.items()) {
      for (std::string& w : ReplaceNonFinite(item, path + "." + key)) where.push_back(std::move(w));
    }
  } else if (value.is_array()) {
    for (size_t i = 0; i < value.size(); ++i) {
      for (std::string& w : ReplaceNonFinite(value[i], path + "[" + std::to_string(i) + "]")) {
        where.push_back(std::move(w));
      }
    }
  }
  return where;
}

}  // namespace rigfit

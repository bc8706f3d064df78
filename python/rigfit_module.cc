// rigfit._rigfit: the compiled half of the Python module (docs/python.md). Converts numpy
// arrays and dicts to the library's plain structs (core/types.h, options/refine_options.h;
// python/convert.h), runs the same library calls as `rigfit refine` (cli/refine_command.cc),
// `rigfit compare` (report/compare.h) and `rigfit simulate` and hands back plain Python values;
// rigfit/__init__.py wraps them in dataclasses. Each function's options arrive as one dict of
// keywords, read by the command's KeywordTable (python/keywords.h), the one place the binding
// writes them. The RGB-D part (sequences, tracking, trajectories) is python/rgbd_module.cc.
// InputError becomes ValueError.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "core/errors.h"
#include "core/evaluate.h"
#include "core/types.h"
#include "io/capture_h5.h"
#include "io/config_yaml.h"
#include "io/extrinsics_json.h"
#include "options/refine_options.h"
#include "python/convert.h"
#include "python/keywords.h"
#include "report/compare.h"
#include "report/refine_meta.h"
#include "rig/refine.h"
#include "sim/simulate_rig.h"

namespace rigfit::python {

void AddRgbdFunctions(py::module_& m);  // python/rgbd_module.cc

namespace {

using Json = nlohmann::json;
using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;

/// The depth camera of d ("depth", "K", ["depth_scale", "confidence", "color", "baseline_m"]):
/// the depth read once into camera.depth_m (DepthView), then ReadCapture's rules
/// (CheckDepthCamera, SetBaseline).
void ReadDepth(const py::dict& d, CameraCapture& camera, const std::string& where) {
  const DepthView depth(d, where);
  camera.width = depth.width();
  camera.height = depth.height();
  camera.depth_m = depth.Read();
  if (!d.contains("K")) Fail(where, "a depth camera needs \"K\" (3x3 intrinsics)");
  const DoubleArray K = Matrix(d["K"], 3, 3, where + ": K");
  const auto k = K.unchecked<2>();
  Mat3 K_matrix;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) K_matrix(r, c) = k(r, c);
  }
  // ReadCapture's rules: another unit refused, glitches dropped, the data contract on K.
  CheckDepthCamera(&camera, K_matrix, where);

  if (d.contains("confidence")) {
    const FloatArray c = FloatArray::ensure(d["confidence"]);
    if (!c || c.ndim() != 2 || c.shape(0) != camera.height || c.shape(1) != camera.width) {
      Fail(where + ": confidence", "expected the depth's shape (H, W)");
    }
    camera.confidence.assign(c.data(), c.data() + c.size());
  }
  if (d.contains("color")) {
    camera.color = ColorOf(d["color"], camera.width, camera.height, where + ": color");
  }
  if (d.contains("baseline_m")) SetBaseline(&camera, py::cast<double>(d["baseline_m"]), where);
}

PointCloud Vectors(const py::handle& value, py::ssize_t rows, const std::string& where) {
  const DoubleArray a = Matrix(value, rows, 3, where);
  const auto v = a.unchecked<2>();
  PointCloud out(static_cast<size_t>(a.shape(0)));
  for (py::ssize_t i = 0; i < a.shape(0); ++i) {
    out[i] = Vec3(v(i, 0), v(i, 1), v(i, 2));
    if (!out[i].allFinite()) Fail(where, "row " + std::to_string(i) + " is not finite");
  }
  return out;
}

/// cameras: serial -> {"depth", "K", ["depth_scale", "confidence", "color", "baseline_m"]} or
/// {"points", ["normals"]}; sorted by serial as ReadCapture sorts them.
RigCapture CaptureOf(const py::dict& cameras) {
  static const std::set<std::string> kKeys = {"depth", "K",      "depth_scale", "confidence",
                                              "color", "points", "normals",     "baseline_m"};
  std::map<std::string, py::dict> by_serial;
  for (const auto& [key, value] : cameras) {
    if (!py::isinstance<py::str>(key)) throw InputError("cameras: keys must be serials (str)");
    const std::string serial = py::cast<std::string>(key);
    if (serial.empty()) throw InputError("cameras: empty serial");
    if (!py::isinstance<py::dict>(value)) {
      throw InputError("cameras: camera " + serial + ": expected a dict");
    }
    by_serial[serial] = py::reinterpret_borrow<py::dict>(value);
  }
  if (by_serial.empty()) throw InputError("cameras: no cameras");
  RigCapture capture;
  for (const auto& [serial, d] : by_serial) {
    const std::string where = "cameras: camera " + serial;
    for (const auto& item : d) {
      const std::string key = py::cast<std::string>(py::str(item.first));
      if (kKeys.count(key) == 0) {
        Fail(where,
             "unknown key \"" + key +
                 "\" (expected depth, K, depth_scale, confidence, color, baseline_m, points, "
                 "normals)");
      }
    }
    CameraCapture camera;
    camera.serial = serial;
    const bool depth = d.contains("depth");
    const bool points = d.contains("points");
    if (depth == points) Fail(where, "expected exactly one of \"depth\" and \"points\"");
    if (depth) {
      ReadDepth(d, camera, where);
    } else {
      camera.points = Vectors(d["points"], -1, where + ": points");
      if (camera.points.empty()) Fail(where + ": points", "empty");
      if (d.contains("normals")) {
        camera.normals = Vectors(d["normals"], static_cast<py::ssize_t>(camera.points.size()),
                                 where + ": normals");
      }
    }
    capture.cameras.push_back(std::move(camera));
  }
  return capture;
}

/// rigfit.refine's keywords besides config: `rigfit refine`'s flags that override the config
/// (unset: the config's value) and those that do not map to a config key.
struct RefineKeywords {
  std::optional<std::string> mode;
  std::optional<std::string> method;
  std::optional<bool> surface_bundle;
  std::optional<double> voxel_size;
  std::optional<std::string> reference;
  bool no_ground = false;
  bool no_icp = false;
  int threads = 2;
};

const KeywordTable<RefineKeywords>& RefineTable() {
  using K = RefineKeywords;
  static const KeywordTable<K> table =
      KeywordTable<K>("refine")
          .Add("mode", [](K& k) { return &k.mode; })
          .Add("method", [](K& k) { return &k.method; })
          .Add("surface_bundle", [](K& k) { return &k.surface_bundle; })
          .Add("voxel_size", [](K& k) { return &k.voxel_size; })
          .Add("reference", [](K& k) { return &k.reference; })
          .Add("no_ground", [](K& k) { return &k.no_ground; })
          .Add("no_icp", [](K& k) { return &k.no_icp; })
          .Add("threads", [](K& k) { return &k.threads; });
  return table;
}

/// rigfit.compare's keywords besides config and gt: the flags of `rigfit compare`.
struct CompareKeywords {
  int threads = 2;
};

const KeywordTable<CompareKeywords>& CompareTable() {
  static const KeywordTable<CompareKeywords> table = KeywordTable<CompareKeywords>("compare").Add(
      "threads", [](CompareKeywords& k) { return &k.threads; });
  return table;
}

/// Throws InputError "<command>: threads must be in [1, 256], got <threads>" (the CLI's range).
void CheckThreads(const std::string& command, int threads) {
  if (threads < 1 || threads > kMaxRefineThreads) {
    throw InputError(command + ": threads must be in [1, " + std::to_string(kMaxRefineThreads) +
                     "], got " + std::to_string(threads));
  }
}

/// A config as rigfit/__init__.py's _config_text gives it: (YAML text from a dict, path), at
/// most one of them not empty.
using ConfigText = std::pair<std::string, std::string>;

/// The options of a run of `command` (refine, compare): config (YAML text from a dict, or a
/// path, or the defaults) with the keyword overrides applied, as `rigfit refine` applies its
/// flags, checked.
RefineOptions OptionsOf(const std::string& command, const ConfigText& config,
                        const RefineKeywords& k) {
  const auto& [config_yaml, config_path] = config;
  RefineOptions options;
  if (!config_path.empty()) {
    options = LoadConfig(config_path);
  } else if (!config_yaml.empty()) {
    options = ParseConfig(config_yaml, "config");
  }
  if (k.mode) {
    if (*k.mode != "joint" && *k.mode != "pairwise") {
      throw InputError(command + ": mode must be joint or pairwise, got '" + *k.mode + "'");
    }
    options.icp.mode = *k.mode == "joint" ? RefineMode::kJoint : RefineMode::kPairwise;
  }
  if (k.method) options.icp.method = RegistrationMethodNamed(*k.method);
  if (k.surface_bundle) options.icp.surface_bundle = *k.surface_bundle;
  if (k.voxel_size) options.icp.voxel_size = *k.voxel_size;
  if (k.reference) options.icp.reference = *k.reference;
  if (k.no_ground) options.ground.enabled = false;
  const std::vector<std::string> problems = OptionProblems(options);
  if (!problems.empty()) {
    std::string text = command + ": invalid options (config with keyword overrides):";
    for (const std::string& p : problems) text += "\n  " + p;
    throw InputError(text);
  }
  return options;
}

/// A camera's surface bundle depth model (rigfit.DepthModel's fields); None when it had none.
py::object DepthModelDict(const DepthModelEstimate& e) {
  if (!(e.offset_prior_sigma > 0.0)) return py::none();
  py::dict d;
  ForEachDepthModelField(e, [&](const char* name, auto value) { d[name] = value; });
  return d;
}

/// The per-camera reports of a run (rig/refine.h CameraReport), covariance as numpy.
py::list CameraReports(const RefineResult& result) {
  py::list out;
  for (const CameraReport& c : result.cameras) {
    py::dict d;
    d["serial"] = c.serial;
    d["reference"] = c.reference;
    d["surface_leveled"] = c.surface_leveled;
    d["leveled"] = c.ground.accepted;
    d["leveling_message"] = c.ground.message;
    d["leveling_rotation_deg"] = c.ground.correction_rotation_deg;
    d["leveling_translation_m"] = c.ground.correction_translation_m;
    d["connected"] = c.connected;
    d["accepted"] = c.accepted;
    d["message"] = c.message;
    d["delta_rotation_deg"] = c.delta_rotation_deg;
    d["delta_translation_m"] = c.delta_translation_m;
    d["own_rotation_deg"] = c.own_rotation_deg;
    d["own_translation_m"] = c.own_translation_m;
    if (c.has_covariance) {
      py::array_t<double> cov({6, 6});
      auto m = cov.mutable_unchecked<2>();
      for (int r = 0; r < 6; ++r) {
        for (int col = 0; col < 6; ++col) m(r, col) = c.covariance(r, col);
      }
      d["covariance"] = cov;
      const PoseSigma sigma = SigmaOf(c.covariance);
      py::dict s;
      s["yaw_deg"] = sigma.yaw_deg;
      s["tilt_deg"] = sigma.tilt_deg;
      s["x_mm"] = sigma.x_mm;
      s["y_mm"] = sigma.y_mm;
      s["z_mm"] = sigma.z_mm;
      d["sigma"] = s;
      py::dict inflation;
      inflation["rotation"] = c.sigma_inflation.rotation;
      inflation["translation"] = c.sigma_inflation.translation;
      d["sigma_inflation"] = inflation;
    } else {
      d["covariance"] = py::none();
      d["sigma"] = py::none();
      d["sigma_inflation"] = py::none();
    }
    d["surfaces"] = c.surfaces;
    d["few_surfaces"] = c.few_surfaces;
    py::list weak;
    for (const WeakDirection& w : c.weak_directions) {
      py::dict wd;
      wd["direction"] = w.name;
      wd["information_fraction"] = w.strength;
      wd["reason"] = w.reason;
      weak.append(wd);
    }
    d["weak_directions"] = weak;
    d["depth_model"] = DepthModelDict(c.depth_model);
    out.append(d);
  }
  return out;
}

/// The per-pair reports of a run (rig/refine.h PairReport).
py::list PairReports(const RefineResult& result) {
  py::list out;
  for (const PairReport& p : result.pairs) {
    py::dict d;
    d["serial_a"] = p.serial_a;
    d["serial_b"] = p.serial_b;
    d["overlap_area_m2"] = p.overlap_area_m2;
    d["fitness"] = p.fitness;
    d["rmse_before_m"] = p.rmse_before_m;
    d["rmse_after_m"] = p.rmse_after_m;
    d["correspondences"] = p.correspondences;
    d["iterations"] = p.iterations;
    d["accepted"] = p.accepted;
    d["message"] = p.message;
    out.append(d);
  }
  return out;
}

/// `rigfit refine` on arrays: keywords as RefineTable reads them.
py::dict RunRefine(const py::dict& cameras, const py::dict& extrinsics, const ConfigText& config,
                   const py::dict& keywords, const py::object& logger) {
  const RefineKeywords k = RefineTable().Apply(keywords);
  CheckThreads("refine", k.threads);
  RefineOptions options = OptionsOf("refine", config, k);
  options.run_registration = !k.no_icp;
  options.threads = k.threads;
  const RigCapture capture = CaptureOf(cameras);
  const PoseMap initial = PosesOf(extrinsics, "extrinsics");
  CheckRefineInput(
      capture, initial, options,
      {"refine", "cameras", "extrinsics", k.reference ? "reference" : "icp.reference"});
  std::vector<std::string> warnings = CaptureWarnings(capture, "cameras");
  const Log log = PythonLog(logger);
  for (const std::string& w : warnings) log.Warning(w);

  RefineResult result;
  {
    py::gil_scoped_release release;
    result = Refine(capture, initial, options, log);
  }
  warnings.insert(warnings.end(), result.warnings.begin(), result.warnings.end());
  Json meta = RefineMetaJson(result, options, warnings, {k.no_ground, k.no_icp});
  for (const std::string& path : ReplaceNonFinite(meta, "_meta")) {
    const std::string warning = path + " was not finite and is written as null";
    log.Warning(warning);
    meta["icp_refined"]["warnings"].push_back(warning);
  }
  // As the CLI: when the refinement is not applied, the output is the leveled input.
  const PoseMap& poses = result.success ? result.refined : result.leveled;
  py::dict out;
  out["extrinsics"] = PosesToDict(poses);
  out["success"] = result.success;
  out["message"] = result.message;
  out["warnings"] = warnings;
  out["cameras"] = CameraReports(result);
  out["pairs"] = PairReports(result);
  out["meta_json"] = meta.dump();
  return out;
}

/// `rigfit compare` on arrays: the three runs (report/compare.h), their JSON document (as
/// `--json` writes it, sources null) and the text the CLI prints. gt: serial -> (4, 4) or None.
py::dict RunCompare(const py::dict& cameras, const py::dict& extrinsics, const ConfigText& config,
                    const py::object& gt, const py::dict& keywords, const py::object& logger) {
  const CompareKeywords k = CompareTable().Apply(keywords);
  CheckThreads("compare", k.threads);
  RefineOptions options = OptionsOf("compare", config, {});
  options.threads = k.threads;
  const RigCapture capture = CaptureOf(cameras);
  const PoseMap initial = PosesOf(extrinsics, "extrinsics");
  CheckRefineInput(capture, initial, options,
                   {"compare", "cameras", "extrinsics", "icp.reference"});
  PoseMap truth_poses;
  if (!gt.is_none()) {
    if (!py::isinstance<py::dict>(gt)) {
      throw InputError("compare: gt must be a dict serial -> (4, 4) or None");
    }
    truth_poses = PosesOf(py::reinterpret_borrow<py::dict>(gt), "gt");
  }
  const PoseMap* truth = gt.is_none() ? nullptr : &truth_poses;
  const CompareSources sources = {"", "", "", config.second};
  CheckCompareInput(capture, truth, {"cameras", "extrinsics", "gt", ""});
  std::vector<std::string> warnings = CaptureWarnings(capture, "cameras");
  const Log log = PythonLog(logger);
  for (const std::string& w : warnings) log.Warning(w);

  CompareResult result;
  {
    py::gil_scoped_release release;
    result = Compare(capture, initial, options, truth, log);
  }
  Json document = CompareToJson(result, sources);
  for (const std::string& path : ReplaceNonFinite(document, "compare")) {
    log.Warning(path + " was not finite and is written as null");
  }
  py::dict out;
  out["json"] = document.dump();
  out["text"] = CompareText(result, sources);
  return out;
}

/// A capture as `cameras` (serial -> {"depth", "K", ["confidence", "color"]} or {"points",
/// ["normals"]}); its buffers become the arrays (VectorToNumpy: no copy), so `capture` is
/// emptied.
py::dict CaptureToDict(RigCapture&& capture) {
  py::dict out;
  for (CameraCapture& c : capture.cameras) {
    py::dict d;
    if (c.HasDepth()) {
      const py::ssize_t h = c.height;
      const py::ssize_t w = c.width;
      d["depth"] = VectorToNumpy(std::move(c.depth_m), {h, w});
      d["K"] = IntrinsicsToK(c.intrinsics);
      if (!c.confidence.empty()) d["confidence"] = VectorToNumpy(std::move(c.confidence), {h, w});
      if (!c.color.empty()) d["color"] = VectorToNumpy(std::move(c.color), {h, w, 3});
      if (c.baseline_m > 0.0) d["baseline_m"] = c.baseline_m;
    } else {
      if (!c.points.empty()) d["points"] = PointsToNumpy(std::move(c.points));
      if (!c.normals.empty()) d["normals"] = PointsToNumpy(std::move(c.normals));
    }
    out[py::str(c.serial)] = d;
  }
  return out;
}

py::dict PyReadCapture(const std::string& path, const py::object& logger) {
  RigCapture capture = ReadCapture(path);
  const Log log = PythonLog(logger);
  for (const std::string& w : CaptureWarnings(capture, path)) log.Warning(w);
  return CaptureToDict(std::move(capture));
}

const KeywordTable<CaptureWriteOptions>& WriteCaptureTable() {
  using O = CaptureWriteOptions;
  static const KeywordTable<O> table =
      KeywordTable<O>("write_capture")
          .Add("depth_as_uint16", [](O& o) { return &o.depth_as_uint16; })
          .Add("depth_scale", [](O& o) { return &o.depth_scale; });
  return table;
}

void PyWriteCapture(const std::string& path, const py::dict& cameras, const py::dict& keywords) {
  const CaptureWriteOptions options = WriteCaptureTable().Apply(keywords);
  WriteCapture(path, CaptureOf(cameras), options);
}

py::dict PyReadExtrinsics(const std::string& path, const py::object& logger) {
  const ExtrinsicsDocument doc = ReadExtrinsics(path);
  const Log log = PythonLog(logger);
  for (const std::string& w : doc.warnings) log.Warning(w);
  return PosesToDict(doc.poses);
}

void PyWriteExtrinsics(const std::string& path, const py::dict& extrinsics,
                       const std::string& meta_json) {
  const PoseMap poses = PosesOf(extrinsics, path);
  const Json meta = meta_json.empty() ? Json::object() : Json::parse(meta_json);
  WriteExtrinsics(path, poses, Json::object(), meta);
}

/// {"pairs", "cameras", "summary", "ignored_cameras"} as `rigfit evaluate --json` writes them,
/// as JSON text (rigfit/__init__.py reads it into a RigErrors).
std::string Evaluate(const py::dict& estimated, const py::dict& ground_truth) {
  const PoseMap est = PosesOf(estimated, "estimated");
  const PoseMap gt = PosesOf(ground_truth, "ground_truth");
  const std::vector<std::string> ignored =
      CheckEvaluationCameras(est, gt, "evaluate", "estimated", "ground_truth");
  Json document = RigErrorsJson(EvaluateRig(est, gt));
  document["ignored_cameras"] = ignored;
  return document.dump();
}

/// rigfit.simulate's keywords: `rigfit simulate`'s flags, read into SimOptions.
/// rigfit.simulate's keywords: the options, the depth model by its name.
struct SimulateKeywords {
  SimOptions sim;
  std::string depth_model = DepthModelName(SimOptions{}.depth_model);
};

const KeywordTable<SimulateKeywords>& SimulateTable() {
  using K = SimulateKeywords;
  static const KeywordTable<K> table =
      KeywordTable<K>("simulate")
          .Add("cameras", [](K& k) { return &k.sim.cameras; })
          .Add("seed", [](K& k) { return &k.sim.seed; })
          .Add("width", [](K& k) { return &k.sim.width; })
          .Add("height", [](K& k) { return &k.sim.height; })
          .Add("noise", [](K& k) { return &k.sim.noise; })
          .Add("noise_corr_px", [](K& k) { return &k.sim.noise_corr_px; })
          .Add("noise_corr_share", [](K& k) { return &k.sim.noise_corr_share; })
          .Add("disparity_quant_px", [](K& k) { return &k.sim.disparity_quant_px; })
          .Add("dropout", [](K& k) { return &k.sim.dropout; })
          .Add("perturb_yaw_deg", [](K& k) { return &k.sim.perturb_yaw_deg; })
          .Add("perturb_xz_m", [](K& k) { return &k.sim.perturb_xz_m; })
          .Add("perturb_tilt_deg", [](K& k) { return &k.sim.perturb_tilt_deg; })
          .Add("bare", [](K& k) { return &k.sim.bare; })
          .Add("depth_model", [](K& k) { return &k.depth_model; })
          .Add("stereo_baseline_m", [](K& k) { return &k.sim.stereo_baseline_m; })
          .Add("stereo_upsample", [](K& k) { return &k.sim.stereo_upsample; })
          .Add("disparity_offset_px", [](K& k) { return &k.sim.disparity_offset_px; })
          .Add("depth_scale", [](K& k) { return &k.sim.depth_scale; })
          .Add("miscalibrated_cameras", [](K& k) { return &k.sim.miscalibrated_cameras; });
  return table;
}

/// {"cameras", "truth", "start"} of SimulateRig, after `rigfit simulate`'s checks
/// (CheckSimOptions).
py::dict Simulate(const py::dict& keywords) {
  SimulateKeywords k = SimulateTable().Apply(keywords);
  CheckKeywords("simulate", [&] {
    k.sim.depth_model = DepthModelNamed(k.depth_model);
    CheckSimOptions(k.sim);
  });
  const SimOptions& options = k.sim;
  SimulatedRig rig;
  {
    py::gil_scoped_release release;
    rig = SimulateRig(options);
  }
  py::dict out;
  out["cameras"] = CaptureToDict(std::move(rig.capture));
  out["truth"] = PosesToDict(rig.gt);
  out["start"] = PosesToDict(rig.init);
  return out;
}

}  // namespace
}  // namespace rigfit::python

PYBIND11_MODULE(_rigfit, m) {
  using namespace rigfit;
  using namespace rigfit::python;
  m.doc() = "rigfit's compiled core; use the package rigfit instead (docs/python.md).";
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const InputError& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    }
  });
  // command -> {keyword: default}: the names and defaults of every keyword table, which
  // rigfit/__init__.py turns into the functions' signatures.
  py::dict defaults;
  defaults["refine"] = RefineTable().Defaults();
  defaults["compare"] = CompareTable().Defaults();
  defaults["write_capture"] = WriteCaptureTable().Defaults();
  defaults["simulate"] = SimulateTable().Defaults();
  m.attr("keyword_defaults") = defaults;
  m.def("refine", &RunRefine, py::arg("cameras"), py::arg("extrinsics"), py::arg("config"),
        py::arg("keywords"), py::arg("logger"));
  m.def("compare", &RunCompare, py::arg("cameras"), py::arg("extrinsics"), py::arg("config"),
        py::arg("gt"), py::arg("keywords"), py::arg("logger"));
  m.def("evaluate", &Evaluate, py::arg("estimated"), py::arg("ground_truth"));
  m.def("read_capture", &PyReadCapture, py::arg("path"), py::arg("logger"));
  m.def("write_capture", &PyWriteCapture, py::arg("path"), py::arg("cameras"), py::arg("keywords"));
  m.def("read_extrinsics", &PyReadExtrinsics, py::arg("path"), py::arg("logger"));
  m.def("write_extrinsics", &PyWriteExtrinsics, py::arg("path"), py::arg("extrinsics"),
        py::arg("meta_json"));
  m.def("simulate", &Simulate, py::arg("keywords"));
  AddRgbdFunctions(m);
}

// rigfit._rigfit: the compiled half of the Python module (docs/python.md). Converts numpy
// arrays and dicts to the library's plain structs (core/types.h, options/refine_options.h;
// python/convert.h), runs the same library calls as `rigfit refine` (cli/refine_command.cc),
// `rigfit compare` (report/compare.h) and `rigfit simulate` and hands back plain Python values;
// rigfit/__init__.py wraps them in typed objects. The RGB-D part (sequences, tracking,
// trajectories) is python/rgbd_module.cc. InputError becomes ValueError.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "core/errors.h"
#include "core/evaluate.h"
#include "core/types.h"
#include "io/capture_h5.h"
#include "io/config_yaml.h"
#include "io/extrinsics_json.h"
#include "options/refine_options.h"
#include "python/convert.h"
#include "report/compare.h"
#include "report/refine_meta.h"
#include "rig/refine.h"
#include "sim/simulate_rig.h"

namespace rigfit::python {

void AddRgbdFunctions(py::module_& m);  // python/rgbd_module.cc

namespace {

using Json = nlohmann::json;
using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;

/// The depth camera of d ("depth", "K", ["depth_scale", "confidence", "color"]): the depth read
/// once into camera.depth_m (DepthView), then ReadCapture's rules (CheckDepthCamera).
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

/// cameras: serial -> {"depth", "K", ["depth_scale", "confidence", "color"]} or
/// {"points", ["normals"]}; sorted by serial as ReadCapture sorts them.
RigCapture CaptureOf(const py::dict& cameras) {
  static const std::set<std::string> kKeys = {"depth", "K",      "depth_scale", "confidence",
                                              "color", "points", "normals"};
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
        Fail(where, "unknown key \"" + key +
                        "\" (expected depth, K, depth_scale, confidence, color, points, normals)");
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

/// The options of a run of `command` (refine, compare): config (YAML text from a dict, or a
/// path, or the defaults) with the keyword overrides applied, as `rigfit refine` applies its
/// flags; the number of worker threads checked.
RefineOptions OptionsOf(const std::string& command, const std::string& config_yaml,
                        const std::string& config_path, const std::string& mode,
                        const std::string& method, const std::string& reference, bool level_ground,
                        int threads) {
  if (threads < 1 || threads > kMaxRefineThreads) {
    throw InputError(command + ": threads must be in [1, " + std::to_string(kMaxRefineThreads) +
                     "], got " + std::to_string(threads));
  }
  RefineOptions options;
  if (!config_path.empty()) {
    options = LoadConfig(config_path);
  } else if (!config_yaml.empty()) {
    options = ParseConfig(config_yaml, "config");
  }
  if (!mode.empty()) {
    if (mode != "joint" && mode != "pairwise") {
      throw InputError("refine: mode must be joint or pairwise, got '" + mode + "'");
    }
    options.icp.mode = mode == "joint" ? RefineMode::kJoint : RefineMode::kPairwise;
  }
  if (!method.empty()) options.icp.method = RegistrationMethodNamed(method);
  if (!reference.empty()) options.icp.reference = reference;
  if (!level_ground) options.ground.enabled = false;
  options.threads = threads;
  const std::vector<std::string> problems = OptionProblems(options);
  if (!problems.empty()) {
    std::string text = command + ": invalid options (config with keyword overrides):";
    for (const std::string& p : problems) text += "\n  " + p;
    throw InputError(text);
  }
  return options;
}

/// The per-camera reports of a run (rig/refine.h CameraReport), covariance as numpy.
py::list CameraReports(const RefineResult& result) {
  py::list out;
  for (const CameraReport& c : result.cameras) {
    py::dict d;
    d["serial"] = c.serial;
    d["reference"] = c.reference;
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
    } else {
      d["covariance"] = py::none();
      d["sigma"] = py::none();
    }
    py::list weak;
    for (const WeakDirection& w : c.weak_directions) {
      py::dict wd;
      wd["name"] = w.name;
      wd["strength"] = w.strength;
      wd["reason"] = w.reason;
      weak.append(wd);
    }
    d["weak_directions"] = weak;
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

py::dict RunRefine(const py::dict& cameras, const py::dict& extrinsics,
                   const std::string& config_yaml, const std::string& config_path,
                   const std::string& mode, const std::string& method, const std::string& reference,
                   bool level_ground, int threads, const py::object& logger) {
  const RefineOptions options =
      OptionsOf("refine", config_yaml, config_path, mode, method, reference, level_ground, threads);
  const RigCapture capture = CaptureOf(cameras);
  const PoseMap initial = PosesOf(extrinsics, "extrinsics");
  CheckRefineInput(
      capture, initial, options,
      {"refine", "cameras", "extrinsics", reference.empty() ? "icp.reference" : "reference"});
  std::vector<std::string> warnings = CaptureWarnings(capture, "cameras");
  const Log log = PythonLog(logger);
  for (const std::string& w : warnings) log.Warning(w);

  RefineResult result;
  {
    py::gil_scoped_release release;
    result = Refine(capture, initial, options, log);
  }
  warnings.insert(warnings.end(), result.warnings.begin(), result.warnings.end());
  Json meta = RefineMetaJson(result, options, warnings, {!level_ground, false});
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
/// `--json` writes it, sources null) and the text the CLI prints.
py::dict RunCompare(const py::dict& cameras, const py::dict& extrinsics,
                    const std::string& config_yaml, const std::string& config_path,
                    const py::object& ground_truth, const std::string& reference, bool level_ground,
                    int threads, const py::object& logger) {
  const RefineOptions options =
      OptionsOf("compare", config_yaml, config_path, "", "", reference, level_ground, threads);
  const RigCapture capture = CaptureOf(cameras);
  const PoseMap initial = PosesOf(extrinsics, "extrinsics");
  CheckRefineInput(
      capture, initial, options,
      {"compare", "cameras", "extrinsics", reference.empty() ? "icp.reference" : "reference"});
  PoseMap gt;
  if (!ground_truth.is_none()) {
    if (!py::isinstance<py::dict>(ground_truth)) {
      throw InputError("compare: ground_truth must be a dict serial -> (4, 4) or None");
    }
    gt = PosesOf(py::reinterpret_borrow<py::dict>(ground_truth), "ground_truth");
  }
  const PoseMap* truth = ground_truth.is_none() ? nullptr : &gt;
  const CompareSources sources = {"", "", "", config_path};
  CheckCompareInput(capture, truth, {"cameras", "extrinsics", "ground_truth", ""});
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
    } else {
      if (!c.points.empty()) d["points"] = PointsToNumpy(std::move(c.points));
      if (!c.normals.empty()) d["normals"] = PointsToNumpy(std::move(c.normals));
    }
    out[py::str(c.serial)] = d;
  }
  return out;
}

py::dict LoadCapture(const std::string& path, const py::object& logger) {
  RigCapture capture = ReadCapture(path);
  const Log log = PythonLog(logger);
  for (const std::string& w : CaptureWarnings(capture, path)) log.Warning(w);
  return CaptureToDict(std::move(capture));
}

py::dict LoadExtrinsics(const std::string& path, const py::object& logger) {
  const ExtrinsicsDocument doc = ReadExtrinsics(path);
  const Log log = PythonLog(logger);
  for (const std::string& w : doc.warnings) log.Warning(w);
  return PosesToDict(doc.poses);
}

void SaveExtrinsics(const std::string& path, const py::dict& extrinsics,
                    const std::string& meta_json) {
  const PoseMap poses = PosesOf(extrinsics, path);
  const Json meta = meta_json.empty() ? Json::object() : Json::parse(meta_json);
  WriteExtrinsics(path, poses, Json::object(), meta);
}

/// {"pairs", "cameras", "summary", "ignored_cameras"} as `rigfit evaluate --json` writes them,
/// as JSON text (rigfit/__init__.py loads it).
std::string Evaluate(const py::dict& estimated, const py::dict& ground_truth) {
  const PoseMap est = PosesOf(estimated, "estimated");
  const PoseMap gt = PosesOf(ground_truth, "ground_truth");
  const std::vector<std::string> ignored =
      CheckEvaluationCameras(est, gt, "evaluate", "estimated", "ground_truth");
  Json document = RigErrorsJson(EvaluateRig(est, gt));
  document["ignored_cameras"] = ignored;
  return document.dump();
}

void SaveCapture(const std::string& path, const py::dict& cameras, bool depth_as_uint16,
                 double depth_scale) {
  const RigCapture capture = CaptureOf(cameras);
  CaptureWriteOptions options;
  options.depth_as_uint16 = depth_as_uint16;
  options.depth_scale = depth_scale;
  WriteCapture(path, capture, options);
}

/// The defaults of SimOptions under the names of `rigfit simulate`'s flags: rigfit.simulate's
/// keyword defaults.
py::dict SimulateDefaults() {
  const SimOptions o;
  py::dict d;
  d["cameras"] = o.cameras;
  d["seed"] = o.seed;
  d["width"] = o.width;
  d["height"] = o.height;
  d["noise"] = o.noise;
  d["noise_corr_px"] = o.noise_corr_px;
  d["noise_corr_share"] = o.noise_corr_share;
  d["disparity_quant_px"] = o.disparity_quant_px;
  d["dropout"] = o.dropout;
  d["perturb_yaw_deg"] = o.perturb_yaw_deg;
  d["perturb_xz_m"] = o.perturb_xz_m;
  d["perturb_tilt_deg"] = o.perturb_tilt_deg;
  d["bare"] = o.bare;
  return d;
}

/// (cameras, truth, start) of SimulateRig, after `rigfit simulate`'s checks (CheckSimOptions).
py::tuple Simulate(int cameras, std::uint64_t seed, int width, int height, double noise,
                   double noise_corr_px, double noise_corr_share, double disparity_quant_px,
                   double dropout, double perturb_yaw_deg, double perturb_xz_m,
                   double perturb_tilt_deg, bool bare) {
  SimOptions o;
  o.cameras = cameras;
  o.seed = seed;
  o.width = width;
  o.height = height;
  o.noise = noise;
  o.noise_corr_px = noise_corr_px;
  o.noise_corr_share = noise_corr_share;
  o.disparity_quant_px = disparity_quant_px;
  o.dropout = dropout;
  o.perturb_yaw_deg = perturb_yaw_deg;
  o.perturb_xz_m = perturb_xz_m;
  o.perturb_tilt_deg = perturb_tilt_deg;
  o.bare = bare;
  CheckSimOptions(o, "simulate", OptionSpelling::kKeyword);
  SimulatedRig rig;
  {
    py::gil_scoped_release release;
    rig = SimulateRig(o);
  }
  return py::make_tuple(CaptureToDict(std::move(rig.capture)), PosesToDict(rig.gt),
                        PosesToDict(rig.init));
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
  m.def("refine", &RunRefine, py::arg("cameras"), py::arg("extrinsics"), py::arg("config_yaml"),
        py::arg("config_path"), py::arg("mode"), py::arg("method"), py::arg("reference"),
        py::arg("level_ground"), py::arg("threads"), py::arg("logger"));
  m.def("compare", &RunCompare, py::arg("cameras"), py::arg("extrinsics"), py::arg("config_yaml"),
        py::arg("config_path"), py::arg("ground_truth"), py::arg("reference"),
        py::arg("level_ground"), py::arg("threads"), py::arg("logger"));
  m.def("load_capture", &LoadCapture, py::arg("path"), py::arg("logger"));
  m.def("evaluate", &Evaluate, py::arg("estimated"), py::arg("ground_truth"));
  m.def("save_capture", &SaveCapture, py::arg("path"), py::arg("cameras"),
        py::arg("depth_as_uint16"), py::arg("depth_scale"));
  m.def("load_extrinsics", &LoadExtrinsics, py::arg("path"), py::arg("logger"));
  m.def("save_extrinsics", &SaveExtrinsics, py::arg("path"), py::arg("extrinsics"),
        py::arg("meta_json"));
  m.def("simulate_defaults", &SimulateDefaults);
  m.def("simulate", &Simulate, py::arg("cameras"), py::arg("seed"), py::arg("width"),
        py::arg("height"), py::arg("noise"), py::arg("noise_corr_px"), py::arg("noise_corr_share"),
        py::arg("disparity_quant_px"), py::arg("dropout"), py::arg("perturb_yaw_deg"),
        py::arg("perturb_xz_m"), py::arg("perturb_tilt_deg"), py::arg("bare"));
  AddRgbdFunctions(m);
}

// rigfit._rigfit: the compiled half of the Python module (docs/python.md). Converts numpy
// arrays and dicts to the library's plain structs (core/types.h, rig/options.h), runs the same
// library calls as `rigfit refine` (cli/refine_command.cc) and hands back plain Python values;
// rigfit/__init__.py wraps them in typed objects. InputError becomes ValueError.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
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
#include "report/refine_meta.h"
#include "rig/options.h"
#include "rig/refine.h"

namespace py = pybind11;

namespace rigfit {
namespace {

using Json = nlohmann::json;
using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;
using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;

[[noreturn]] void Fail(const std::string& where, const std::string& what) {
  throw InputError(where + ": " + what);
}

std::string Shape(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) {
    s += (i ? ", " : "") + std::to_string(a.shape(i));
  }
  return s + (a.ndim() == 1 ? ",)" : ")");
}

/// A float64 array of exactly `rows` x `cols` (rows < 0: any), as a C-contiguous array.
DoubleArray Matrix(const py::handle& value, py::ssize_t rows, py::ssize_t cols,
                   const std::string& where) {
  DoubleArray a;
  try {
    a = DoubleArray::ensure(value);
  } catch (const py::error_already_set&) {
  }
  if (!a) Fail(where, "expected a numeric array");
  const bool shape_ok = a.ndim() == 2 && (rows < 0 || a.shape(0) == rows) && a.shape(1) == cols;
  if (!shape_ok) {
    Fail(where, "expected shape (" + (rows < 0 ? std::string("N") : std::to_string(rows)) + ", " +
                    std::to_string(cols) + "), got " + Shape(a));
  }
  return a;
}

/// A depth sample in metres as float: NaN where invalid (NaN, +-inf, <= 0), as ReadCapture.
float DepthSample(double z) {
  if (!(z > 0.0 && std::isfinite(z))) return std::numeric_limits<float>::quiet_NaN();
  return static_cast<float>(std::min<double>(z, std::numeric_limits<float>::max()));
}

void ReadDepth(const py::dict& d, CameraCapture& camera, const std::string& where) {
  const py::array raw = py::array::ensure(d["depth"]);
  if (!raw || raw.ndim() != 2) {
    Fail(where + ": depth",
         "expected a 2-D array (H, W), got " + (raw ? Shape(raw) : std::string("no array")));
  }
  camera.height = static_cast<int>(raw.shape(0));
  camera.width = static_cast<int>(raw.shape(1));
  if (camera.width == 0 || camera.height == 0) Fail(where + ": depth", "empty image");
  const size_t n = static_cast<size_t>(raw.size());
  camera.depth_m.resize(n);
  const bool has_scale = d.contains("depth_scale");
  if (raw.dtype().is(py::dtype::of<std::uint16_t>())) {
    if (!has_scale) Fail(where, "uint16 depth needs \"depth_scale\" (metres per unit)");
    const double scale = py::cast<double>(d["depth_scale"]);
    if (!(std::isfinite(scale) && scale > 0.0)) {
      Fail(where + ": depth_scale", "must be a finite number > 0, got " + std::to_string(scale));
    }
    const auto a = py::array_t<std::uint16_t, py::array::c_style>::ensure(raw);
    const std::uint16_t* p = a.data();
    for (size_t i = 0; i < n; ++i) camera.depth_m[i] = DepthSample(p[i] * scale);
  } else if (raw.dtype().kind() == 'f') {
    if (has_scale) Fail(where, "\"depth_scale\" is for uint16 depth; float depth is in metres");
    if (raw.dtype().is(py::dtype::of<float>())) {
      const auto a = FloatArray::ensure(raw);
      const float* p = a.data();
      for (size_t i = 0; i < n; ++i) camera.depth_m[i] = DepthSample(p[i]);
    } else {
      const auto a = DoubleArray::ensure(raw);
      const double* p = a.data();
      for (size_t i = 0; i < n; ++i) camera.depth_m[i] = DepthSample(p[i]);
    }
  } else {
    Fail(where + ": depth", "expected float32 or float64 metres, or uint16 with depth_scale, got " +
                                std::string(py::str(raw.dtype())));
  }
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
    const auto c = py::array_t<std::uint8_t, py::array::c_style>::ensure(d["color"]);
    if (!c || c.ndim() != 3 || c.shape(0) != camera.height || c.shape(1) != camera.width ||
        c.shape(2) != 3) {
      Fail(where + ": color", "expected uint8 (H, W, 3)");
    }
    camera.color.assign(c.data(), c.data() + c.size());
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

/// extrinsics: serial -> 4x4 T_world_camera, checked as ReadExtrinsics checks a file's
/// (finite, last row [0, 0, 0, 1], rotation within 1e-3 of orthonormal with det > 0); not
/// re-orthonormalised, so that a pose passes through unchanged.
PoseMap PosesOf(const py::dict& extrinsics, const std::string& name) {
  PoseMap poses;
  for (const auto& [key, value] : extrinsics) {
    if (!py::isinstance<py::str>(key)) throw InputError(name + ": keys must be serials (str)");
    const std::string serial = py::cast<std::string>(key);
    const std::string where = name + ": camera " + serial;
    if (serial.empty()) throw InputError(name + ": empty serial");
    const DoubleArray a = Matrix(value, 4, 4, where);
    const auto m = a.unchecked<2>();
    Pose T;
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) T.matrix()(r, c) = m(r, c);
    }
    if (!T.matrix().allFinite()) Fail(where, "entries must be finite");
    if (T.matrix().row(3) != Eigen::RowVector4d(0, 0, 0, 1)) {
      Fail(where, "last row must be [0, 0, 0, 1]");
    }
    const Mat3 R = T.linear();
    const double deviation = (R.transpose() * R - Mat3::Identity()).cwiseAbs().maxCoeff();
    if (deviation > 1e-3 || R.determinant() <= 0.0) {
      std::ostringstream what;
      what << "rotation block is not a rotation (max |R^T R - I| = " << deviation
           << ", det = " << R.determinant() << ")";
      Fail(where, what.str());
    }
    poses[serial] = T;
  }
  return poses;
}

py::array_t<double> MatrixToNumpy(const Eigen::Matrix4d& m) {
  py::array_t<double> out({4, 4});
  auto o = out.mutable_unchecked<2>();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) o(r, c) = m(r, c);
  }
  return out;
}

py::dict PosesToDict(const PoseMap& poses) {
  py::dict out;
  for (const auto& [serial, T] : poses) out[py::str(serial)] = MatrixToNumpy(T.matrix());
  return out;
}

/// The Python logger "rigfit" as a Log: callable from the solver's threads (takes the GIL).
Log PythonLog(const py::object& logger) {
  if (logger.is_none()) return {};
  return {[logger](LogLevel level, const std::string& message) {
    py::gil_scoped_acquire gil;
    try {
      const int py_level = level == LogLevel::kDebug ? 10 : level == LogLevel::kInfo ? 20 : 30;
      logger.attr("log")(py_level, message);
    } catch (const py::error_already_set&) {
      // A failing handler must not abort the solve.
    }
  }};
}

/// The options of a run: config (YAML text from a dict, or a path, or the defaults) with the
/// keyword overrides applied, as `rigfit refine` applies its flags.
RefineOptions OptionsOf(const std::string& config_yaml, const std::string& config_path,
                        const std::string& mode, const std::string& method,
                        const std::string& reference, bool level_ground) {
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
  const std::vector<std::string> problems = OptionProblems(options);
  if (!problems.empty()) {
    std::string text = "refine: invalid options (config with keyword overrides):";
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
  if (threads < 1 || threads > 256) {
    throw InputError("refine: threads must be in [1, 256], got " + std::to_string(threads));
  }
  const RefineOptions options =
      OptionsOf(config_yaml, config_path, mode, method, reference, level_ground);
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
    result = Refine(capture, initial, options, /*run_icp=*/true, threads, log);
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

py::dict LoadCapture(const std::string& path, const py::object& logger) {
  const RigCapture capture = ReadCapture(path);
  const Log log = PythonLog(logger);
  for (const std::string& w : CaptureWarnings(capture, path)) log.Warning(w);
  py::dict out;
  for (const CameraCapture& c : capture.cameras) {
    py::dict d;
    if (c.HasDepth()) {
      py::array_t<float> depth({c.height, c.width});
      std::copy(c.depth_m.begin(), c.depth_m.end(), depth.mutable_data());
      d["depth"] = depth;
      py::array_t<double> K({3, 3});
      auto k = K.mutable_unchecked<2>();
      const double values[3][3] = {{c.intrinsics.fx, 0.0, c.intrinsics.cx},
                                   {0.0, c.intrinsics.fy, c.intrinsics.cy},
                                   {0.0, 0.0, 1.0}};
      for (int r = 0; r < 3; ++r) {
        for (int col = 0; col < 3; ++col) k(r, col) = values[r][col];
      }
      d["K"] = K;
      if (!c.confidence.empty()) {
        py::array_t<float> conf({c.height, c.width});
        std::copy(c.confidence.begin(), c.confidence.end(), conf.mutable_data());
        d["confidence"] = conf;
      }
      if (!c.color.empty()) {
        py::array_t<std::uint8_t> color({c.height, c.width, 3});
        std::copy(c.color.begin(), c.color.end(), color.mutable_data());
        d["color"] = color;
      }
    } else {
      for (const auto& [name, vectors] :
           {std::pair{"points", &c.points}, {"normals", &c.normals}}) {
        if (vectors->empty()) continue;
        py::array_t<double> a({static_cast<py::ssize_t>(vectors->size()), py::ssize_t{3}});
        auto v = a.mutable_unchecked<2>();
        for (size_t i = 0; i < vectors->size(); ++i) {
          for (int j = 0; j < 3; ++j) v(i, j) = (*vectors)[i](j);
        }
        d[name] = a;
      }
    }
    out[py::str(c.serial)] = d;
  }
  return out;
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

/// {"pairs", "cameras", "summary", "ignored_cameras"} as `rigfit evaluate --json` writes them.
py::dict Evaluate(const py::dict& estimated, const py::dict& ground_truth) {
  const PoseMap est = PosesOf(estimated, "estimated");
  const PoseMap gt = PosesOf(ground_truth, "ground_truth");
  std::vector<std::string> missing, ignored;
  for (const auto& entry : gt) {
    if (est.count(entry.first) == 0) missing.push_back(entry.first);
  }
  for (const auto& entry : est) {
    if (gt.count(entry.first) == 0) ignored.push_back(entry.first);
  }
  if (!missing.empty()) {
    std::string list;
    for (const std::string& m : missing) list += (list.empty() ? "" : ", ") + m;
    throw InputError("evaluate: estimated has no pose for camera(s) " + list + " of ground_truth");
  }
  if (gt.empty()) throw InputError("evaluate: ground_truth holds no cameras");
  const RigErrors e = EvaluateRig(est, gt);
  constexpr double kMToMm = 1e3;
  py::list pairs;
  for (const PairError& p : e.pairs) {
    py::dict d;
    d["serial_i"] = p.serial_i;
    d["serial_j"] = p.serial_j;
    d["rotation_deg"] = p.error.rotation_rad * kRadToDeg;
    d["translation_mm"] = p.error.translation_m * kMToMm;
    pairs.append(d);
  }
  py::list cameras;
  for (const auto& [serial, tilt] : e.tilt_rad) {
    py::dict d;
    d["serial"] = serial;
    d["tilt_deg"] = tilt * kRadToDeg;
    cameras.append(d);
  }
  const auto rms_max = [](bool defined, double rms, double max) {
    py::dict d;
    d["rms"] = defined ? py::object(py::float_(rms)) : py::object(py::none());
    d["max"] = defined ? py::object(py::float_(max)) : py::object(py::none());
    return d;
  };
  const bool has_pairs = !e.pairs.empty();
  py::dict summary;
  summary["rotation_deg"] =
      rms_max(has_pairs, e.rms_rotation_rad * kRadToDeg, e.max_rotation_rad * kRadToDeg);
  summary["translation_mm"] =
      rms_max(has_pairs, e.rms_translation_m * kMToMm, e.max_translation_m * kMToMm);
  summary["tilt_deg"] = rms_max(true, e.rms_tilt_rad * kRadToDeg, e.max_tilt_rad * kRadToDeg);
  py::dict out;
  out["ignored_cameras"] = ignored;
  out["cameras"] = cameras;
  out["pairs"] = pairs;
  out["summary"] = summary;
  return out;
}

void SaveCapture(const std::string& path, const py::dict& cameras, bool depth_as_uint16,
                 double depth_scale) {
  const RigCapture capture = CaptureOf(cameras);
  CaptureWriteOptions options;
  options.depth_as_uint16 = depth_as_uint16;
  options.depth_scale = depth_scale;
  WriteCapture(path, capture, options);
}

}  // namespace
}  // namespace rigfit

PYBIND11_MODULE(_rigfit, m) {
  using namespace rigfit;
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
  m.def("load_capture", &LoadCapture, py::arg("path"), py::arg("logger"));
  m.def("evaluate", &Evaluate, py::arg("estimated"), py::arg("ground_truth"));
  m.def("save_capture", &SaveCapture, py::arg("path"), py::arg("cameras"),
        py::arg("depth_as_uint16"), py::arg("depth_scale"));
  m.def("load_extrinsics", &LoadExtrinsics, py::arg("path"), py::arg("logger"));
  m.def("save_extrinsics", &SaveExtrinsics, py::arg("path"), py::arg("extrinsics"),
        py::arg("meta_json"));
}

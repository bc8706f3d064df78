#include "python/convert.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <sstream>

#include "core/errors.h"

namespace rigfit::python {

void Fail(const std::string& where, const std::string& what) {
  throw InputError(where + ": " + what);
}

std::string Shape(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) {
    s += (i ? ", " : "") + std::to_string(a.shape(i));
  }
  return s + (a.ndim() == 1 ? ",)" : ")");
}

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

Pose CheckedPose(const Eigen::Matrix4d& m, const std::string& where) {
  Pose T;
  T.matrix() = m;
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
  return T;
}

Pose PoseOf(const py::handle& value, const std::string& where) {
  const DoubleArray a = Matrix(value, 4, 4, where);
  return CheckedPose(Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(a.data()),
                     where);
}

PoseMap PosesOf(const py::dict& poses, const std::string& name) {
  PoseMap out;
  for (const auto& [key, value] : poses) {
    if (!py::isinstance<py::str>(key)) throw InputError(name + ": keys must be serials (str)");
    const std::string serial = py::cast<std::string>(key);
    if (serial.empty()) throw InputError(name + ": empty serial");
    out[serial] = PoseOf(value, name + ": camera " + serial);
  }
  return out;
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

py::array_t<double> PosesToNumpy(const std::vector<Pose>& poses) {
  py::array_t<double> out({static_cast<py::ssize_t>(poses.size()), py::ssize_t{4}, py::ssize_t{4}});
  auto o = out.mutable_unchecked<3>();
  for (size_t i = 0; i < poses.size(); ++i) {
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) o(i, r, c) = poses[i].matrix()(r, c);
    }
  }
  return out;
}

py::array_t<double> IntrinsicsToK(const PinholeIntrinsics& in) {
  py::array_t<double> K({3, 3});
  auto k = K.mutable_unchecked<2>();
  const double values[3][3] = {{in.fx, 0.0, in.cx}, {0.0, in.fy, in.cy}, {0.0, 0.0, 1.0}};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) k(r, c) = values[r][c];
  }
  return K;
}

py::array_t<double> PointsToNumpy(PointCloud&& points) {
  static_assert(sizeof(Vec3) == 3 * sizeof(double), "a Vec3 must be three packed doubles");
  auto* owner = new PointCloud(std::move(points));
  py::capsule free(owner, [](void* p) { delete static_cast<PointCloud*>(p); });
  return py::array_t<double>({static_cast<py::ssize_t>(owner->size()), py::ssize_t{3}},
                             reinterpret_cast<const double*>(owner->data()), free);
}

namespace {

/// A depth sample in metres as float: NaN where invalid (NaN, +-inf, <= 0), as ReadCapture.
float DepthSample(double z) {
  if (!(z > 0.0 && std::isfinite(z))) return std::numeric_limits<float>::quiet_NaN();
  return static_cast<float>(std::min<double>(z, std::numeric_limits<float>::max()));
}

}  // namespace

template <typename T>
void DepthView::ReadRows(double scale, float* out) const {
  for (int v = 0; v < height_; ++v) {
    const char* row = data_ + v * row_stride_;
    if (col_stride_ == static_cast<py::ssize_t>(sizeof(T))) {
      const T* p = reinterpret_cast<const T*>(row);
      for (int u = 0; u < width_; ++u) *out++ = DepthSample(static_cast<double>(p[u]) * scale);
    } else {
      for (int u = 0; u < width_; ++u) {
        T value;
        std::memcpy(&value, row + u * col_stride_, sizeof(T));
        *out++ = DepthSample(static_cast<double>(value) * scale);
      }
    }
  }
}

DepthView::DepthView(const py::dict& d, const std::string& where) {
  py::array raw = py::array::ensure(d["depth"]);
  if (!raw || raw.ndim() != 2) {
    Fail(where + ": depth",
         "expected a 2-D array (H, W), got " + (raw ? Shape(raw) : std::string("no array")));
  }
  height_ = static_cast<int>(raw.shape(0));
  width_ = static_cast<int>(raw.shape(1));
  if (width_ == 0 || height_ == 0) Fail(where + ": depth", "empty image");
  const bool has_scale = d.contains("depth_scale");
  const py::dtype dtype = raw.dtype();
  if (dtype.kind() == 'u' && dtype.itemsize() == 2) {
    if (!has_scale) Fail(where, "uint16 depth needs \"depth_scale\" (metres per unit)");
    scale_ = py::cast<double>(d["depth_scale"]);
    if (!(std::isfinite(scale_) && scale_ > 0.0)) {
      Fail(where + ": depth_scale", "must be a finite number > 0, got " + std::to_string(scale_));
    }
    kind_ = Kind::kUint16;
    // Another byte order: converted to native first.
    if (!dtype.is(py::dtype::of<std::uint16_t>())) raw = py::array_t<std::uint16_t>::ensure(raw);
  } else if (dtype.kind() == 'f') {
    if (has_scale) Fail(where, "\"depth_scale\" is for uint16 depth; float depth is in metres");
    if (dtype.is(py::dtype::of<float>())) {
      kind_ = Kind::kFloat32;
    } else {
      kind_ = Kind::kFloat64;
      if (!dtype.is(py::dtype::of<double>())) raw = py::array_t<double>::ensure(raw);
    }
  } else {
    Fail(where + ": depth", "expected float32 or float64 metres, or uint16 with depth_scale, got " +
                                std::string(py::str(py::object(dtype))));
  }
  array_ = raw;
  data_ = static_cast<const char*>(array_.data());
  row_stride_ = array_.strides(0);
  col_stride_ = array_.strides(1);
}

std::vector<float> DepthView::Read() const {
  std::vector<float> metres(static_cast<size_t>(width_) * height_);
  switch (kind_) {
    case Kind::kFloat32:
      ReadRows<float>(1.0, metres.data());
      break;
    case Kind::kFloat64:
      ReadRows<double>(1.0, metres.data());
      break;
    case Kind::kUint16:
      ReadRows<std::uint16_t>(scale_, metres.data());
      break;
  }
  return metres;
}

std::vector<std::uint8_t> ColorOf(const py::handle& value, int width, int height,
                                  const std::string& where) {
  const py::array a = py::array::ensure(value);
  if (!a || !a.dtype().is(py::dtype::of<std::uint8_t>()) || a.ndim() != 3 || a.shape(0) != height ||
      a.shape(1) != width || a.shape(2) != 3) {
    Fail(where, "expected uint8 (H, W, 3)");
  }
  std::vector<std::uint8_t> out(static_cast<size_t>(width) * height * 3);
  const auto c = a.unchecked<std::uint8_t, 3>();
  size_t i = 0;
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      for (int k = 0; k < 3; ++k) out[i++] = c(v, u, k);
    }
  }
  return out;
}

Log PythonLog(const py::object& logger) {
  if (logger.is_none()) return {};
  // The Log (and this lambda's copy of the logger) may be destroyed on a library thread
  // without the GIL: the logger is held by a shared owner that takes the GIL to let go of it.
  auto held = std::shared_ptr<py::object>(new py::object(logger), [](py::object* p) {
    py::gil_scoped_acquire gil;
    delete p;
  });
  return {[held](LogLevel level, const std::string& message) {
    py::gil_scoped_acquire gil;
    try {
      const int py_level = level == LogLevel::kDebug ? 10 : level == LogLevel::kInfo ? 20 : 30;
      held->attr("log")(py_level, message);
    } catch (const py::error_already_set&) {
      // A failing handler must not abort the run.
    }
  }};
}

}  // namespace rigfit::python

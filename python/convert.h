// What the parts of rigfit._rigfit share (docs/python.md): numpy arrays and dicts to the
// library's plain structs and back. Input arrays are read where they lie (any strides, native
// dtypes) into the library's structs, the one copy those own; library buffers that already
// have the array's layout (depth images, colour, point clouds) become numpy arrays without a
// copy, owned by a capsule.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "core/log.h"
#include "core/types.h"

namespace rigfit::python {

namespace py = pybind11;

using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

/// Throws InputError "<where>: <what>" (ValueError in Python).
[[noreturn]] void Fail(const std::string& where, const std::string& what);

/// "(2, 3)", "(5,)": the shape of an array for messages.
std::string Shape(const py::array& a);

/// A float64 array of exactly `rows` x `cols` (rows < 0: any), as a C-contiguous array.
DoubleArray Matrix(const py::handle& value, py::ssize_t rows, py::ssize_t cols,
                   const std::string& where);

/// A 4x4 T_world_camera, checked as ReadExtrinsics checks a file's (finite, last row [0, 0,
/// 0, 1], rotation within 1e-3 of orthonormal with det > 0); not re-orthonormalised, so that a
/// pose passes through unchanged. InputError "<where>: ..." otherwise.
Pose CheckedPose(const Eigen::Matrix4d& m, const std::string& where);

/// CheckedPose of a (4, 4) array.
Pose PoseOf(const py::handle& value, const std::string& where);

/// serial -> 4x4, each checked by PoseOf; `name` ("extrinsics") names the dict in messages.
PoseMap PosesOf(const py::dict& poses, const std::string& name);

/// A 4x4 float64 array (numpy's own buffer, written once from the matrix).
py::array_t<double> MatrixToNumpy(const Eigen::Matrix4d& m);

/// serial -> 4x4 float64.
py::dict PosesToDict(const PoseMap& poses);

/// (N, 4, 4) float64, C-contiguous: the poses transposed once from Eigen's column-major
/// matrices into numpy's buffer (the only copy).
py::array_t<double> PosesToNumpy(const std::vector<Pose>& poses);

/// The 3x3 K of pinhole intrinsics.
py::array_t<double> IntrinsicsToK(const PinholeIntrinsics& intrinsics);

/// The vector as a numpy array of `shape` (C order) without a copy: the vector is moved into
/// a capsule that owns it for as long as the array (or a view of it) lives.
template <typename T>
py::array_t<T> VectorToNumpy(std::vector<T>&& values, std::vector<py::ssize_t> shape) {
  auto* owner = new std::vector<T>(std::move(values));
  py::capsule free(owner, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  return py::array_t<T>(std::move(shape), owner->data(), free);
}

/// (N, 3) float64 without a copy (a Vec3 is three packed doubles).
py::array_t<double> PointsToNumpy(PointCloud&& points);

/// A depth image handed in from Python: checked (rank, dtype, depth_scale) with the GIL held,
/// read into float metres with NaN where invalid (NaN, +-inf, <= 0, 0 in uint16) by Read(),
/// which touches no Python object and so runs without the GIL too. Native float32, float64 and
/// uint16 arrays are read where they lie, with their strides (no copy before Read's); other
/// float or uint16 byte orders are converted first. Holds a reference to the array: destroy it
/// with the GIL held.
class DepthView {
 public:
  /// d["depth"] with d["depth_scale"] (metres per unit; uint16 only); `where` names the input
  /// in messages ("cameras: camera a").
  DepthView(const py::dict& d, const std::string& where);
  int width() const { return width_; }
  int height() const { return height_; }
  std::vector<float> Read() const;

 private:
  enum class Kind { kFloat32, kFloat64, kUint16 };
  /// The image's samples of type T, each times `scale`, as DepthSample metres into `out`
  /// (width x height, row-major).
  template <typename T>
  void ReadRows(double scale, float* out) const;

  py::array array_;
  Kind kind_ = Kind::kFloat32;
  const char* data_ = nullptr;
  py::ssize_t row_stride_ = 0;  ///< bytes
  py::ssize_t col_stride_ = 0;  ///< bytes
  int width_ = 0;
  int height_ = 0;
  double scale_ = 1.0;
};

/// A (height, width, 3) uint8 colour image read into a row-major vector (one copy, any
/// strides); InputError "<where>: expected uint8 (H, W, 3)" otherwise.
std::vector<std::uint8_t> ColorOf(const py::handle& value, int width, int height,
                                  const std::string& where);

/// The Python logger as a Log: callable from the library's threads (takes the GIL); a failing
/// handler is ignored. None: no log.
Log PythonLog(const py::object& logger);

}  // namespace rigfit::python

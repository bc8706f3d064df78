// HDF5 files written with the C API for the io_* tests, to make inputs that rigfit's own
// writer never would (bursts, wrong types, broken layouts).
#pragma once

#include <gtest/gtest.h>
#include <hdf5.h>

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace rigfit::io_test {

template <typename T>
hid_t NativeType();
template <>
inline hid_t NativeType<float>() {
  return H5T_NATIVE_FLOAT;
}
template <>
inline hid_t NativeType<double>() {
  return H5T_NATIVE_DOUBLE;
}
template <>
inline hid_t NativeType<std::uint16_t>() {
  return H5T_NATIVE_UINT16;
}
template <>
inline hid_t NativeType<std::uint8_t>() {
  return H5T_NATIVE_UINT8;
}
template <>
inline hid_t NativeType<std::int32_t>() {
  return H5T_NATIVE_INT32;
}

/// Writes HDF5 files with the C API, to make inputs that rigfit's own writer never would.
class H5Builder {
 public:
  explicit H5Builder(const std::string& path)
      : file_(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT)) {
    EXPECT_GE(file_, 0);
  }
  ~H5Builder() { H5Fclose(file_); }
  H5Builder(const H5Builder&) = delete;
  H5Builder& operator=(const H5Builder&) = delete;

  /// format = "rig-capture" and version = 1 (or the values given).
  void Root(const std::string& format = "rig-capture", int version = 1,
            bool variable_length = false) {
    StringAttribute("/", "format", format, variable_length);
    NumberAttribute("/", "version", H5T_STD_I64LE, version);
  }

  void StringAttribute(const std::string& object, const char* name, const std::string& value,
                       bool variable_length) {
    const hid_t type = H5Tcopy(H5T_C_S1);
    H5Tset_size(type, variable_length ? H5T_VARIABLE : value.size());
    const hid_t space = H5Screate(H5S_SCALAR);
    const hid_t o = H5Oopen(file_, object.c_str(), H5P_DEFAULT);
    const hid_t a = H5Acreate2(o, name, type, space, H5P_DEFAULT, H5P_DEFAULT);
    const char* text = value.c_str();
    EXPECT_GE(variable_length ? H5Awrite(a, type, &text) : H5Awrite(a, type, text), 0);
    H5Aclose(a);
    H5Oclose(o);
    H5Sclose(space);
    H5Tclose(type);
  }

  template <typename T>
  void NumberAttribute(const std::string& object, const char* name, hid_t file_type, T value) {
    const hid_t space = H5Screate(H5S_SCALAR);
    const hid_t o = H5Oopen(file_, object.c_str(), H5P_DEFAULT);
    const hid_t a = H5Acreate2(o, name, file_type, space, H5P_DEFAULT, H5P_DEFAULT);
    EXPECT_GE(H5Awrite(a, NativeType<T>(), &value), 0);
    H5Aclose(a);
    H5Oclose(o);
    H5Sclose(space);
  }

  void Group(const std::string& name) {
    const hid_t lcpl = LinkCreation();
    EXPECT_GE(H5Gclose(H5Gcreate2(file_, name.c_str(), lcpl, H5P_DEFAULT, H5P_DEFAULT)), 0);
    H5Pclose(lcpl);
  }

  template <typename T>
  void Dataset(const std::string& name, hid_t file_type, const std::vector<hsize_t>& dims,
               const std::vector<T>& values) {
    const hid_t lcpl = LinkCreation();
    const hid_t space = H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr);
    const hid_t d =
        H5Dcreate2(file_, name.c_str(), file_type, space, lcpl, H5P_DEFAULT, H5P_DEFAULT);
    EXPECT_GE(d, 0) << name;
    if (!values.empty()) {
      EXPECT_GE(H5Dwrite(d, NativeType<T>(), H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()), 0);
    }
    H5Dclose(d);
    H5Sclose(space);
    H5Pclose(lcpl);
  }

  void Intrinsics(const std::string& camera, const std::vector<double>& K) {
    Dataset("/cameras/" + camera + "/intrinsics", H5T_IEEE_F64LE, {3, 3}, K);
  }

  /// A valid 4x3 float32 depth camera, 2 m everywhere.
  void DepthCamera(const std::string& serial) {
    Dataset("/cameras/" + serial + "/depth", H5T_IEEE_F32LE, {3, 4}, std::vector<float>(12, 2.0f));
    Intrinsics(serial, {5.0, 0.0, 1.5, 0.0, 5.0, 1.0, 0.0, 0.0, 1.0});
  }

  hid_t file() const { return file_; }

 private:
  static hid_t LinkCreation() {
    const hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
    H5Pset_create_intermediate_group(lcpl, 1);
    return lcpl;
  }

  hid_t file_;
};

/// A capture of two depth bursts. Camera "cam": F = 3 frames of a 2x3 float32 image
/// (frame-major, pixel i of frame f at f * 6 + i) with invalid samples (NaN, 0, -1, +-inf),
/// K = [5 0 1; 0 5 1; 0 0 1]. Camera "mm": the same idea as uint16 millimetres, 2 frames of
/// 1x2, 0 invalid, K = [5 0 1; 0 5 0.5; 0 0 1].
inline void WriteBurstCapture(const std::string& path) {
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  constexpr float kInf = std::numeric_limits<float>::infinity();
  H5Builder h5(path);
  h5.Root();
  const std::vector<float> frames = {
      1, kNaN, kNaN, 0,  kInf,  7,  // frame 0
      2, 1,    kNaN, -1, 2,     7,  // frame 1
      3, 4,    kNaN, 5,  -kInf, 1,  // frame 2
  };
  h5.Dataset("/cameras/cam/depth", H5T_IEEE_F32LE, {3, 2, 3}, frames);
  h5.Intrinsics("cam", {5.0, 0.0, 1.0, 0.0, 5.0, 1.0, 0.0, 0.0, 1.0});
  h5.Dataset("/cameras/mm/depth", H5T_STD_U16LE, {2, 1, 2},
             std::vector<std::uint16_t>{1000, 0, 3000, 0});
  h5.NumberAttribute("/cameras/mm/depth", "depth_scale", H5T_IEEE_F64LE, 0.001);
  h5.Intrinsics("mm", {5.0, 0.0, 1.0, 0.0, 5.0, 0.5, 0.0, 0.0, 1.0});
}

}  // namespace rigfit::io_test

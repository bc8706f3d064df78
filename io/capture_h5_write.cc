// Writing rig captures (io/capture_h5.h): the contract checked first, datasets chunked and
// compressed, the file replaced atomically.
#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <set>
#include <string>
#include <vector>

#include "core/errors.h"
#include "io/atomic_file.h"
#include "io/capture_h5.h"
#include "io/capture_h5_internal.h"
#include "io/hdf5_internal.h"

namespace rigfit {
namespace h5 {
namespace {

/// Chunks of about this many elements (1 MiB of float32) when compressing.
constexpr hsize_t kChunkElements = hsize_t{1} << 18;

/// Checks that capture can be written as the contract, naming path and camera otherwise.
void CheckWritable(const RigCapture& capture, const CaptureWriteOptions& options,
                   const std::string& path) {
  const Context file{path + ": cannot write", ""};
  if (capture.cameras.empty()) file.Fail("", "no cameras");
  if (options.depth_as_uint16 && !(options.depth_scale > 0 && std::isfinite(options.depth_scale))) {
    file.Fail("depth_scale", "must be > 0 and finite");
  }
  std::set<std::string> serials;
  for (const CameraCapture& camera : capture.cameras) {
    const Context where{path + ": cannot write", camera.serial};
    if (camera.serial.empty() || camera.serial == "." ||
        camera.serial.find('/') != std::string::npos) {
      where.Fail("", "serial must be a non-empty name without '/'");
    }
    if (!serials.insert(camera.serial).second) where.Fail("", "duplicate serial");
    if (camera.HasDepth() == camera.HasPoints()) {
      where.Fail("", "needs either depth or points (exactly one)");
    }
    if (camera.HasDepth()) {
      const size_t pixels = static_cast<size_t>(std::max(camera.width, 0)) *
                            static_cast<size_t>(std::max(camera.height, 0));
      if (camera.width <= 0 || camera.height <= 0 || camera.depth_m.size() != pixels) {
        where.Fail("depth", std::to_string(camera.depth_m.size()) + " values for " +
                                std::to_string(camera.width) + "x" + std::to_string(camera.height));
      }
      const PinholeIntrinsics& k = camera.intrinsics;
      Mat3 K;
      K << k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1;
      const std::string problem = IntrinsicsProblem(K, camera.width, camera.height);
      if (!problem.empty()) where.Fail("intrinsics", problem);
      if (!camera.confidence.empty() && camera.confidence.size() != pixels) {
        where.Fail("confidence", "size does not match the depth image");
      }
      if (camera.baseline_m != 0.0 &&
          !(camera.baseline_m > 0.0 && std::isfinite(camera.baseline_m))) {
        where.Fail("baseline_m", "must be > 0 and finite (0: not recorded)");
      }
      if (!camera.color.empty() && camera.color.size() != 3 * pixels) {
        where.Fail("color", "size does not match the depth image (3 bytes per pixel)");
      }
      if (!camera.normals.empty()) where.Fail("normals", "only allowed beside points");
      // What ReadCapture would reject is not written.
      CheckDepthUnit(camera.depth_m, where);
    } else {
      if (!camera.normals.empty() && camera.normals.size() != camera.points.size()) {
        where.Fail("normals", "size does not match points");
      }
      CheckVectors(camera.points, "points", kMaxRangeM, where);
      CheckVectors(camera.normals, "normals", std::numeric_limits<double>::infinity(), where);
      if (!camera.confidence.empty() || !camera.color.empty()) {
        where.Fail("", "confidence and color are only allowed beside depth");
      }
    }
  }
}

bool DeflateAvailable() {
  unsigned int config = 0;
  return H5Zfilter_avail(H5Z_FILTER_DEFLATE) > 0 &&
         H5Zget_filter_info(H5Z_FILTER_DEFLATE, &config) >= 0 &&
         (config & H5Z_FILTER_CONFIG_ENCODE_ENABLED) != 0;
}

/// A sample type's HDF5 types: in the file (little-endian, as the format fixes it) and in memory.
struct SampleTypes {
  hid_t file;    ///< the type the file stores
  hid_t memory;  ///< the type of the samples in memory
};
SampleTypes TypesOf(const float*) { return {H5T_IEEE_F32LE, H5T_NATIVE_FLOAT}; }
SampleTypes TypesOf(const double*) { return {H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE}; }
SampleTypes TypesOf(const std::uint16_t*) { return {H5T_STD_U16LE, H5T_NATIVE_UINT16}; }
SampleTypes TypesOf(const std::uint8_t*) { return {H5T_STD_U8LE, H5T_NATIVE_UINT8}; }

/// Writes one dataset of `data`'s sample type (TypesOf); large ones chunked (whole rows) and
/// compressed with shuffle + deflate.
template <typename T>
void WriteDataset(hid_t group, const std::string& name, const std::vector<hsize_t>& dims,
                  const T* data, const Context& where) {
  const auto [file_type, memory_type] = TypesOf(data);
  const H5Id space(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr), H5Sclose);
  const H5Id dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  hsize_t row_elements = 1;
  for (size_t i = 1; i < dims.size(); ++i) row_elements *= dims[i];
  if (dims[0] * row_elements > 64 && DeflateAvailable()) {
    std::vector<hsize_t> chunk = dims;
    chunk[0] = std::clamp<hsize_t>(kChunkElements / row_elements, 1, dims[0]);
    H5Pset_chunk(dcpl.get(), static_cast<int>(chunk.size()), chunk.data());
    H5Pset_shuffle(dcpl.get());
    H5Pset_deflate(dcpl.get(), 1);  // level 1: most of the gain of higher levels, fast
  }
  const H5Id dataset(
      H5Dcreate2(group, name.c_str(), file_type, space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT),
      H5Dclose);
  if (!dataset.valid() ||
      H5Dwrite(dataset.get(), memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) {
    where.Fail(name, "cannot write dataset");
  }
}

/// A scalar float64 dataset (the contract's baseline_m).
void WriteScalarDataset(hid_t group, const char* name, double value, const Context& where) {
  const H5Id space(H5Screate(H5S_SCALAR), H5Sclose);
  const H5Id dataset(
      H5Dcreate2(group, name, H5T_IEEE_F64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
      H5Dclose);
  if (!dataset.valid() ||
      H5Dwrite(dataset.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, &value) < 0) {
    where.Fail(name, "cannot write dataset");
  }
}

void WriteScalarAttribute(hid_t object, const char* name, hid_t file_type, hid_t memory_type,
                          const void* value, const Context& where) {
  const H5Id space(H5Screate(H5S_SCALAR), H5Sclose);
  const H5Id attribute(H5Acreate2(object, name, file_type, space.get(), H5P_DEFAULT, H5P_DEFAULT),
                       H5Aclose);
  if (!attribute.valid() || H5Awrite(attribute.get(), memory_type, value) < 0) {
    where.Fail(std::string("attribute ") + name, "cannot write");
  }
}

std::vector<float> ToFloat32(const PointCloud& vectors) {
  std::vector<float> values;
  values.reserve(3 * vectors.size());
  for (const Vec3& v : vectors) {
    for (int i = 0; i < 3; ++i) values.push_back(static_cast<float>(v[i]));
  }
  return values;
}

/// uint16 depth units round(z / scale); invalid (NaN, <= 0, inf) becomes 0.
std::vector<std::uint16_t> ToUint16Depth(const std::vector<float>& depth_m, double scale,
                                         const Context& where) {
  std::vector<std::uint16_t> units(depth_m.size(), 0);
  for (size_t i = 0; i < depth_m.size(); ++i) {
    const float z = depth_m[i];
    if (!(z > 0.0f && std::isfinite(z))) continue;
    const double u = std::round(z / scale);
    if (u > std::numeric_limits<std::uint16_t>::max()) {
      where.Fail("depth", "value " + std::to_string(z) + " m at pixel " + std::to_string(i) +
                              " exceeds the uint16 range with depth_scale " +
                              std::to_string(scale));
    }
    units[i] = static_cast<std::uint16_t>(u);
  }
  return units;
}

void WriteCamera(hid_t cameras, const CameraCapture& camera, const CaptureWriteOptions& options,
                 const Context& where) {
  const H5Id group(
      H5Gcreate2(cameras, camera.serial.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
  if (!group.valid()) where.Fail("", "cannot create group");
  if (camera.HasPoints()) {
    const std::vector<hsize_t> dims = {camera.points.size(), 3};
    const std::vector<float> points = ToFloat32(camera.points);
    WriteDataset(group.get(), "points", dims, points.data(), where);
    if (!camera.normals.empty()) {
      const std::vector<float> normals = ToFloat32(camera.normals);
      WriteDataset(group.get(), "normals", dims, normals.data(), where);
    }
    return;
  }
  const std::vector<hsize_t> image = {static_cast<hsize_t>(camera.height),
                                      static_cast<hsize_t>(camera.width)};
  if (options.depth_as_uint16) {
    const std::vector<std::uint16_t> units =
        ToUint16Depth(camera.depth_m, options.depth_scale, where);
    WriteDataset(group.get(), "depth", image, units.data(), where);
    const H5Id depth(H5Dopen2(group.get(), "depth", H5P_DEFAULT), H5Dclose);
    WriteScalarAttribute(depth.get(), "depth_scale", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE,
                         &options.depth_scale, where);
  } else {
    WriteDataset(group.get(), "depth", image, camera.depth_m.data(), where);
  }
  const PinholeIntrinsics& k = camera.intrinsics;
  const double K[9] = {k.fx, 0.0, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0};
  WriteDataset(group.get(), "intrinsics", {3, 3}, K, where);
  if (!camera.confidence.empty()) {
    WriteDataset(group.get(), "confidence", image, camera.confidence.data(), where);
  }
  if (!camera.color.empty()) {
    WriteDataset(group.get(), "color", {image[0], image[1], 3}, camera.color.data(), where);
  }
  if (camera.baseline_m > 0.0)
    WriteScalarDataset(group.get(), "baseline_m", camera.baseline_m, where);
}

void WriteFile(const std::string& tmp_path, const RigCapture& capture,
               const CaptureWriteOptions& options, const std::string& path) {
  const Context where{path, ""};
  const H5Id fapl = StrongCloseAccess();
  H5Id file(H5Fcreate(tmp_path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl.get()), H5Fclose);
  if (!file.valid()) where.Fail("", "cannot create HDF5 file '" + tmp_path + "'");

  const H5Id string_type(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(string_type.get(), std::char_traits<char>::length(kFormat));
  H5Tset_strpad(string_type.get(), H5T_STR_NULLPAD);
  WriteScalarAttribute(file.get(), "format", string_type.get(), string_type.get(), kFormat, where);
  const long long version = kVersion;
  WriteScalarAttribute(file.get(), "version", H5T_STD_I32LE, H5T_NATIVE_LLONG, &version, where);

  {
    const H5Id cameras(H5Gcreate2(file.get(), "cameras", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                       H5Gclose);
    if (!cameras.valid()) where.Fail("/cameras", "cannot create group");
    for (const CameraCapture& camera : capture.cameras) {
      WriteCamera(cameras.get(), camera, options, {path, camera.serial});
    }
  }
  if (H5Fclose(file.release()) < 0) where.Fail("", "cannot finish writing '" + tmp_path + "'");
}

}  // namespace
}  // namespace h5

void WriteCapture(const std::string& path, const RigCapture& capture,
                  const CaptureWriteOptions& options) {
  h5::SilenceHdf5Errors();
  h5::CheckWritable(capture, options, path);
  WriteFileAtomically(
      path, [&](const std::string& tmp_path) { h5::WriteFile(tmp_path, capture, options, path); });
}

}  // namespace rigfit

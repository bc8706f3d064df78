// Reading rig captures (io/capture_h5.h): the root attributes, each camera's datasets under
// the contract's rules, bursts, and the in-memory image.
#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "core/errors.h"
#include "io/capture_h5.h"
#include "io/capture_h5_internal.h"
#include "io/hdf5_internal.h"

namespace rigfit {
namespace h5 {
namespace {

/// Skew and last-row tolerance of K, relative to fx (exact zeros are expected).
constexpr double kIntrinsicsTolerance = 1e-9;
/// Smallest focal length accepted, pixels: below it a pixel spans more than 45 degrees, and
/// unprojection (x = z (u - cx) / fx) would blow up towards infinity.
constexpr double kMinFocalPx = 1.0;

/// A capture whose median valid depth is beyond this is in another unit (millimetres read as
/// metres, a wrong depth_scale): no depth camera sees a room from 100 m away.
constexpr double kMaxMedianDepthM = 100.0;

}  // namespace

std::string IntrinsicsProblem(const Mat3& K, int width, int height) {
  std::ostringstream problem;
  if (!K.allFinite()) return "entries must be finite";
  if (!(K(0, 0) > 0.0 && K(1, 1) > 0.0)) {
    problem << "fx and fy must be > 0, got " << K(0, 0) << " and " << K(1, 1);
    return problem.str();
  }
  if (K(0, 0) < kMinFocalPx || K(1, 1) < kMinFocalPx) {
    problem << "fx and fy must be at least " << kMinFocalPx << " pixel, got " << K(0, 0) << " and "
            << K(1, 1);
    return problem.str();
  }
  const double tolerance = kIntrinsicsTolerance * std::max(K(0, 0), K(1, 1));
  if (std::abs(K(0, 1)) > tolerance || std::abs(K(1, 0)) > tolerance) {
    return "skew must be 0 (K[0][1] and K[1][0])";
  }
  if (std::abs(K(2, 0)) > kIntrinsicsTolerance || std::abs(K(2, 1)) > kIntrinsicsTolerance ||
      std::abs(K(2, 2) - 1.0) > kIntrinsicsTolerance) {
    return "last row must be [0, 0, 1]";
  }
  // The principal point of a real camera lies on (or close to) its image.
  if (K(0, 2) < -0.5 * width || K(0, 2) > 1.5 * width || K(1, 2) < -0.5 * height ||
      K(1, 2) > 1.5 * height) {
    problem << "principal point (" << K(0, 2) << ", " << K(1, 2)
            << ") does not match the image size " << width << "x" << height;
    return problem.str();
  }
  return "";
}

void CheckDepthUnit(const std::vector<float>& metres, const Context& where) {
  std::vector<float> valid;
  valid.reserve(metres.size());
  for (const float z : metres) {
    if (std::isfinite(z)) valid.push_back(z);
  }
  if (valid.empty()) return;
  const auto middle = valid.begin() + static_cast<std::ptrdiff_t>(valid.size() / 2);
  std::nth_element(valid.begin(), middle, valid.end());
  if (*middle > kMaxMedianDepthM) {
    std::ostringstream what;
    what << "median valid depth " << *middle << " m is beyond " << kMaxMedianDepthM
         << " m: depth must be float metres, or uint16 with depth_scale in metres per unit";
    where.Fail("depth", what.str());
  }
}

void CheckVectors(const PointCloud& vectors, const std::string& name, double max_norm,
                  const Context& where) {
  for (size_t i = 0; i < vectors.size(); ++i) {
    if (!vectors[i].allFinite()) where.Fail(name, "row " + std::to_string(i) + " is not finite");
    if (vectors[i].norm() > max_norm) {
      std::ostringstream what;
      what << "row " << i << " has length " << vectors[i].norm() << ", beyond " << max_norm
           << (name == "points" ? " m from the camera: points must be in metres" : "");
      where.Fail(name, what.str());
    }
  }
}

namespace {

// ---------------------------------------------------------------------------------------------
// Root attributes.

std::string ReadStringAttribute(hid_t attribute, const Context& where, const std::string& name) {
  const H5Id type(H5Aget_type(attribute), H5Tclose);
  const H5Id space(H5Aget_space(attribute), H5Sclose);
  if (H5Tget_class(type.get()) != H5T_STRING) {
    where.Fail("root attribute '" + name + "'",
               "expected a string, got " + DescribeType(type.get()));
  }
  if (H5Sget_simple_extent_npoints(space.get()) != 1) {
    where.Fail("root attribute '" + name + "'", "expected a single string");
  }
  const H5Id memory_type(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_cset(memory_type.get(), H5Tget_cset(type.get()));
  std::string value;
  if (H5Tis_variable_str(type.get()) > 0) {
    H5Tset_size(memory_type.get(), H5T_VARIABLE);
    char* text = nullptr;
    if (H5Aread(attribute, memory_type.get(), &text) < 0) {
      where.Fail("root attribute '" + name + "'", "cannot read");
    }
    if (text != nullptr) value = text;
    H5free_memory(text);
  } else {
    const size_t size = H5Tget_size(type.get());
    H5Tset_size(memory_type.get(), size + 1);  // room for the terminating NUL
    H5Tset_strpad(memory_type.get(), H5T_STR_NULLTERM);
    std::vector<char> text(size + 1, '\0');
    if (H5Aread(attribute, memory_type.get(), text.data()) < 0) {
      where.Fail("root attribute '" + name + "'", "cannot read");
    }
    value = text.data();
    while (!value.empty() && value.back() == ' ') value.pop_back();  // space padding
  }
  return value;
}

void CheckRootAttributes(hid_t file, const Context& where) {
  if (H5Aexists(file, "format") <= 0) {
    where.Fail("", "missing root attribute 'format' (expected \"rig-capture\")");
  }
  const H5Id format(H5Aopen(file, "format", H5P_DEFAULT), H5Aclose);
  const std::string value = ReadStringAttribute(format.get(), where, "format");
  if (value != kFormat) {
    where.Fail("root attribute 'format'", "expected \"rig-capture\", got \"" + value + "\"");
  }
  if (H5Aexists(file, "version") <= 0) where.Fail("", "missing root attribute 'version'");
  const H5Id version(H5Aopen(file, "version", H5P_DEFAULT), H5Aclose);
  const H5Id type(H5Aget_type(version.get()), H5Tclose);
  const H5Id space(H5Aget_space(version.get()), H5Sclose);
  if (H5Tget_class(type.get()) != H5T_INTEGER || H5Sget_simple_extent_npoints(space.get()) != 1) {
    where.Fail("root attribute 'version'", "expected a single integer");
  }
  long long number = 0;
  if (H5Aread(version.get(), H5T_NATIVE_LLONG, &number) < 0) {
    where.Fail("root attribute 'version'", "cannot read");
  }
  if (number != kVersion) {
    where.Fail("root attribute 'version'",
               "unsupported version " + std::to_string(number) + " (this rigfit reads 1)");
  }
}

// ---------------------------------------------------------------------------------------------
// Cameras.

/// Per-pixel median of the valid (non-NaN) samples of F frames of n pixels; NaN if none.
/// For an even count the median is the mean of the two middle samples.
std::vector<float> BurstMedian(const std::vector<float>& frames, size_t num_frames, size_t n) {
  std::vector<float> median(n, std::numeric_limits<float>::quiet_NaN());
  std::vector<float> samples;
  samples.reserve(num_frames);
  for (size_t i = 0; i < n; ++i) {
    samples.clear();
    for (size_t f = 0; f < num_frames; ++f) {
      const float z = frames[f * n + i];
      if (!std::isnan(z)) samples.push_back(z);
    }
    if (samples.empty()) continue;
    const size_t mid = samples.size() / 2;
    std::nth_element(samples.begin(), samples.begin() + mid, samples.end());
    if (samples.size() % 2 == 1) {
      median[i] = samples[mid];
    } else {
      const float upper = samples[mid];
      const float lower = *std::max_element(samples.begin(), samples.begin() + mid);
      median[i] = 0.5f * (lower + upper);
    }
  }
  return median;
}

double ReadDepthScale(const Dataset& depth, const Context& where) {
  const std::string field = "depth attribute depth_scale";
  if (H5Aexists(depth.id.get(), "depth_scale") <= 0) {
    where.Fail(field, "missing (required for uint16 depth: metres per unit, e.g. 0.001)");
  }
  const H5Id attribute(H5Aopen(depth.id.get(), "depth_scale", H5P_DEFAULT), H5Aclose);
  const H5Id type(H5Aget_type(attribute.get()), H5Tclose);
  const H5Id space(H5Aget_space(attribute.get()), H5Sclose);
  const H5T_class_t type_class = H5Tget_class(type.get());
  if ((type_class != H5T_FLOAT && type_class != H5T_INTEGER) ||
      H5Sget_simple_extent_npoints(space.get()) != 1) {
    where.Fail(field, "expected a single number");
  }
  double scale = 0.0;
  if (H5Aread(attribute.get(), H5T_NATIVE_DOUBLE, &scale) < 0) where.Fail(field, "cannot read");
  if (!(scale > 0.0 && std::isfinite(scale))) {
    where.Fail(field, "must be > 0 and finite, got " + std::to_string(scale));
  }
  return scale;
}

/// A depth sample in metres as float: NaN where invalid (NaN, +-inf, <= 0). Values beyond the
/// float range (possible in float64 or scaled uint16) become the largest float rather than an
/// undefined conversion; CheckDepthRange rejects them.
float DepthSample(double z) {
  if (!(z > 0.0 && std::isfinite(z))) return std::numeric_limits<float>::quiet_NaN();
  return static_cast<float>(std::min<double>(z, std::numeric_limits<float>::max()));
}

/// Depth samples in metres, NaN where invalid (NaN, +-inf, <= 0).
template <typename T>
std::vector<float> ReadFloatDepth(const Dataset& depth, hid_t memory_type, const Context& where) {
  const std::vector<T> raw = ReadAll<T>(depth, memory_type, where);
  std::vector<float> metres(raw.size());
  for (size_t i = 0; i < raw.size(); ++i) metres[i] = DepthSample(raw[i]);
  return metres;
}

/// CheckDepthUnit, then sensor glitches: finite depths beyond kMaxRangeM become invalid (NaN)
/// and are counted in camera.glitch_depth_samples.
void DropDepthGlitches(std::vector<float>& metres, CameraCapture& camera, const Context& where) {
  CheckDepthUnit(metres, where);
  for (float& z : metres) {
    if (std::isfinite(z) && z > kMaxRangeM) {
      z = std::numeric_limits<float>::quiet_NaN();
      ++camera.glitch_depth_samples;
    }
  }
}

/// Reads the depth of a camera; with `frames`, every frame of a burst too ([F, H, W] metres,
/// the same samples the median is taken of).
void ReadDepth(hid_t group, CameraCapture& camera, const Context& where,
               std::vector<float>* frames) {
  const Dataset depth = OpenDataset(group, "depth", where);
  if (depth.dims.size() != 2 && depth.dims.size() != 3) {
    where.Fail("depth", "expected rank 2 or 3, got " + std::to_string(depth.dims.size()) + " " +
                            DescribeDims(depth.dims));
  }
  const size_t rank = depth.dims.size();
  const size_t num_frames = rank == 3 ? depth.dims[0] : 1;
  camera.height = static_cast<int>(depth.dims[rank - 2]);
  camera.width = static_cast<int>(depth.dims[rank - 1]);

  std::vector<float> metres;
  const size_t type_size = H5Tget_size(depth.type.get());
  if (depth.type_class == H5T_FLOAT && type_size == 4) {
    metres = ReadFloatDepth<float>(depth, H5T_NATIVE_FLOAT, where);
  } else if (depth.type_class == H5T_FLOAT && type_size == 8) {
    metres = ReadFloatDepth<double>(depth, H5T_NATIVE_DOUBLE, where);
  } else if (depth.type_class == H5T_INTEGER && type_size == 2 &&
             H5Tget_sign(depth.type.get()) == H5T_SGN_NONE) {
    const double scale = ReadDepthScale(depth, where);
    const std::vector<std::uint16_t> raw = ReadAll<std::uint16_t>(depth, H5T_NATIVE_UINT16, where);
    metres.resize(raw.size());
    for (size_t i = 0; i < raw.size(); ++i) metres[i] = DepthSample(raw[i] * scale);  // 0: NaN
  } else {
    where.Fail("depth",
               "expected float32, float64 or uint16, got " + DescribeType(depth.type.get()));
  }
  const size_t pixels = static_cast<size_t>(camera.width) * camera.height;
  DropDepthGlitches(metres, camera, where);
  if (frames != nullptr) *frames = metres;
  camera.depth_m = num_frames == 1 ? std::move(metres) : BurstMedian(metres, num_frames, pixels);
}

void ReadIntrinsics(hid_t group, CameraCapture& camera, const Context& where) {
  if (H5Lexists(group, "intrinsics", H5P_DEFAULT) <= 0) {
    where.Fail("intrinsics", "missing (required beside depth)");
  }
  const Dataset d = OpenDataset(group, "intrinsics", where);
  ExpectFloat(d, where);
  ExpectRank(d, 2, where);
  if (d.dims[0] != 3 || d.dims[1] != 3) {
    where.Fail("intrinsics", "expected shape [3, 3], got " + DescribeDims(d.dims));
  }
  const std::vector<double> k = ReadAll<double>(d, H5T_NATIVE_DOUBLE, where);
  const Mat3 K = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(k.data());
  const std::string problem = IntrinsicsProblem(K, camera.width, camera.height);
  if (!problem.empty()) where.Fail("intrinsics", problem);
  camera.intrinsics = {K(0, 0), K(1, 1), K(0, 2), K(1, 2)};
}

/// An [N, 3] float dataset of finite values (points, normals), each no longer than max_norm.
PointCloud ReadVectors(hid_t group, const std::string& name, double max_norm,
                       const Context& where) {
  const Dataset d = OpenDataset(group, name, where);
  ExpectFloat(d, where);
  ExpectRank(d, 2, where);
  if (d.dims[1] != 3) where.Fail(name, "expected shape [N, 3], got " + DescribeDims(d.dims));
  const std::vector<double> raw = ReadAll<double>(d, H5T_NATIVE_DOUBLE, where);
  PointCloud vectors(d.dims[0]);
  for (size_t i = 0; i < vectors.size(); ++i) {
    vectors[i] = Vec3(raw[3 * i], raw[3 * i + 1], raw[3 * i + 2]);
  }
  CheckVectors(vectors, name, max_norm, where);
  return vectors;
}

void ExpectImageShape(const Dataset& d, const CameraCapture& camera, size_t channels,
                      const Context& where) {
  std::vector<hsize_t> expected = {static_cast<hsize_t>(camera.height),
                                   static_cast<hsize_t>(camera.width)};
  if (channels > 0) expected.push_back(channels);
  if (d.dims != expected) {
    where.Fail(d.name, "expected shape " + DescribeDims(expected) + " (the depth image), got " +
                           DescribeDims(d.dims));
  }
}

void ReadConfidence(hid_t group, CameraCapture& camera, const Context& where) {
  const Dataset d = OpenDataset(group, "confidence", where);
  if (d.type_class != H5T_FLOAT && d.type_class != H5T_INTEGER) {
    where.Fail("confidence", "expected a numeric type, got " + DescribeType(d.type.get()));
  }
  ExpectImageShape(d, camera, 0, where);
  camera.confidence = ReadAll<float>(d, H5T_NATIVE_FLOAT, where);
  for (size_t i = 0; i < camera.confidence.size(); ++i) {
    if (!std::isfinite(camera.confidence[i])) {
      where.Fail("confidence", "value at pixel " + std::to_string(i) + " is not finite");
    }
  }
}

void ReadColor(hid_t group, CameraCapture& camera, const Context& where) {
  const Dataset d = OpenDataset(group, "color", where);
  if (d.type_class != H5T_INTEGER || H5Tget_size(d.type.get()) != 1 ||
      H5Tget_sign(d.type.get()) != H5T_SGN_NONE) {
    where.Fail("color", "expected uint8, got " + DescribeType(d.type.get()));
  }
  ExpectImageShape(d, camera, 3, where);
  camera.color = ReadAll<std::uint8_t>(d, H5T_NATIVE_UINT8, where);
}

/// camera.baseline_m = baseline_m when it is finite and > 0; `where` fails otherwise.
void SetBaseline(CameraCapture& camera, double baseline_m, const Context& where) {
  if (!(baseline_m > 0.0 && std::isfinite(baseline_m))) {
    where.Fail("baseline_m", "must be finite and > 0, got " + std::to_string(baseline_m));
  }
  camera.baseline_m = baseline_m;
}

/// The optional stereo baseline: a float scalar (or a one-element array), finite and > 0.
void ReadBaseline(hid_t group, CameraCapture& camera, const Context& where) {
  const Dataset d = OpenDataset(group, "baseline_m", where);
  ExpectFloat(d, where);
  if (d.Elements() != 1) {
    where.Fail("baseline_m", "expected a scalar, got shape " + DescribeDims(d.dims));
  }
  SetBaseline(camera, ReadAll<double>(d, H5T_NATIVE_DOUBLE, where)[0], where);
}

/// Reads one camera; with `frames`, every frame of its depth too (ReadDepth).
CameraCapture ReadCamera(hid_t cameras, const std::string& serial, const std::string& file,
                         std::vector<float>* frames = nullptr) {
  const Context where{file, serial};
  const H5Id group = OpenChild(cameras, serial, where, "");
  if (H5Iget_type(group.get()) != H5I_GROUP) where.Fail("", "expected a group under /cameras");
  const auto has = [&](const char* name) { return H5Lexists(group.get(), name, H5P_DEFAULT) > 0; };
  const bool has_depth = has("depth");
  const bool has_points = has("points");
  if (has_depth && has_points) {
    where.Fail("", "has both depth and points (a camera has one or the other)");
  }
  if (!has_depth && !has_points) where.Fail("", "has neither depth nor points");
  for (const char* name :
       has_depth ? std::vector<const char*>{"normals"}
                 : std::vector<const char*>{"intrinsics", "confidence", "color", "baseline_m"}) {
    if (has(name)) {
      where.Fail(name, has_depth ? "only allowed beside points" : "only allowed beside depth");
    }
  }

  CameraCapture camera;
  camera.serial = serial;
  if (has_depth) {
    ReadDepth(group.get(), camera, where, frames);
    ReadIntrinsics(group.get(), camera, where);
    if (has("confidence")) ReadConfidence(group.get(), camera, where);
    if (has("color")) ReadColor(group.get(), camera, where);
    if (has("baseline_m")) ReadBaseline(group.get(), camera, where);
  } else {
    camera.points = ReadVectors(group.get(), "points", kMaxRangeM, where);
    if (has("normals")) {
      camera.normals =
          ReadVectors(group.get(), "normals", std::numeric_limits<double>::infinity(), where);
      if (camera.normals.size() != camera.points.size()) {
        where.Fail("normals", std::to_string(camera.normals.size()) + " rows for " +
                                  std::to_string(camera.points.size()) + " points");
      }
    }
  }
  return camera;
}

/// The checked /cameras group of an open capture (root attributes checked too) and its
/// serials, sorted.
H5Id OpenCameras(hid_t file, const std::string& name, std::vector<std::string>* serials) {
  const Context where{name, ""};
  CheckRootAttributes(file, where);
  H5Id cameras = OpenChild(file, "cameras", where, "/cameras");
  if (!cameras.valid()) where.Fail("", "missing group /cameras");
  if (H5Iget_type(cameras.get()) != H5I_GROUP) where.Fail("/cameras", "expected a group");
  H5G_info_t info;
  if (H5Gget_info(cameras.get(), &info) < 0) where.Fail("/cameras", "cannot list");
  if (info.nlinks == 0) where.Fail("/cameras", "is empty (no camera)");
  for (hsize_t i = 0; i < info.nlinks; ++i) {
    const ssize_t length = H5Lget_name_by_idx(cameras.get(), ".", H5_INDEX_NAME, H5_ITER_INC, i,
                                              nullptr, 0, H5P_DEFAULT);
    if (length < 0) where.Fail("/cameras", "cannot list");
    std::string serial(static_cast<size_t>(length) + 1, '\0');
    H5Lget_name_by_idx(cameras.get(), ".", H5_INDEX_NAME, H5_ITER_INC, i, serial.data(),
                       serial.size(), H5P_DEFAULT);
    serial.resize(static_cast<size_t>(length));
    serials->push_back(serial);
  }
  std::sort(serials->begin(), serials->end());
  return cameras;
}

RigCapture ReadOpenFile(hid_t file, const std::string& name) {
  std::vector<std::string> serials;
  const H5Id cameras = OpenCameras(file, name, &serials);
  RigCapture capture;
  for (const std::string& serial : serials) {
    capture.cameras.push_back(ReadCamera(cameras.get(), serial, name));
  }
  return capture;
}

/// A capture file opened for reading; InputError naming it when it is missing, unreadable or
/// no HDF5 file.
H5Id OpenCaptureFile(const std::string& path) {
  SilenceHdf5Errors();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec) || !std::ifstream(path).good()) {
    throw InputError(path + ": cannot open: no such readable file");
  }
  if (H5Fis_hdf5(path.c_str()) <= 0) throw InputError(path + ": not an HDF5 file");
  const H5Id fapl = StrongCloseAccess();
  H5Id file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, fapl.get()), H5Fclose);
  if (!file.valid()) throw InputError(path + ": cannot open as HDF5 (damaged file?)");
  return file;
}

}  // namespace
}  // namespace h5

void CheckDepthCamera(CameraCapture* camera, const Mat3& K, const std::string& source) {
  const h5::Context where{source, ""};
  h5::DropDepthGlitches(camera->depth_m, *camera, where);
  const std::string problem = h5::IntrinsicsProblem(K, camera->width, camera->height);
  if (!problem.empty()) where.Fail("K", problem);
  camera->intrinsics = {K(0, 0), K(1, 1), K(0, 2), K(1, 2)};
}

void SetBaseline(CameraCapture* camera, double baseline_m, const std::string& source) {
  h5::SetBaseline(*camera, baseline_m, h5::Context{source, ""});
}

RigCapture ReadCapture(const std::string& path) {
  const h5::H5Id file = h5::OpenCaptureFile(path);
  return h5::ReadOpenFile(file.get(), path);
}

CameraBurst ReadCaptureBurst(const std::string& path, const std::string& serial) {
  const h5::H5Id file = h5::OpenCaptureFile(path);
  std::vector<std::string> serials;
  const h5::H5Id cameras = h5::OpenCameras(file.get(), path, &serials);
  const std::string chosen = serial.empty() ? serials.front() : serial;
  if (std::find(serials.begin(), serials.end(), chosen) == serials.end()) {
    std::string known;
    for (const std::string& s : serials) known += (known.empty() ? "" : ", ") + s;
    throw InputError(path + ": camera " + chosen + ": not in the file (cameras: " + known + ")");
  }
  CameraBurst burst;
  burst.camera = h5::ReadCamera(cameras.get(), chosen, path, &burst.frames_depth_m);
  if (!burst.camera.HasDepth()) {
    throw InputError(path + ": camera " + chosen + ": has points, not depth frames");
  }
  burst.num_frames = static_cast<int>(burst.frames_depth_m.size() / burst.camera.depth_m.size());
  return burst;
}

std::vector<std::string> CaptureWarnings(const RigCapture& capture, const std::string& path) {
  std::vector<std::string> warnings;
  for (const CameraCapture& camera : capture.cameras) {
    if (camera.glitch_depth_samples == 0) continue;
    warnings.push_back(path + ": camera " + camera.serial + ": " +
                       std::to_string(camera.glitch_depth_samples) + " depth samples beyond " +
                       std::to_string(static_cast<int>(h5::kMaxRangeM)) +
                       " m read as invalid (sensor glitches)");
  }
  return warnings;
}

RigCapture ReadCaptureFromMemory(const void* data, std::size_t size, const std::string& name) {
  h5::SilenceHdf5Errors();
  if (data == nullptr || size == 0) throw InputError(name + ": empty file");
  const h5::H5Id fapl = h5::StrongCloseAccess();
  // Core (in-memory) driver without a backing store; the image is copied by HDF5.
  if (H5Pset_fapl_core(fapl.get(), 1 << 16, 0) < 0 ||
      H5Pset_file_image(fapl.get(), const_cast<void*>(data), size) < 0) {
    throw InputError(name + ": cannot set up the in-memory HDF5 file");
  }
  // The core driver refuses to open an image under the name of a file that exists on disk,
  // so `name` (for messages only) is not given to HDF5: nothing can exist below /dev/null.
  const h5::H5Id file(H5Fopen("/dev/null/rigfit-in-memory-image", H5F_ACC_RDONLY, fapl.get()),
                      H5Fclose);
  if (!file.valid()) throw InputError(name + ": not an HDF5 file (or damaged)");
  return h5::ReadOpenFile(file.get(), name);
}

}  // namespace rigfit

#include "io/capture_h5.h"

#include <fcntl.h>
#include <hdf5.h>
#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>
#include <utility>
#include <vector>

#include "core/errors.h"
#include "io/atomic_file.h"
#include "io/capture_bytes.h"

namespace rigfit {
namespace {

constexpr const char* kFormat = "rig-capture";
constexpr long long kVersion = 1;
/// Largest dataset read, in elements (1 GiB of float32): bounds the memory a damaged or
/// hostile file can make rigfit allocate.
constexpr hsize_t kMaxElements = hsize_t{1} << 28;
/// Deflate expands data at most about 1032:1, so a dataset that declares more than this many
/// times the bytes the file stores of it was never (fully) written, or the file is damaged:
/// its missing part would be fill values, and a small hostile file could make rigfit allocate
/// up to kMaxElements values.
constexpr hsize_t kMaxExpansion = 4096;
/// Chunks of about this many elements (1 MiB of float32) when compressing.
constexpr hsize_t kChunkElements = hsize_t{1} << 18;
/// Skew and last-row tolerance of K, relative to fx (exact zeros are expected).
constexpr double kIntrinsicsTolerance = 1e-9;
/// Smallest focal length accepted, pixels: below it a pixel spans more than 45 degrees, and
/// unprojection (x = z (u - cx) / fx) would blow up towards infinity.
constexpr double kMinFocalPx = 1.0;
/// Depths and point distances beyond this are no measurement of a depth camera but a unit
/// mistake (millimetres as metres, a wrong depth_scale) or a damaged file.
constexpr double kMaxRangeM = 1000.0;

/// Owns one HDF5 identifier and closes it with its own close function.
class H5Id {
 public:
  using Closer = herr_t (*)(hid_t);
  H5Id() = default;
  H5Id(hid_t id, Closer close) : id_(id), close_(close) {}
  H5Id(H5Id&& other) noexcept : id_(std::exchange(other.id_, -1)), close_(other.close_) {}
  H5Id& operator=(H5Id&& other) noexcept {
    if (this != &other) {
      if (id_ >= 0) close_(id_);
      id_ = std::exchange(other.id_, -1);
      close_ = other.close_;
    }
    return *this;
  }
  H5Id(const H5Id&) = delete;
  H5Id& operator=(const H5Id&) = delete;
  ~H5Id() {
    if (id_ >= 0) close_(id_);
  }
  hid_t get() const { return id_; }
  bool valid() const { return id_ >= 0; }
  /// Gives up ownership (to close the identifier explicitly and check the result).
  hid_t release() { return std::exchange(id_, -1); }

 private:
  hid_t id_ = -1;
  Closer close_ = nullptr;
};

/// Turns off the HDF5 library's own printing of its error stack (we report our own).
void SilenceHdf5Errors() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }

/// Where an error is: "<file>: camera <serial>: <dataset>: <what>".
struct Context {
  std::string file;
  std::string camera;

  [[noreturn]] void Fail(const std::string& field, const std::string& what) const {
    std::string message = file + ": ";
    if (!camera.empty()) message += "camera " + camera + ": ";
    if (!field.empty()) message += field + ": ";
    throw InputError(message + what);
  }
};

std::string DescribeType(hid_t type) {
  const size_t bits = 8 * H5Tget_size(type);
  switch (H5Tget_class(type)) {
    case H5T_INTEGER:
      return (H5Tget_sign(type) == H5T_SGN_NONE ? "uint" : "int") + std::to_string(bits);
    case H5T_FLOAT:
      return "float" + std::to_string(bits);
    case H5T_STRING:
      return "string";
    case H5T_COMPOUND:
      return "compound";
    case H5T_ENUM:
      return "enum";
    case H5T_ARRAY:
      return "array";
    case H5T_VLEN:
      return "variable-length";
    default:
      return "an unsupported type";
  }
}

std::string DescribeDims(const std::vector<hsize_t>& dims) {
  std::string text = "[";
  for (size_t i = 0; i < dims.size(); ++i) text += (i ? ", " : "") + std::to_string(dims[i]);
  return text + "]";
}

/// A child object of a group reached through a hard link (external links could point
/// anywhere on disk), or an invalid H5Id if there is no such link. field names it in errors.
H5Id OpenChild(hid_t group, const std::string& name, const Context& where,
               const std::string& field) {
  if (H5Lexists(group, name.c_str(), H5P_DEFAULT) <= 0) return {};
  H5L_info_t link;
  if (H5Lget_info(group, name.c_str(), &link, H5P_DEFAULT) < 0 || link.type != H5L_TYPE_HARD) {
    where.Fail(field, "must be a group or dataset, not a soft or external link");
  }
  H5Id object(H5Oopen(group, name.c_str(), H5P_DEFAULT), H5Oclose);
  if (!object.valid()) where.Fail(field, "cannot open");
  return object;
}

/// An open dataset with its type and shape.
struct Dataset {
  std::string name;
  H5Id id;
  H5Id type;
  H5T_class_t type_class = H5T_NO_CLASS;
  std::vector<hsize_t> dims;

  hsize_t Elements() const {
    hsize_t n = 1;
    for (const hsize_t d : dims) n *= d;
    return n;
  }
};

Dataset OpenDataset(hid_t group, const std::string& name, const Context& where) {
  Dataset d;
  d.name = name;
  d.id = OpenChild(group, name, where, name);
  if (H5Iget_type(d.id.get()) != H5I_DATASET) where.Fail(name, "expected a dataset");
  d.type = H5Id(H5Dget_type(d.id.get()), H5Tclose);
  const H5Id space(H5Dget_space(d.id.get()), H5Sclose);
  if (!d.type.valid() || !space.valid()) where.Fail(name, "cannot read type or shape");
  d.type_class = H5Tget_class(d.type.get());
  const int rank = H5Sget_simple_extent_ndims(space.get());
  if (rank < 0) where.Fail(name, "cannot read shape");
  d.dims.resize(rank);
  H5Sget_simple_extent_dims(space.get(), d.dims.data(), nullptr);
  // Bound the element count (and prevent overflow) before anything is allocated.
  hsize_t n = 1;
  for (const hsize_t dim : d.dims) {
    if (dim == 0) where.Fail(name, "has zero size " + DescribeDims(d.dims));
    if (dim > kMaxElements || n > kMaxElements / dim) {
      where.Fail(name, "too large " + DescribeDims(d.dims) + " (limit " +
                           std::to_string(kMaxElements) + " elements)");
    }
    n *= dim;
  }
  return d;
}

void ExpectRank(const Dataset& d, size_t rank, const Context& where) {
  if (d.dims.size() != rank) {
    where.Fail(d.name, "expected rank " + std::to_string(rank) + ", got " +
                           std::to_string(d.dims.size()) + " " + DescribeDims(d.dims));
  }
}

void ExpectFloat(const Dataset& d, const Context& where) {
  if (d.type_class != H5T_FLOAT) {
    where.Fail(d.name, "expected float32 or float64, got " + DescribeType(d.type.get()));
  }
}

/// Every element, converted by HDF5 to the memory type. A dataset whose declared size is more
/// than kMaxExpansion times what the file stores of it is rejected before anything is allocated.
template <typename T>
std::vector<T> ReadAll(const Dataset& d, hid_t memory_type, const Context& where) {
  const hsize_t declared = d.Elements() * H5Tget_size(d.type.get());
  const hsize_t stored = H5Dget_storage_size(d.id.get());
  if (declared > kMaxExpansion * std::max<hsize_t>(stored, 1)) {
    where.Fail(d.name, "declares " + DescribeDims(d.dims) + " (" + std::to_string(declared) +
                           " bytes) but the file stores " + std::to_string(stored) +
                           " bytes of it: damaged, or never written");
  }
  std::vector<T> values(d.Elements());
  if (H5Dread(d.id.get(), memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) < 0) {
    where.Fail(d.name, "cannot read its data (damaged, or compressed with an unavailable filter)");
  }
  return values;
}

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

/// "" if K is a pinhole matrix of a width x height image, else what is wrong with it.
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

/// A capture whose median valid depth is beyond this is in another unit (millimetres read as
/// metres, a wrong depth_scale): no depth camera sees a room from 100 m away.
constexpr double kMaxMedianDepthM = 100.0;

/// Fails when the valid (finite) depth as a whole looks like another unit: its median is
/// beyond kMaxMedianDepthM. Every sample of a burst counts.
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

/// Fails on the first vector (row of points, normals) that is not finite or is longer than
/// max_norm.
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
  for (const char* name : has_depth
                              ? std::vector<const char*>{"normals"}
                              : std::vector<const char*>{"intrinsics", "confidence", "color"}) {
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

H5Id StrongCloseAccess() {
  H5Id fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  H5Pset_fclose_degree(fapl.get(), H5F_CLOSE_STRONG);
  return fapl;
}

// ---------------------------------------------------------------------------------------------
// Writing.

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

/// Writes one dataset; large ones chunked (whole rows) and compressed with shuffle + deflate.
void WriteDataset(hid_t group, const std::string& name, hid_t file_type, hid_t memory_type,
                  const std::vector<hsize_t>& dims, const void* data, const Context& where) {
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
    WriteDataset(group.get(), "points", H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, dims, points.data(),
                 where);
    if (!camera.normals.empty()) {
      const std::vector<float> normals = ToFloat32(camera.normals);
      WriteDataset(group.get(), "normals", H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, dims, normals.data(),
                   where);
    }
    return;
  }
  const std::vector<hsize_t> image = {static_cast<hsize_t>(camera.height),
                                      static_cast<hsize_t>(camera.width)};
  if (options.depth_as_uint16) {
    const std::vector<std::uint16_t> units =
        ToUint16Depth(camera.depth_m, options.depth_scale, where);
    WriteDataset(group.get(), "depth", H5T_STD_U16LE, H5T_NATIVE_UINT16, image, units.data(),
                 where);
    const H5Id depth(H5Dopen2(group.get(), "depth", H5P_DEFAULT), H5Dclose);
    WriteScalarAttribute(depth.get(), "depth_scale", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE,
                         &options.depth_scale, where);
  } else {
    WriteDataset(group.get(), "depth", H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, image,
                 camera.depth_m.data(), where);
  }
  const PinholeIntrinsics& k = camera.intrinsics;
  const double K[9] = {k.fx, 0.0, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0};
  WriteDataset(group.get(), "intrinsics", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {3, 3}, K, where);
  if (!camera.confidence.empty()) {
    WriteDataset(group.get(), "confidence", H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, image,
                 camera.confidence.data(), where);
  }
  if (!camera.color.empty()) {
    WriteDataset(group.get(), "color", H5T_STD_U8LE, H5T_NATIVE_UINT8, {image[0], image[1], 3},
                 camera.color.data(), where);
  }
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

/// Writes all of `bytes` to fd (blocking), after its length as a uint64; false on an error.
bool WriteAll(int fd, const std::string& bytes) {
  const std::uint64_t length = bytes.size();
  const std::string framed(reinterpret_cast<const char*>(&length), sizeof(length));
  for (const std::string* part : {&framed, &bytes}) {
    for (std::size_t done = 0; done < part->size();) {
      const ssize_t n = write(fd, part->data() + done, part->size() - done);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) return false;
      done += static_cast<std::size_t>(n);
    }
  }
  return true;
}

/// waitpid, again after a signal; its result.
pid_t Reap(pid_t pid, int* status) {
  pid_t done = 0;
  while ((done = waitpid(pid, status, 0)) < 0 && errno == EINTR) {
  }
  return done;
}

/// The guarded read's child process and the read end of its pipe: on every way out of the
/// parent (an exception too), the pipe is closed and a child still running is killed and
/// reaped.
struct ReadingChild {
  pid_t pid = -1;
  int fd = -1;

  ReadingChild(pid_t p, int f) : pid(p), fd(f) {}
  ReadingChild(const ReadingChild&) = delete;
  ReadingChild& operator=(const ReadingChild&) = delete;
  ~ReadingChild() { Stop(); }

  void ClosePipe() {
    if (fd >= 0) close(fd);
    fd = -1;
  }
  void Stop() {
    ClosePipe();
    if (pid > 0) {
      kill(pid, SIGKILL);
      Reap(pid, nullptr);
    }
    pid = -1;
  }
};

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

void CheckDepthCamera(CameraCapture* camera, const Mat3& K, const std::string& source) {
  const Context where{source, ""};
  DropDepthGlitches(camera->depth_m, *camera, where);
  const std::string problem = IntrinsicsProblem(K, camera->width, camera->height);
  if (!problem.empty()) where.Fail("K", problem);
  camera->intrinsics = {K(0, 0), K(1, 1), K(0, 2), K(1, 2)};
}

RigCapture ReadCapture(const std::string& path) {
  const H5Id file = OpenCaptureFile(path);
  return ReadOpenFile(file.get(), path);
}

CameraBurst ReadCaptureBurst(const std::string& path, const std::string& serial) {
  const H5Id file = OpenCaptureFile(path);
  std::vector<std::string> serials;
  const H5Id cameras = OpenCameras(file.get(), path, &serials);
  const std::string chosen = serial.empty() ? serials.front() : serial;
  if (std::find(serials.begin(), serials.end(), chosen) == serials.end()) {
    std::string known;
    for (const std::string& s : serials) known += (known.empty() ? "" : ", ") + s;
    throw InputError(path + ": camera " + chosen + ": not in the file (cameras: " + known + ")");
  }
  CameraBurst burst;
  burst.camera = ReadCamera(cameras.get(), chosen, path, &burst.frames_depth_m);
  if (!burst.camera.HasDepth()) {
    throw InputError(path + ": camera " + chosen + ": has points, not depth frames");
  }
  burst.num_frames = static_cast<int>(burst.frames_depth_m.size() / burst.camera.depth_m.size());
  return burst;
}

RigCapture ReadCaptureGuarded(const std::string& path, double timeout_s) {
  if (std::isnan(timeout_s)) throw std::invalid_argument("ReadCaptureGuarded: timeout is NaN");
  timeout_s = std::clamp(timeout_s, 0.0, 1e9);  // 1e9 s: no deadline
  int channel[2];
  // Close-on-exec: a process another thread starts must not hold the write end open.
  if (pipe2(channel, O_CLOEXEC) != 0) return ReadCapture(path);  // no pipe, no guard
  // A wider pipe than the 64 KiB default: fewer switches between writer and reader.
  fcntl(channel[1], F_SETPIPE_SZ, 1 << 20);
  std::vector<char> chunk(1 << 20);
  const pid_t pid = fork();
  if (pid < 0) {
    close(channel[0]);
    close(channel[1]);
    return ReadCapture(path);
  }
  if (pid == 0) {
    // The read. _exit: no atexit handlers, no destructors of the parent's objects. Exit code
    // 0 sends the capture's bytes, 2 and 3 an error message, each after its length.
    close(channel[0]);
    int code = 0;
    std::string bytes;
    try {
      bytes = EncodeCapture(ReadCapture(path));
    } catch (const InputError& e) {
      code = 2;
      bytes = e.what();
    } catch (const std::exception& e) {
      code = 3;
      bytes = e.what();
    }
    if (!WriteAll(channel[1], bytes)) code = 4;
    _exit(code);
  }
  close(channel[1]);
  ReadingChild child(pid, channel[0]);
  // Read until the child closes its end (it exits), or the deadline.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  std::string bytes;
  std::uint64_t length = 0;  // of the payload, once its 8 bytes are in
  bool have_length = false;
  for (;;) {
    const double left =
        std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
    if (left <= 0.0) {
      child.Stop();
      throw InputError(path + ": reading it did not finish in " +
                       std::to_string(static_cast<long long>(timeout_s)) +
                       " s (a loop inside the HDF5 library?): damaged file?");
    }
    pollfd wait_for = {child.fd, POLLIN, 0};
    const int ready = poll(&wait_for, 1, static_cast<int>(std::min(left * 1000.0 + 1.0, 1e9)));
    if (ready == 0 || (ready < 0 && errno == EINTR)) continue;
    const ssize_t got = ready < 0 ? -1 : read(child.fd, chunk.data(), chunk.size());
    if (got < 0 && (errno == EINTR || errno == EAGAIN)) continue;
    if (got < 0) {  // cannot wait for the child: no guard, read as usual
      child.Stop();
      return ReadCapture(path);
    }
    if (got == 0) break;  // end of file: the child is done
    bytes.append(chunk.data(), static_cast<std::size_t>(got));
    if (!have_length && bytes.size() >= sizeof(length)) {
      std::memcpy(&length, bytes.data(), sizeof(length));
      bytes.reserve(sizeof(length) + std::min<std::uint64_t>(length, std::uint64_t{1} << 36));
      have_length = true;
    }
  }
  child.ClosePipe();
  int status = 0;
  const pid_t done = Reap(pid, &status);
  child.pid = -1;
  // The payload: the bytes after their length, complete if the length says they all came.
  const bool complete = have_length && length == bytes.size() - sizeof(length);
  std::string payload = std::move(bytes);
  payload.erase(0, std::min(payload.size(), sizeof(length)));
  if (done != pid) return ReadCapture(path);  // the child was reaped elsewhere: no verdict
  if (WIFSIGNALED(status)) {
    throw InputError(path + ": the HDF5 library crashed reading it (" +
                     strsignal(WTERMSIG(status)) + "): damaged file?");
  }
  const int code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  if (code == 4) return ReadCapture(path);  // the child read the file but could not send it
  if (code == 0) {
    try {
      if (complete) return DecodeCapture(std::move(payload));
    } catch (const std::runtime_error&) {
    }
    throw InputError(path + ": reading it failed (the capture came back incomplete)");
  }
  if (code == 2 && !payload.empty()) throw InputError(payload);
  throw InputError(path + ": reading it failed" +
                   (payload.empty() || code != 3 ? " (exit code " + std::to_string(code) + ")"
                                                 : ": " + payload) +
                   ": damaged file?");
}

std::vector<std::string> CaptureWarnings(const RigCapture& capture, const std::string& path) {
  std::vector<std::string> warnings;
  for (const CameraCapture& camera : capture.cameras) {
    if (camera.glitch_depth_samples == 0) continue;
    warnings.push_back(path + ": camera " + camera.serial + ": " +
                       std::to_string(camera.glitch_depth_samples) + " depth samples beyond " +
                       std::to_string(static_cast<int>(kMaxRangeM)) +
                       " m read as invalid (sensor glitches)");
  }
  return warnings;
}

RigCapture ReadCaptureFromMemory(const void* data, std::size_t size, const std::string& name) {
  SilenceHdf5Errors();
  if (data == nullptr || size == 0) throw InputError(name + ": empty file");
  const H5Id fapl = StrongCloseAccess();
  // Core (in-memory) driver without a backing store; the image is copied by HDF5.
  if (H5Pset_fapl_core(fapl.get(), 1 << 16, 0) < 0 ||
      H5Pset_file_image(fapl.get(), const_cast<void*>(data), size) < 0) {
    throw InputError(name + ": cannot set up the in-memory HDF5 file");
  }
  // The core driver refuses to open an image under the name of a file that exists on disk,
  // so `name` (for messages only) is not given to HDF5: nothing can exist below /dev/null.
  const H5Id file(H5Fopen("/dev/null/rigfit-in-memory-image", H5F_ACC_RDONLY, fapl.get()),
                  H5Fclose);
  if (!file.valid()) throw InputError(name + ": not an HDF5 file (or damaged)");
  return ReadOpenFile(file.get(), name);
}

void WriteCapture(const std::string& path, const RigCapture& capture,
                  const CaptureWriteOptions& options) {
  SilenceHdf5Errors();
  CheckWritable(capture, options, path);
  WriteFileAtomically(
      path, [&](const std::string& tmp_path) { WriteFile(tmp_path, capture, options, path); });
}

}  // namespace rigfit

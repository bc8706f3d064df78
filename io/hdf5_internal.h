// The HDF5 plumbing of the capture reader and writer (io/capture_h5.h): identifiers closed by
// their owner, errors that name the file, the camera and the dataset, and datasets opened and
// read within bounds on what a damaged file can make rigfit allocate. Internal to io/ (not
// installed): no other module sees HDF5 types.
#pragma once

#include <hdf5.h>

#include <algorithm>
#include <string>
#include <utility>
#include <vector>

#include "core/errors.h"

namespace rigfit::h5 {

/// Deflate expands data at most about 1032:1, so a dataset that declares more than this many
/// times the bytes the file stores of it was never (fully) written, or the file is damaged:
/// its missing part would be fill values, and a small hostile file could make rigfit allocate
/// up to kMaxElements values.
constexpr hsize_t kMaxExpansion = 4096;

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
void SilenceHdf5Errors();

/// File access properties under which closing a file closes every object still open in it.
H5Id StrongCloseAccess();

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

/// The type as a contract's name: "float32", "uint16", "string", ...
std::string DescribeType(hid_t type);

/// "[d0, d1, ...]".
std::string DescribeDims(const std::vector<hsize_t>& dims);

/// A child object of a group reached through a hard link (external links could point
/// anywhere on disk), or an invalid H5Id if there is no such link. field names it in errors.
H5Id OpenChild(hid_t group, const std::string& name, const Context& where,
               const std::string& field);

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

/// The dataset `name` of `group` (a hard link), with no dimension 0 and at most kMaxElements
/// elements; InputError otherwise.
Dataset OpenDataset(hid_t group, const std::string& name, const Context& where);

void ExpectRank(const Dataset& d, size_t rank, const Context& where);

void ExpectFloat(const Dataset& d, const Context& where);

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

}  // namespace rigfit::h5

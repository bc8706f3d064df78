#include "io/hdf5_internal.h"

namespace rigfit::h5 {
namespace {

/// Largest dataset read, in elements (1 GiB of float32): bounds the memory a damaged or
/// hostile file can make rigfit allocate.
constexpr hsize_t kMaxElements = hsize_t{1} << 28;

}  // namespace

void SilenceHdf5Errors() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }

H5Id StrongCloseAccess() {
  H5Id fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  H5Pset_fclose_degree(fapl.get(), H5F_CLOSE_STRONG);
  return fapl;
}

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

}  // namespace rigfit::h5

#include "io/ply.h"

#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <optional>

#include "core/errors.h"
#include "io/atomic_file.h"
#include "io/read_file.h"

#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "rigfit's PLY reader and writer copy binary_little_endian values as host values"
#endif

namespace rigfit {
namespace {

enum class PlyFormat { kAscii, kBinaryLittleEndian };

enum class ScalarType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

std::optional<ScalarType> ScalarTypeFromName(const std::string& name) {
  static const std::pair<const char*, ScalarType> kNames[] = {
      {"char", ScalarType::kInt8},      {"int8", ScalarType::kInt8},
      {"uchar", ScalarType::kUint8},    {"uint8", ScalarType::kUint8},
      {"short", ScalarType::kInt16},    {"int16", ScalarType::kInt16},
      {"ushort", ScalarType::kUint16},  {"uint16", ScalarType::kUint16},
      {"int", ScalarType::kInt32},      {"int32", ScalarType::kInt32},
      {"uint", ScalarType::kUint32},    {"uint32", ScalarType::kUint32},
      {"float", ScalarType::kFloat32},  {"float32", ScalarType::kFloat32},
      {"double", ScalarType::kFloat64}, {"float64", ScalarType::kFloat64}};
  for (const auto& [n, type] : kNames) {
    if (name == n) return type;
  }
  return std::nullopt;
}

size_t SizeOf(ScalarType type) {
  switch (type) {
    case ScalarType::kInt8:
    case ScalarType::kUint8:
      return 1;
    case ScalarType::kInt16:
    case ScalarType::kUint16:
      return 2;
    case ScalarType::kInt32:
    case ScalarType::kUint32:
    case ScalarType::kFloat32:
      return 4;
    case ScalarType::kFloat64:
      return 8;
  }
  return 0;
}

bool IsInteger(ScalarType type) {
  return type != ScalarType::kFloat32 && type != ScalarType::kFloat64;
}

/// Whether an ASCII value fits its declared type (integers: whole and in range).
bool FitsType(double value, ScalarType type) {
  if (!IsInteger(type)) return true;
  const int bits = static_cast<int>(8 * SizeOf(type));
  const bool is_signed =
      type == ScalarType::kInt8 || type == ScalarType::kInt16 || type == ScalarType::kInt32;
  const double lo = is_signed ? -std::ldexp(1.0, bits - 1) : 0.0;
  const double hi = std::ldexp(1.0, is_signed ? bits - 1 : bits) - 1.0;
  return value == std::floor(value) && value >= lo && value <= hi;
}

template <typename T>
double Load(const char* p) {
  T value;
  std::memcpy(&value, p, sizeof(T));
  return static_cast<double>(value);
}

double LoadBinary(const char* p, ScalarType type) {
  switch (type) {
    case ScalarType::kInt8:
      return Load<std::int8_t>(p);
    case ScalarType::kUint8:
      return Load<std::uint8_t>(p);
    case ScalarType::kInt16:
      return Load<std::int16_t>(p);
    case ScalarType::kUint16:
      return Load<std::uint16_t>(p);
    case ScalarType::kInt32:
      return Load<std::int32_t>(p);
    case ScalarType::kUint32:
      return Load<std::uint32_t>(p);
    case ScalarType::kFloat32:
      return Load<float>(p);
    case ScalarType::kFloat64:
      return Load<double>(p);
  }
  return 0.0;
}

struct Property {
  std::string name;
  ScalarType type = ScalarType::kFloat32;  ///< the item type for a list
  bool is_list = false;
  ScalarType count_type = ScalarType::kUint8;
};

struct Element {
  std::string name;
  std::uint64_t count = 0;
  std::vector<Property> properties;
  size_t line = 0;  ///< header line of its "element" statement
};

struct Header {
  PlyFormat format = PlyFormat::kAscii;
  std::vector<Element> elements;
  size_t data_offset = 0;  ///< first byte after "end_header\n"
};

std::vector<std::string> SplitWords(const std::string& line) {
  std::vector<std::string> words;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    const size_t start = i;
    while (i < line.size() && !std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    if (i > start) words.push_back(line.substr(start, i - start));
  }
  return words;
}

Header ParseHeader(const std::string& bytes, const std::string& path) {
  Header header;
  bool has_format = false;
  size_t pos = 0;
  for (size_t line_number = 1;; ++line_number) {
    const size_t end = bytes.find('\n', pos);
    if (end == std::string::npos) throw InputError(path + ": PLY header has no end_header");
    std::string line = bytes.substr(pos, end - pos);
    pos = end + 1;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const std::string where = path + ": header line " + std::to_string(line_number) + ": ";
    const std::vector<std::string> w = SplitWords(line);
    if (line_number == 1) {
      if (line != "ply") throw InputError(path + ": not a PLY file (first line is not 'ply')");
      continue;
    }
    if (w.empty() || w[0] == "comment" || w[0] == "obj_info") continue;
    if (w[0] == "end_header") break;
    if (w[0] == "format") {
      if (w.size() != 3 || w[2] != "1.0") throw InputError(where + "expected 'format <f> 1.0'");
      if (w[1] == "ascii") {
        header.format = PlyFormat::kAscii;
      } else if (w[1] == "binary_little_endian") {
        header.format = PlyFormat::kBinaryLittleEndian;
      } else {
        throw InputError(where + "unsupported format '" + w[1] +
                         "' (ascii or binary_little_endian)");
      }
      has_format = true;
    } else if (w[0] == "element") {
      Element element;
      if (w.size() != 3) throw InputError(where + "expected 'element <name> <count>'");
      element.name = w[1];
      element.line = line_number;
      const auto [p, ec] = std::from_chars(w[2].data(), w[2].data() + w[2].size(), element.count);
      if (ec != std::errc() || p != w[2].data() + w[2].size()) {
        throw InputError(where + "element " + w[1] + ": bad count '" + w[2] + "'");
      }
      header.elements.push_back(element);
    } else if (w[0] == "property") {
      if (header.elements.empty()) throw InputError(where + "property before any element");
      Property property;
      const bool is_list = w.size() >= 2 && w[1] == "list";
      if (w.size() != (is_list ? 5u : 3u)) {
        throw InputError(where + "expected 'property <type> <name>' or " +
                         "'property list <count type> <item type> <name>'");
      }
      property.is_list = is_list;
      property.name = w.back();
      const std::optional<ScalarType> type = ScalarTypeFromName(w[is_list ? 3 : 1]);
      if (!type) throw InputError(where + "unknown property type '" + w[is_list ? 3 : 1] + "'");
      property.type = *type;
      if (is_list) {
        const std::optional<ScalarType> count_type = ScalarTypeFromName(w[2]);
        if (!count_type || !IsInteger(*count_type)) {
          throw InputError(where + "list count type must be an integer type, got '" + w[2] + "'");
        }
        property.count_type = *count_type;
      }
      header.elements.back().properties.push_back(property);
    } else {
      throw InputError(where + "unexpected '" + w[0] + "'");
    }
  }
  if (!has_format) throw InputError(path + ": PLY header has no format line");
  header.data_offset = pos;
  return header;
}

/// Sequential reader of element data in either encoding.
class DataCursor {
 public:
  DataCursor(const std::string& bytes, size_t offset, PlyFormat format)
      : bytes_(bytes), pos_(offset), format_(format) {}

  size_t Remaining() const { return bytes_.size() - pos_; }

  /// The next value; false at the end of the data or for a malformed ASCII token.
  bool Next(ScalarType type, double* value) {
    if (format_ == PlyFormat::kBinaryLittleEndian) {
      if (Remaining() < SizeOf(type)) return false;
      *value = LoadBinary(bytes_.data() + pos_, type);
      pos_ += SizeOf(type);
      return true;
    }
    while (pos_ < bytes_.size() && std::isspace(static_cast<unsigned char>(bytes_[pos_]))) ++pos_;
    const size_t start = pos_;
    while (pos_ < bytes_.size() && !std::isspace(static_cast<unsigned char>(bytes_[pos_]))) ++pos_;
    if (pos_ == start) return false;
    const char* first = bytes_.data() + start;
    const char* last = bytes_.data() + pos_;
    if (*first == '+') ++first;
    const auto [p, ec] = std::from_chars(first, last, *value);
    if (ec != std::errc() || p != last) return false;
    return FitsType(*value, type);
  }

 private:
  const std::string& bytes_;
  size_t pos_;
  PlyFormat format_;
};

/// Minimum bytes of one record in the file, to bound counts by the data actually present.
size_t MinRecordBytes(const Element& element, PlyFormat format) {
  size_t bytes = 0;
  for (const Property& p : element.properties) {
    // ASCII: at least one character and one separator per value (or list count).
    bytes += format == PlyFormat::kAscii ? 2 : SizeOf(p.is_list ? p.count_type : p.type);
  }
  return bytes;
}

void CheckCountFits(const Element& element, const DataCursor& cursor, PlyFormat format,
                    const std::string& path) {
  const size_t record = MinRecordBytes(element, format);
  // +1: the last ASCII value needs no separator after it.
  if (record > 0 && element.count > (cursor.Remaining() + 1) / record) {
    throw InputError(path + ": element " + element.name + ": " + std::to_string(element.count) +
                     " records declared but the file is too short for them");
  }
}

/// Reads one record, calling store(property index, value) for every scalar property.
template <typename Store>
void ReadRecord(const Element& element, std::uint64_t record, DataCursor& cursor,
                const std::string& path, Store&& store) {
  for (size_t k = 0; k < element.properties.size(); ++k) {
    const Property& p = element.properties[k];
    const std::string where = path + ": element " + element.name + " record " +
                              std::to_string(record) + ": property " + p.name + ": ";
    double value = 0.0;
    if (!cursor.Next(p.is_list ? p.count_type : p.type, &value)) {
      throw InputError(where + "truncated or malformed data");
    }
    if (!p.is_list) {
      store(k, value);
      continue;
    }
    if (value < 0) throw InputError(where + "negative list length");
    const auto length = static_cast<std::uint64_t>(value);
    if (length > cursor.Remaining()) throw InputError(where + "list longer than the file");
    for (std::uint64_t i = 0; i < length; ++i) {
      if (!cursor.Next(p.type, &value)) throw InputError(where + "truncated or malformed list");
    }
  }
}

std::optional<size_t> FindProperty(const Element& element, const std::string& name) {
  for (size_t k = 0; k < element.properties.size(); ++k) {
    if (element.properties[k].name == name) return k;
  }
  return std::nullopt;
}

/// Indices of a group of properties (x y z, nx ny nz, red green blue): all present or none.
std::optional<std::array<size_t, 3>> FindGroup(const Element& vertex,
                                               const std::array<const char*, 3>& names,
                                               bool required, const std::string& path) {
  std::array<std::optional<size_t>, 3> found;
  for (int i = 0; i < 3; ++i) found[i] = FindProperty(vertex, names[i]);
  const int present = (found[0] ? 1 : 0) + (found[1] ? 1 : 0) + (found[2] ? 1 : 0);
  const std::string group = std::string(names[0]) + " " + names[1] + " " + names[2];
  if (present == 0 && !required) return std::nullopt;
  if (present != 3) throw InputError(path + ": element vertex: needs all of " + group);
  std::array<size_t, 3> indices;
  for (int i = 0; i < 3; ++i) {
    indices[i] = *found[i];
    if (vertex.properties[indices[i]].is_list) {
      throw InputError(path + ": element vertex: property " + names[i] + " must not be a list");
    }
  }
  return indices;
}

}  // namespace

PlyCloud ReadPly(const std::string& path) {
  const std::string bytes = ReadWholeFile(path);
  const Header header = ParseHeader(bytes, path);
  DataCursor cursor(bytes, header.data_offset, header.format);

  PlyCloud cloud;
  for (const Element& element : header.elements) {
    CheckCountFits(element, cursor, header.format, path);
    if (element.name != "vertex") {
      if (element.properties.empty()) continue;  // records without properties take no bytes
      for (std::uint64_t r = 0; r < element.count; ++r) {
        ReadRecord(element, r, cursor, path, [](size_t, double) {});
      }
      continue;
    }
    const std::array<size_t, 3> xyz = *FindGroup(element, {"x", "y", "z"}, true, path);
    const auto normal = FindGroup(element, {"nx", "ny", "nz"}, false, path);
    const auto color = FindGroup(element, {"red", "green", "blue"}, false, path);
    if (color) {
      for (const size_t k : *color) {
        if (element.properties[k].type != ScalarType::kUint8) {
          throw InputError(path + ": element vertex: property " + element.properties[k].name +
                           " must be uchar");
        }
      }
    }
    std::vector<double> values(element.properties.size());
    cloud.points.reserve(element.count);
    if (normal) cloud.normals.reserve(element.count);
    if (color) cloud.colors.reserve(element.count);
    for (std::uint64_t r = 0; r < element.count; ++r) {
      ReadRecord(element, r, cursor, path, [&](size_t k, double v) { values[k] = v; });
      const Vec3 p(values[xyz[0]], values[xyz[1]], values[xyz[2]]);
      const Vec3 n = normal ? Vec3(values[(*normal)[0]], values[(*normal)[1]], values[(*normal)[2]])
                            : Vec3::Zero();
      if (!p.allFinite() || !n.allFinite()) {
        ++cloud.skipped_non_finite;
        continue;
      }
      cloud.points.push_back(p);
      if (normal) cloud.normals.push_back(n);
      if (color) {
        cloud.colors.push_back({static_cast<std::uint8_t>(values[(*color)[0]]),
                                static_cast<std::uint8_t>(values[(*color)[1]]),
                                static_cast<std::uint8_t>(values[(*color)[2]])});
      }
    }
    return cloud;  // later elements (faces, ...) are not needed
  }
  throw InputError(path + ": no element vertex");
}

void WritePly(const std::string& path, const PlyCloud& cloud) {
  const size_t n = cloud.points.size();
  const bool with_normals = !cloud.normals.empty();
  const bool with_colors = !cloud.colors.empty();
  if (with_normals && cloud.normals.size() != n) {
    throw InputError(path + ": cannot write: " + std::to_string(cloud.normals.size()) +
                     " normals for " + std::to_string(n) + " points");
  }
  if (with_colors && cloud.colors.size() != n) {
    throw InputError(path + ": cannot write: " + std::to_string(cloud.colors.size()) +
                     " colors for " + std::to_string(n) + " points");
  }
  std::string header =
      "ply\nformat binary_little_endian 1.0\ncomment written by rigfit\nelement vertex " +
      std::to_string(n) + "\nproperty float x\nproperty float y\nproperty float z\n";
  if (with_normals) header += "property float nx\nproperty float ny\nproperty float nz\n";
  if (with_colors) header += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  header += "end_header\n";

  const size_t record = 3 * sizeof(float) * (with_normals ? 2 : 1) + (with_colors ? 3 : 0);
  std::string data(n * record, '\0');
  char* out = data.data();
  const auto put3 = [&out](const Vec3& v) {
    const float f[3] = {static_cast<float>(v.x()), static_cast<float>(v.y()),
                        static_cast<float>(v.z())};
    std::memcpy(out, f, sizeof(f));
    out += sizeof(f);
  };
  for (size_t i = 0; i < n; ++i) {
    put3(cloud.points[i]);
    if (with_normals) put3(cloud.normals[i]);
    if (with_colors) {
      std::memcpy(out, cloud.colors[i].data(), 3);
      out += 3;
    }
  }
  WriteFileAtomically(path, [&](const std::string& tmp_path) {
    std::ofstream file(tmp_path, std::ios::binary | std::ios::trunc);
    file << header;
    file.write(data.data(), static_cast<std::streamsize>(data.size()));
    file.close();
    if (!file) throw InputError(path + ": write error");
  });
}

}  // namespace rigfit

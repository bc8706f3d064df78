// The keyword options of rigfit's Python functions (docs/python.md): one table per command maps
// each keyword (the CLI's long flag, '-' written '_') to the field of the command's options it
// sets. A table is the only place the binding writes a keyword: Apply reads the dict of keywords
// a call was given (None: not given, the field keeps the library's default) and Defaults tells
// rigfit/__init__.py the names and defaults for the functions' signatures and docstrings.
#pragma once

#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/errors.h"
#include "core/setting_error.h"

namespace rigfit::python {

namespace py = pybind11;

/// `value` read as the keyword `where` ("track: first") takes it; InputError (ValueError in
/// Python) "<where> must be <kind>, got <repr>" for another type. A bool takes True or False
/// only (numpy's too), a number no bool, an integer no float.
void ReadKeyword(const py::handle& value, const std::string& where, bool* out);
void ReadKeyword(const py::handle& value, const std::string& where, int* out);
void ReadKeyword(const py::handle& value, const std::string& where, std::uint64_t* out);
void ReadKeyword(const py::handle& value, const std::string& where, double* out);
void ReadKeyword(const py::handle& value, const std::string& where, float* out);
void ReadKeyword(const py::handle& value, const std::string& where, std::string* out);
void ReadKeyword(const py::handle& value, const std::string& where, std::vector<int>* out);
void ReadKeyword(const py::handle& value, const std::string& where, std::vector<double>* out);

template <typename T>
void ReadKeyword(const py::handle& value, const std::string& where, std::optional<T>* out) {
  T read{};
  ReadKeyword(value, where, &read);
  *out = std::move(read);
}

/// "track: unknown keyword 'firts' (track takes first, max_frames, ...)".
[[noreturn]] void FailUnknownKeyword(const std::string& command, const std::string& name,
                                     const std::vector<std::string>& names);

/// The keywords of one command, read into `Args` (the command's options struct, or a small
/// struct holding it and the settings that are checked before they are applied).
template <typename Args>
class KeywordTable {
 public:
  explicit KeywordTable(std::string command) : command_(std::move(command)) {}

  /// Adds the keyword `name`, read into the field `field(&args)` points to, e.g.
  /// `[](TrackKeywords& k) { return &k.odometry.first_frame; }`.
  template <typename Field>
  KeywordTable& Add(std::string name, Field field) {
    using Value = std::remove_pointer_t<std::invoke_result_t<Field, Args&>>;
    entries_.push_back({std::move(name),
                        [field](const py::handle& value, const std::string& where, Args* args) {
                          Value read{};
                          ReadKeyword(value, where, &read);
                          *field(*args) = std::move(read);
                        },
                        [field](Args& args) { return py::cast(*field(args)); }});
    return *this;
  }

  /// `args` with the given keywords applied, None skipped; InputError naming an unknown
  /// keyword or a value of the wrong type.
  Args Apply(const py::dict& keywords, Args args = Args{}) const {
    for (const auto& [key, value] : keywords) {
      const std::string name = py::cast<std::string>(py::str(key));
      const Entry* entry = Find(name);
      if (entry == nullptr) FailUnknownKeyword(command_, name, Names());
      if (!value.is_none()) entry->read(value, command_ + ": " + name, &args);
    }
    return args;
  }

  /// name -> default (the field of a default-constructed Args), in the table's order.
  py::dict Defaults() const {
    Args defaults{};
    py::dict out;
    for (const Entry& entry : entries_) out[py::str(entry.name)] = entry.get(defaults);
    return out;
  }

 private:
  struct Entry {
    std::string name;
    std::function<void(const py::handle&, const std::string&, Args*)> read;
    std::function<py::object(Args&)> get;
  };

  const Entry* Find(const std::string& name) const {
    for (const Entry& entry : entries_) {
      if (entry.name == name) return &entry;
    }
    return nullptr;
  }

  std::vector<std::string> Names() const {
    std::vector<std::string> names;
    for (const Entry& entry : entries_) names.push_back(entry.name);
    return names;
  }

  std::string command_;
  std::vector<Entry> entries_;
};

/// Runs `check`, the library's checks of `command`'s settings: a SettingError becomes an
/// InputError (ValueError) "<command>: <message>", the settings spelled as keywords.
template <typename Check>
void CheckKeywords(const std::string& command, const Check& check) {
  try {
    check();
  } catch (const SettingError& e) {
    throw InputError(command + ": " + e.Spelled(SettingError::Key));
  }
}

}  // namespace rigfit::python

#include "python/keywords.h"

namespace rigfit::python {
namespace {

[[noreturn]] void FailType(const py::handle& value, const std::string& where,
                           const std::string& kind) {
  throw InputError(where + " must be " + kind + ", got " + std::string(py::repr(value)) + " (" +
                   std::string(py::str(py::type::of(value).attr("__name__"))) + ")");
}

/// True for Python's and numpy's bools, which a number keyword refuses.
bool IsBool(const py::handle& value) {
  if (py::isinstance<py::bool_>(value)) return true;
  return std::string(py::str(py::type::of(value).attr("__name__"))) == "bool_";
}

template <typename Integer>
void ReadInteger(const py::handle& value, const std::string& where, Integer* out,
                 const std::string& kind) {
  if (IsBool(value) || PyIndex_Check(value.ptr()) == 0) FailType(value, where, kind);
  try {
    *out = py::cast<Integer>(value);
  } catch (const py::cast_error&) {
    FailType(value, where, kind);
  }
}

template <typename Real>
void ReadReal(const py::handle& value, const std::string& where, Real* out) {
  const bool number =
      PyFloat_Check(value.ptr()) || PyIndex_Check(value.ptr()) || py::hasattr(value, "__float__");
  if (IsBool(value) || !number || py::isinstance<py::str>(value)) {
    FailType(value, where, "a number");
  }
  try {
    *out = static_cast<Real>(py::cast<double>(value));
  } catch (const py::cast_error&) {
    FailType(value, where, "a number");
  }
}

template <typename T>
void ReadList(const py::handle& value, const std::string& where, std::vector<T>* out,
              const std::string& kind) {
  if (!py::isinstance<py::sequence>(value) || py::isinstance<py::str>(value)) {
    FailType(value, where, kind);
  }
  out->clear();
  const auto items = py::reinterpret_borrow<py::sequence>(value);
  for (size_t i = 0; i < py::len(items); ++i) {
    T item{};
    ReadKeyword(items[i], where + "[" + std::to_string(i) + "]", &item);
    out->push_back(item);
  }
}

}  // namespace

void ReadKeyword(const py::handle& value, const std::string& where, bool* out) {
  if (!IsBool(value)) FailType(value, where, "True or False");
  *out = py::cast<bool>(value);
}

void ReadKeyword(const py::handle& value, const std::string& where, int* out) {
  ReadInteger(value, where, out, "an integer");
}

void ReadKeyword(const py::handle& value, const std::string& where, std::uint64_t* out) {
  ReadInteger(value, where, out, "an integer in [0, 2^64 - 1]");
}

void ReadKeyword(const py::handle& value, const std::string& where, double* out) {
  ReadReal(value, where, out);
}

void ReadKeyword(const py::handle& value, const std::string& where, float* out) {
  ReadReal(value, where, out);
}

void ReadKeyword(const py::handle& value, const std::string& where, std::string* out) {
  if (!py::isinstance<py::str>(value)) FailType(value, where, "a str");
  *out = py::cast<std::string>(value);
}

void ReadKeyword(const py::handle& value, const std::string& where, std::vector<int>* out) {
  ReadList(value, where, out, "a list of integers");
}

void ReadKeyword(const py::handle& value, const std::string& where, std::vector<double>* out) {
  ReadList(value, where, out, "a list of numbers");
}

void FailUnknownKeyword(const std::string& command, const std::string& name,
                        const std::vector<std::string>& names) {
  std::string list;
  for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
  throw InputError(command + ": unknown keyword '" + name + "' (" + command + " takes " +
                   (list.empty() ? std::string("none") : list) + ")");
}

}  // namespace rigfit::python

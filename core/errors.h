// rigfit's error policy, written down once:
// - I/O and configuration throw InputError, naming the file and the field at fault.
// - Solvers never throw on bad geometry: they return a result struct with `success`
//   and `message`.
// - The CLI maps InputError to exit code 2, other exceptions to 1 (internal error).
// - assert() only for programmer errors.
#pragma once

#include <stdexcept>
#include <string>

namespace rigfit {

/// Bad input from the user: a file, a field or a value that rigfit cannot use.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace rigfit

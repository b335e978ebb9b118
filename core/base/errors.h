// Errors from bad input or parameters (the message is one line naming the file or parameter),
// and the cancel that is not one.
#pragma once

#include <stdexcept>
#include <string>

namespace cvt {

// The input (file, selection, parameter) cannot be used; what() names it and says why.
struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The user cancelled a running stage. Not a std::exception on purpose: a cancel is no error, so
// a `catch (const std::exception&)` that reports errors lets it pass on to the caller that
// handles cancels (CLI: exit 130; viewer: the job's 'cancelled' status).
struct Cancelled {
  const char* what() const noexcept { return "cancelled"; }
};

}  // namespace cvt

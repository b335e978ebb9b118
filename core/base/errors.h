// Errors from bad input or parameters; the message is one line naming the file or parameter.
#pragma once

#include <stdexcept>
#include <string>

namespace cvt {

// The input (file, selection, parameter) cannot be used; what() names it and says why.
struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The user cancelled a running stage.
struct Cancelled : std::runtime_error {
  Cancelled() : std::runtime_error("cancelled") {}
};

}  // namespace cvt

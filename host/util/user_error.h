// The host tools' one error type for what a user can fix (a bad file, field, option or device).
#pragma once

#include <stdexcept>

namespace mfns::host {

// A user-facing error: what() is one line naming the file, field or device and what is wrong.
// Tools print it as "<tool>: <what>" and exit 1.
class UserError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace mfns::host

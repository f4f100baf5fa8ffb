// Errors at the project's boundaries (files, command line, messages).
//
// An InputError names *where* the problem is (a field path such as `targets[2].position_m`,
// or a file) and *why*, so the message a user sees is "FIELD: REASON".
#pragma once

#include <stdexcept>
#include <string>

namespace ridgeline {

class InputError : public std::runtime_error {
 public:
  InputError(std::string field, std::string reason)
      : std::runtime_error(field.empty() ? reason : field + ": " + reason),
        field_(std::move(field)),
        reason_(std::move(reason)) {}

  /// Path of the offending field or file, e.g. `uavs[1].vehicle.tau_v_s`.
  const std::string& field() const { return field_; }
  /// Why the value is rejected, in words a user can act on.
  const std::string& reason() const { return reason_; }

 private:
  std::string field_;
  std::string reason_;
};

}  // namespace ridgeline

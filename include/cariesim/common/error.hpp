#pragma once
/// Errors of the offline pipeline (mesh import, scene parsing, tree building). The servo step never
/// throws; it answers bad input with flags (render/step.hpp).

#include <stdexcept>
#include <string>

namespace cariesim {

/// An input problem with a message that names what was wrong and where (file, line:column, field).
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace cariesim

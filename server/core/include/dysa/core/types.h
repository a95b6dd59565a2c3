// Basic types shared by every part of the core.
#pragma once

#include <Eigen/Core>
#include <array>
#include <stdexcept>
#include <string>

namespace dysa {

// Particle state is single precision: it halves memory traffic in the neighbour loops and
// matches what a GPU backend stores. Parameters and scene geometry are double.
using Real = float;
using Vec3 = Eigen::Matrix<Real, 3, 1>;
using Vec3d = Eigen::Vector3d;

// Axis-aligned box [min, max].
struct Aabb {
  Vec3d min = Vec3d::Zero();
  Vec3d max = Vec3d::Zero();

  Vec3d Size() const { return max - min; }
  Vec3d Center() const { return 0.5 * (min + max); }
  bool Contains(const Vec3d& p) const {
    return (p.array() >= min.array()).all() && (p.array() <= max.array()).all();
  }
};

// Which axes of a domain wrap around (x, y, z): a particle leaving through one face enters
// through the opposite one, and neighbours are found across the seam.
using Periodicity = std::array<bool, 3>;

// A scene, parameter or command-line value that is not acceptable. field() names what was
// wrong (a JSON path such as "fluid_blocks[0].spacing" or a parameter name); what() is a full
// sentence for the user that includes the field and, where one exists, the allowed range.
class ConfigError : public std::runtime_error {
 public:
  ConfigError(std::string field, const std::string& message)
      : std::runtime_error(field.empty() ? message : field + ": " + message),
        field_(std::move(field)),
        message_(message) {}
  const std::string& field() const { return field_; }
  // The message without the field prefix.
  const std::string& message() const { return message_; }

 private:
  std::string field_;
  std::string message_;
};

}  // namespace dysa

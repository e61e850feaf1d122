#pragma once
/// \file geometry/motion.hpp
/// \brief Rigid transforms and prescribed wall motion: a pose x = R x_ref + t per time and a wall
/// velocity field v_wall(x, t) (translation, rotation about a moving centre, or user callables).
#include <Eigen/Core>
#include <cmath>
#include <functional>
#include <type_traits>
#include <utility>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/geometry/detail/primitives.hpp"

namespace mpskit::geometry {

/// Angular velocity: a scalar (rad/s, counter-clockwise) in 2D, a vector (rad/s) in 3D.
template <int D>
using angular_velocity = std::conditional_t<D == 2, double, vec<3>>;

/// Rigid transform x ↦ R x + t (R a rotation).
template <int D>
struct rigid_transform {
  mat<D> rotation = mat<D>::Identity();  ///< R
  vec<D> translation = vec<D>::Zero();   ///< t
  /// Applies the transform to a point.
  vec<D> apply(const vec<D>& x) const { return rotation * x + translation; }
};

/// Rotation matrix for an angle θ (2D) or a rotation vector θ·axis (3D, Rodrigues' formula).
inline mat<2> rotation_matrix(double theta) {
  mat<2> r;
  const double c = std::cos(theta), s = std::sin(theta);
  r << c, -s, s, c;
  return r;
}
/// Rodrigues: R = I + sin θ K + (1 − cos θ) K², K the cross-product matrix of the unit axis.
inline mat<3> rotation_matrix(const vec<3>& rotation_vector) {
  const double theta = rotation_vector.norm();
  if (theta == 0.0) return mat<3>::Identity();
  const vec<3> k = rotation_vector / theta;
  mat<3> kx;
  kx << 0, -k.z(), k.y(), k.z(), 0, -k.x(), -k.y(), k.x(), 0;
  return (mat<3>::Identity() + std::sin(theta) * kx + (1.0 - std::cos(theta)) * (kx * kx)).eval();
}

/// ω × r: in 2D ω is the scalar z-component, so ω × r = ω (−r_y, r_x).
inline vec<2> cross_omega(double omega, const vec<2>& r) { return vec<2>(-omega * r.y(), omega * r.x()); }
inline vec<3> cross_omega(const vec<3>& omega, const vec<3>& r) { return detail::cross3(omega, r); }

/// Prescribed motion of a polygon set: pose(t) and wall velocity v(x, t). The reference geometry is
/// the set as constructed (pose at t = 0 is the identity for the built-in motions).
template <int D>
requires Dimension<D>
class prescribed_motion final {
 public:
  /// Pose as a function of time.
  using pose_function = std::function<rigid_transform<D>(double)>;
  /// Wall velocity at a (current) point and time.
  using velocity_function = std::function<vec<D>(const vec<D>&, double)>;

  /// A fixed wall (identity pose, zero velocity).
  prescribed_motion() = default;

  /// Constant translation velocity U (m/s): x(t) = x_ref + U t, v = U.
  static prescribed_motion translation(const vec<D>& velocity) {
    return rigid(vec<D>::Zero(), velocity, angular_velocity<D>{zero_omega()});
  }
  /// Constant rotation ω (rad/s) about a fixed centre c: x(t) = R(ω t)(x_ref − c) + c, v = ω × (x − c).
  static prescribed_motion rotation(const vec<D>& centre, const angular_velocity<D>& omega) {
    return rigid(centre, vec<D>::Zero(), omega);
  }
  /// Constant translation U and rotation ω about a centre that starts at c and moves with U:
  /// x(t) = R(ω t)(x_ref − c) + c + U t, v(x) = U + ω × (x − c − U t).
  static prescribed_motion rigid(const vec<D>& centre, const vec<D>& velocity,
                                 const angular_velocity<D>& omega) {
    check_finite(centre, "centre");
    check_finite(velocity, "velocity");
    if constexpr (D == 2) {
      if (!std::isfinite(omega))
        fail("geometry::prescribed_motion: angular velocity must be finite, got ", omega);
    } else {
      check_finite(omega, "angular velocity");
    }
    prescribed_motion m;
    m.moving_ = true;
    m.pose_ = [centre, velocity, omega](double t) {
      rigid_transform<D> x;
      x.rotation = rotation_matrix(omega * t);
      x.translation = (centre + velocity * t - x.rotation * centre).eval();
      return x;
    };
    m.velocity_ = [centre, velocity, omega](const vec<D>& x, double t) {
      const vec<D> r = x - centre - velocity * t;
      return (velocity + cross_omega(omega, r)).eval();
    };
    return m;
  }
  /// User callables: pose(t) and v(x, t). Either may be empty: an empty pose keeps the geometry
  /// fixed (e.g. a conveyor belt with tangential velocity), an empty velocity means v = 0.
  static prescribed_motion callable(pose_function pose, velocity_function velocity) {
    prescribed_motion m;
    m.moving_ = static_cast<bool>(pose);
    m.pose_ = std::move(pose);
    m.velocity_ = std::move(velocity);
    return m;
  }

  /// Pose at time t.
  rigid_transform<D> pose(double t) const { return pose_ ? pose_(t) : rigid_transform<D>{}; }
  /// Wall velocity at point x (current configuration) and time t.
  vec<D> velocity(const vec<D>& x, double t) const { return velocity_ ? velocity_(x, t) : vec<D>::Zero(); }
  /// True if the pose changes with time (the hierarchy must be refitted).
  bool moves() const { return moving_; }

 private:
  static angular_velocity<D> zero_omega() {
    if constexpr (D == 2) {
      return 0.0;
    } else {
      return vec<3>::Zero();
    }
  }
  template <class V>
  static void check_finite(const V& v, const char* what) {
    if (!v.allFinite()) fail("geometry::prescribed_motion: ", what, " must be finite");
  }
  pose_function pose_;
  velocity_function velocity_;
  bool moving_ = false;
};

}  // namespace mpskit::geometry

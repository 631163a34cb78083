#include "mcvo/geometry/interpolate.h"

#include "mcvo/geometry/so3.h"

namespace mcvo {

Rigid3d InterpolatePose(const Rigid3d& world_from_a, const Rigid3d& world_from_b, double alpha) {
  // Slerp as a_from_b's rotation scaled in the tangent space; So3Log takes the
  // shortest arc (angle <= pi) whatever the quaternion signs.
  const Eigen::Quaterniond a_from_b = world_from_a.rotation.conjugate() * world_from_b.rotation;
  const Eigen::Quaterniond rotation = world_from_a.rotation * So3Exp(alpha * So3Log(a_from_b));
  const Eigen::Vector3d translation =
      (1.0 - alpha) * world_from_a.translation + alpha * world_from_b.translation;
  return Rigid3d(rotation, translation);
}

Rigid3d InterpolatePose(const Rigid3d& world_from_a, int64_t t_a_ns, const Rigid3d& world_from_b,
                        int64_t t_b_ns, int64_t t_ns) {
  if (t_a_ns == t_b_ns) return world_from_a;
  // Differences in integer ns first: exact, then one division.
  const double alpha = static_cast<double>(t_ns - t_a_ns) / static_cast<double>(t_b_ns - t_a_ns);
  return InterpolatePose(world_from_a, world_from_b, alpha);
}

}  // namespace mcvo

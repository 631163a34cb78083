// Interpolation of stamped poses: rotation by slerp (along the shortest
// arc, via So3Exp/So3Log), translation linearly, both with the same
// fraction alpha = (t - t_a) / (t_b - t_a).
#pragma once

#include <cstdint>

#include "mcvo/geometry/rigid3d.h"

namespace mcvo {

// world_from_body at t_ns, from world_from_a at t_a_ns and world_from_b at
// t_b_ns. alpha outside [0, 1] extrapolates (the caller decides whether it
// may). When t_a_ns == t_b_ns, returns world_from_a.
Rigid3d InterpolatePose(const Rigid3d& world_from_a, int64_t t_a_ns, const Rigid3d& world_from_b,
                        int64_t t_b_ns, int64_t t_ns);

// The same with an explicit fraction: alpha = 0 -> a, alpha = 1 -> b.
Rigid3d InterpolatePose(const Rigid3d& world_from_a, const Rigid3d& world_from_b, double alpha);

}  // namespace mcvo

// Standing still on a rendered route: a stand at the start and stops along
// the way, as a time warp between the sequence's clock and the route's.
//
// The rig drives the route (trajectory.h) on route time tau(t). Without
// stops tau(t) = t. A stand of S seconds at the start holds tau = 0 for S
// seconds, then the rig pulls away; a stop at time T of D seconds slows the
// rig down, holds it for D seconds, then pulls away. Pulling away and slowing
// down take ramp_s seconds each, with the speed factor dtau/dt following a
// smoothstep (3u^2 - 2u^3), so speed and acceleration are continuous: a car
// at a traffic light, not a teleport. Moving objects of the scene keep the
// sequence's clock (traffic goes on while the rig stands).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace mcvo::synth {

struct Stop {
  double at_s = 0.0;        // sequence time the rig starts slowing down
  double duration_s = 0.0;  // time it stands still
};

struct StopPlan {
  double stand_s = 0.0;  // standing at the start (0: drives off at once, at cruise speed)
  std::vector<Stop> stops;
  double ramp_s = 4.0;  // pulling away / slowing down

  bool Empty() const { return stand_s <= 0.0 && stops.empty(); }
  // Throws UsageError naming the field (stand_s < 0, a stop before the end of
  // the previous one or of the stand, ramp_s <= 0, non-finite values).
  void Check() const;
  // Route time, seconds, at sequence time t_s (t_s >= 0; non-decreasing in t_s).
  double RouteSeconds(double t_s) const;
  // Whether the rig stands still at t_s (route speed factor zero).
  bool Standing(double t_s) const;
};

// Parses --stop "AT:DURATION" (seconds), e.g. "12:3". Throws UsageError.
Stop ParseStop(const std::string& text);

}  // namespace mcvo::synth

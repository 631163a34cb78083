// Standing still on a rendered route (see stops.h).
#include "mcvo/synth/stops.h"

#include <cmath>

#include "mcvo/util/error.h"
#include "mcvo/util/strings.h"

namespace mcvo::synth {
namespace {

// Integral over [0, u] of the smoothstep 3x^2 - 2x^3 (u in [0, 1]).
double RampUp(double u) { return u * u * u - 0.5 * u * u * u * u; }

// A piece of the warp: from t0 on, the speed factor is 0, 1, rising or falling.
enum class Phase { kStill, kCruise, kRising, kFalling };

struct Piece {
  double t0;
  Phase phase;
};

std::vector<Piece> Pieces(const StopPlan& plan) {
  std::vector<Piece> pieces;
  double t = 0.0;
  if (plan.stand_s > 0.0) {
    pieces.push_back({0.0, Phase::kStill});
    pieces.push_back({plan.stand_s, Phase::kRising});
    t = plan.stand_s + plan.ramp_s;
  }
  pieces.push_back({t, Phase::kCruise});
  for (const Stop& stop : plan.stops) {
    pieces.push_back({stop.at_s, Phase::kFalling});
    pieces.push_back({stop.at_s + plan.ramp_s, Phase::kStill});
    pieces.push_back({stop.at_s + plan.ramp_s + stop.duration_s, Phase::kRising});
    pieces.push_back({stop.at_s + 2.0 * plan.ramp_s + stop.duration_s, Phase::kCruise});
  }
  return pieces;
}

// Route time gained over dt seconds of a piece of the phase (dt within the piece).
double Gain(Phase phase, double dt, double ramp_s) {
  switch (phase) {
    case Phase::kStill:
      return 0.0;
    case Phase::kCruise:
      return dt;
    case Phase::kRising:
      return ramp_s * RampUp(dt / ramp_s);
    case Phase::kFalling:
      return dt - ramp_s * RampUp(dt / ramp_s);
  }
  return dt;
}

}  // namespace

void StopPlan::Check() const {
  if (!(std::isfinite(stand_s) && stand_s >= 0.0))
    throw UsageError(StrCat("stand: must be >= 0 seconds, got ", FormatDouble(stand_s)));
  if (!(std::isfinite(ramp_s) && ramp_s > 0.0))
    throw UsageError(StrCat("stop ramp: must be > 0 seconds, got ", FormatDouble(ramp_s)));
  // The first stop may begin once the rig cruises again.
  double free_from = stand_s > 0.0 ? stand_s + ramp_s : 0.0;
  for (size_t i = 0; i < stops.size(); ++i) {
    const Stop& s = stops[i];
    if (!(std::isfinite(s.at_s) && std::isfinite(s.duration_s) && s.duration_s > 0.0 && s.at_s >= free_from)) {
      throw UsageError(StrCat("stop ", i + 1, ": ", FormatDouble(s.at_s), ":", FormatDouble(s.duration_s),
                              " must start at or after ", FormatDouble(free_from),
                              " s (after the stand or the previous stop and its ramps) and last > 0 s"));
    }
    free_from = s.at_s + 2.0 * ramp_s + s.duration_s;
  }
}

double StopPlan::RouteSeconds(double t_s) const {
  if (Empty()) return t_s;
  if (!(t_s > 0.0)) return 0.0;
  const std::vector<Piece> pieces = Pieces(*this);
  double tau = 0.0;
  for (size_t i = 0; i < pieces.size(); ++i) {
    const double end = i + 1 < pieces.size() ? pieces[i + 1].t0 : t_s;
    if (t_s <= end) return tau + Gain(pieces[i].phase, t_s - pieces[i].t0, ramp_s);
    tau += Gain(pieces[i].phase, end - pieces[i].t0, ramp_s);
  }
  return tau;
}

bool StopPlan::Standing(double t_s) const {
  const std::vector<Piece> pieces = Pieces(*this);
  for (size_t i = 0; i < pieces.size(); ++i) {
    const double end = i + 1 < pieces.size() ? pieces[i + 1].t0 : INFINITY;
    if (t_s >= pieces[i].t0 && t_s < end) return pieces[i].phase == Phase::kStill;
  }
  return false;
}

Stop ParseStop(const std::string& text) {
  const std::vector<std::string_view> parts = SplitFields(text, ':');
  const auto at = parts.size() == 2 ? ParseDouble(parts[0]) : std::nullopt;
  const auto duration = parts.size() == 2 ? ParseDouble(parts[1]) : std::nullopt;
  if (!at || !duration) throw UsageError("--stop: expected AT:DURATION in seconds (e.g. 12:3), got '" + text + "'");
  return Stop{*at, *duration};
}

}  // namespace mcvo::synth

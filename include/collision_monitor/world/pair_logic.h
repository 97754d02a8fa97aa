/// \file
/// Pure per-pair logic of the world model, free of geometry and of any state: the status
/// machine with hysteresis, the events of a transition and the distance beyond which a pair is
/// certainly CLEAR. Header-only so that it is unit-tested on its own
/// (test/world/test_pair_logic.cpp).
///
/// Status machine (d = signed distance in metres, w = warning_distance, c = contact_distance,
/// h = hysteresis):
///   from CLEAR (or UNKNOWN, or a new pair): COLLISION if d <= c, else WARNING if d < w, else
///   CLEAR; from WARNING: COLLISION if d <= c, else WARNING while d < w + h, else CLEAR; from
///   COLLISION: COLLISION while d <= c + h, else WARNING while d < w + h, else CLEAR.
/// A NaN distance (a failed narrow phase, WorldModel) gives UNKNOWN, never CLEAR; +inf means
/// beyond reach (no narrow phase run): CLEAR.
///
/// Event scheme: a status is an interval; CLEAR has no events. A transition from X to Y emits
/// END(X) when X is not CLEAR, then BEGIN(Y) when Y is not CLEAR. So CLEAR->COLLISION is one
/// COLLISION_BEGIN, WARNING->COLLISION is WARNING_END then COLLISION_BEGIN, and every BEGIN of a
/// pair is matched by exactly one END (consumers can count open intervals per type).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "collision_monitor/world/world_model.h"

namespace collision_monitor {
namespace world {

/// Status after `prev` given the signed distance `d` (m). See the file comment.
inline PairStatus nextStatus(PairStatus prev, double d, const Settings& s) {
  if (std::isnan(d)) return PairStatus::Unknown;
  const double w = s.warning_distance;
  const double c = s.contact_distance;
  const double h = s.hysteresis;
  switch (prev) {
    case PairStatus::Collision:
      if (d <= c + h) return PairStatus::Collision;
      return d < w + h ? PairStatus::Warning : PairStatus::Clear;
    case PairStatus::Warning:
      if (d <= c) return PairStatus::Collision;
      return d < w + h ? PairStatus::Warning : PairStatus::Clear;
    case PairStatus::Clear:
    case PairStatus::Unknown:
      break;
  }
  if (d <= c) return PairStatus::Collision;
  return d < w ? PairStatus::Warning : PairStatus::Clear;
}

/// Whether nextStatus(prev, d) == prev for every d in [lo, hi]. Each status holds on an interval
/// of distances (an intersection of half-lines), so its two ends tell.
inline bool holdsThrough(PairStatus prev, double lo, double hi, const Settings& s) {
  return nextStatus(prev, lo, s) == prev && nextStatus(prev, hi, s) == prev;
}

/// A distance (m) beyond which a pair with previous status `prev` is certainly CLEAR:
/// d > clearCutoff(prev) implies nextStatus(prev, d) == Clear. Used to skip narrow-phase work.
inline double clearCutoff(PairStatus prev, const Settings& s) {
  const double base = std::max(s.warning_distance, s.contact_distance);
  if (prev == PairStatus::Warning || prev == PairStatus::Collision) return base + s.hysteresis;
  return base;
}

/// The cutoff for any previous status (the broad phase uses it for every pair).
inline double clearCutoffAny(const Settings& s) {
  return std::max(s.warning_distance, s.contact_distance) + std::max(0.0, s.hysteresis);
}

inline EventType beginEvent(PairStatus s) {
  switch (s) {
    case PairStatus::Collision:
      return EventType::CollisionBegin;
    case PairStatus::Warning:
      return EventType::WarningBegin;
    default:
      return EventType::UnknownBegin;
  }
}

inline EventType endEvent(PairStatus s) {
  switch (s) {
    case PairStatus::Collision:
      return EventType::CollisionEnd;
    case PairStatus::Warning:
      return EventType::WarningEnd;
    default:
      return EventType::UnknownEnd;
  }
}

/// The events of the transition `from` -> `to`, in order, written to `out`; returns how many
/// (0, 1 or 2). See the file comment for the scheme.
inline int transitionEvents(PairStatus from, PairStatus to, EventType out[2]) {
  if (from == to) return 0;
  int n = 0;
  if (from != PairStatus::Clear) out[n++] = endEvent(from);
  if (to != PairStatus::Clear) out[n++] = beginEvent(to);
  return n;
}

/// Swaps the roles of a and b in a result: names, witness points, normal.
inline void flipPair(PairResult* r) {
  std::swap(r->body_a, r->body_b);
  std::swap(r->point_a, r->point_b);
  r->normal = -r->normal;
}

}  // namespace world
}  // namespace collision_monitor

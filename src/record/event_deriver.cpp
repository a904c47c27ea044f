#include "record/event_deriver.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "cariesim/device/safety.hpp"

namespace cariesim::record {

EventDeriver::EventDeriver(double soft_tissue_threshold, double period)
    : threshold_(soft_tissue_threshold), period_(period) {
  // The flag runs that become episodes: overruns, then safety faults and the step's clamps (kind
  // "safety"), then engine flags.
  flags_ = {{
      {false, 0u, "overrun", "cycles", {}},
      {true, kSafetyStale, "safety", "stale_input", {}},
      {true, kSafetyNonFinite, "safety", "non_finite", {}},
      {true, kSafetyInvalidInput, "safety", "invalid_input", {}},
      {false, kFlagForceClamped, "safety", "force_clamped", {}},  // the step's clamp, the one clamp
      {false, kFlagTorqueClamped, "safety", "torque_clamped", {}},
      {false, kFlagNonFiniteInput, "engine", "non_finite_pose", {}},
      {false, kFlagJumpLimited, "engine", "jump_limited", {}},
      {false, kFlagInfeasible, "engine", "infeasible", {}},
      {false, kFlagContactOverflow, "engine", "contact_overflow", {}},
      {false, kFlagQpRowsFull, "engine", "qp_rows_full", {}},
      {false, kFlagLagging, "engine", "lagging", {}},
      {false, kFlagQpActiveSetFull, "engine", "qp_active_set_full", {}},
      {false, kFlagQpIterationLimit, "engine", "qp_iteration_limit", {}},
      {false, kFlagWorkBudget, "engine", "work_budget", {}},
      {false, kFlagCatchingUp, "engine", "catching_up", {}},
  }};
}

void EventDeriver::open(Episode& episode, const RecordedEvent& event) {
  episode.id = next_id_++;
  episode.event = event;
  episode.last_t = event.t;
  episode.stored = false;
  episode.dirty = true;
}

// A closed episode is handed out once more in its final form.
void EventDeriver::close(Episode& episode) {
  if (episode.id < 0) return;
  if (episode.dirty || !episode.stored) pending_.push_back({episode.id, !episode.stored, episode.event});
  episode.id = -1;
}

void EventDeriver::instant(const RecordedEvent& event) { pending_.push_back({next_id_++, true, event}); }

void EventDeriver::add_external(const RecordedEvent& event) { instant(event); }

void EventDeriver::add(const ServoSample& s) {
  // Gaps: the time advanced by more than 1.5 periods (samples dropped upstream) or not at all.
  if (have_previous_ && period_ > 0.0 && std::isfinite(s.t) && std::isfinite(previous_t_)) {
    const double dt = s.t - previous_t_;
    if (dt > 1.5 * period_) {
      instant({previous_t_, "gap", "missing_samples", std::round(dt / period_) - 1.0, -1, dt});
    } else if (dt <= 0.0) {
      instant({s.t, "gap", "time_not_increasing", dt, -1, 0.0});
    }
  }

  track_state(s);
  track_soft_tissue(s);
  track_flags(s);

  // Buttons: one event per edge of each bit.
  const uint32_t changed = s.buttons ^ previous_buttons_;
  for (int bit = 0; bit < 32; ++bit) {
    if ((changed & (1u << bit)) == 0) continue;
    const bool pressed = (s.buttons & (1u << bit)) != 0;
    instant({s.t, "button", pressed ? "pressed" : "released", static_cast<double>(bit), -1, 0.0});
  }

  previous_buttons_ = s.buttons;
  previous_state_ = s.state;
  previous_t_ = s.t;
  have_previous_ = true;
}

// State changes, and penetration episodes from entering a lesion (inserting) until the probe is back
// on the surface or free, with the deepest insertion reached.
void EventDeriver::track_state(const ServoSample& s) {
  const bool inside = penetrating(s.state);
  if (s.state != previous_state_) {
    const std::string detail = std::string(state_name(previous_state_)) + "->" + state_name(s.state);
    instant({s.t, "state", detail, static_cast<double>(s.depth), s.lesion, 0.0});
    if (!inside) close(penetration_);
  }
  if (inside && penetration_.id < 0) {
    open(penetration_, {s.t, "penetration", "max_depth", static_cast<double>(s.depth), s.lesion, 0.0});
  } else if (inside) {
    RecordedEvent& e = penetration_.event;
    e.value = std::max(e.value, static_cast<double>(s.depth));
    e.duration = s.t - e.t;
    penetration_.dirty = true;
  }
}

// Soft-tissue presses above the threshold, one episode each, with the peak force; the episode ends
// when the force falls below kSoftTissueRelease x threshold (so noise at the threshold is one press).
void EventDeriver::track_soft_tissue(const ServoSample& s) {
  const double force = s.soft_tissue_force;
  if (soft_tissue_.id < 0) {
    if (force > threshold_) open(soft_tissue_, {s.t, "soft_tissue", "peak_force", force, -1, 0.0});
    return;
  }
  if (!(force >= kSoftTissueRelease * threshold_)) {
    close(soft_tissue_);
    return;
  }
  RecordedEvent& e = soft_tissue_.event;
  e.value = std::max(e.value, force);
  e.duration = s.t - e.t;
  soft_tissue_.dirty = true;
}

// Runs of a flag (gaps shorter than kEpisodeGap joined): value counts the flagged cycles.
void EventDeriver::track_flags(const ServoSample& s) {
  for (FlagTrack& track : flags_) {
    const bool set =
        track.mask == 0 ? s.overrun : ((track.safety ? s.safety_flags : s.step_flags) & track.mask) != 0;
    Episode& episode = track.episode;
    if (set && episode.id < 0) {
      open(episode, {s.t, track.kind, track.detail, 1.0, -1, 0.0});
    } else if (set) {
      episode.event.value += 1.0;
      episode.event.duration = s.t - episode.event.t;
      episode.last_t = s.t;
      episode.dirty = true;
    } else if (episode.id >= 0 && !(s.t - episode.last_t < kEpisodeGap)) {
      close(episode);
    }
  }
}

void EventDeriver::finish() {
  close(penetration_);
  close(soft_tissue_);
  for (FlagTrack& track : flags_) close(track.episode);
}

// Pending instants and closed episodes first, then the open episodes that changed.
void EventDeriver::take(std::vector<Change>& out) {
  out.insert(out.end(), pending_.begin(), pending_.end());
  pending_.clear();
  const auto hand_out = [&out](Episode& episode) {
    if (episode.id < 0 || !episode.dirty) return;
    out.push_back({episode.id, !episode.stored, episode.event});
    episode.stored = true;
    episode.dirty = false;
  };
  hand_out(penetration_);
  hand_out(soft_tissue_);
  for (FlagTrack& track : flags_) hand_out(track.episode);
}

}  // namespace cariesim::record

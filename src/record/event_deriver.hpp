#pragma once
// Events derived from the sample stream by the recorder's writer thread (docs/records.md lists them):
// instantaneous events (state changes, button edges, gaps in the sample times) and episodes
// (penetration of a lesion, a soft-tissue press, overruns, safety and engine flags) that are written
// when they start and updated with every batch while they last, so a crash loses at most the last
// batch of an episode's progress too.
#include <array>
#include <cstdint>
#include <vector>

#include "cariesim/record/recorder.hpp"

namespace cariesim::record {

class EventDeriver {
 public:
  /// An event to write: `fresh` the first time (INSERT with row id `id`), afterwards an update of
  /// the same row (its value and duration grew).
  struct Change {
    int64_t id = 0;
    bool fresh = true;
    RecordedEvent event;
  };

  /// `soft_tissue_threshold` in N; `period` in s is the expected sample interval (1 / rate; 0 or
  /// less: no gap events).
  EventDeriver(double soft_tissue_threshold, double period);

  /// Feeds the next sample.
  void add(const ServoSample& sample);
  /// Adds an event from outside the stream (Recorder::record_event).
  void add_external(const RecordedEvent& event);
  /// Ends the open episodes (end of the recording).
  void finish();
  /// Appends the events created or changed since the last call to `out`.
  void take(std::vector<Change>& out);

  /// A soft-tissue episode ends when the force falls below this fraction of the threshold.
  static constexpr double kSoftTissueRelease = 0.5;
  /// s: a flag episode (overruns, safety, engine) ends after this long without the flag.
  static constexpr double kEpisodeGap = 0.1;

 private:
  struct Episode {
    int64_t id = -1;  // -1: none open
    RecordedEvent event;
    double last_t = 0.0;  // s, last sample the condition held
    bool stored = false;  // handed out at least once
    bool dirty = false;   // changed since handed out
  };
  // A bit of a flag word whose runs become episodes.
  struct FlagTrack {
    bool safety = false;  // safety_flags (else step_flags or, for mask 0, the overrun bit)
    uint32_t mask = 0;
    const char* kind = "";
    const char* detail = "";
    Episode episode;
  };

  void open(Episode& episode, const RecordedEvent& event);
  void close(Episode& episode);
  void instant(const RecordedEvent& event);
  void track_flags(const ServoSample& s);
  void track_soft_tissue(const ServoSample& s);
  void track_state(const ServoSample& s);

  double threshold_;
  double period_;
  int64_t next_id_ = 0;
  bool have_previous_ = false;
  double previous_t_ = 0.0;
  InteractionState previous_state_ = InteractionState::Free;
  uint32_t previous_buttons_ = 0;
  Episode penetration_;
  Episode soft_tissue_;
  std::array<FlagTrack, 16> flags_;
  std::vector<Change> pending_;  // instants and closed episodes, in order
};

}  // namespace cariesim::record

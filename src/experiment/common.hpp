#pragma once
// Shared pieces of the experiments: trajectories made of straight segments, CSV output, statistics.
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "cariesim/experiment/experiments.hpp"
#include "cariesim/io/json.hpp"
#include "cariesim/experiment/simulate.hpp"

namespace cariesim::experiment {

/// A trajectory of straight segments: each call adds the pose reached `duration` s after the last.
class Path {
 public:
  explicit Path(const Pose& start) { trajectory_.add(0.0, start); }
  Path& to(double duration, const Pose& pose) {
    trajectory_.add(trajectory_.end() + duration, pose);
    return *this;
  }
  Path& hold(double duration) { return to(duration, trajectory_.pose.back()); }
  [[nodiscard]] const Trajectory& trajectory() const { return trajectory_; }
  [[nodiscard]] double end() const { return trajectory_.end(); }  ///< s
  [[nodiscard]] const Pose& last() const { return trajectory_.pose.back(); }

 private:
  Trajectory trajectory_;
};

/// A pose with the given tip position and orientation.
inline Pose at(const Vec3& p, const Quat& q) { return Pose{p, q}; }

/// Writes a CSV (io::CsvWriter) with the column keys and rows of numbers (%.6g) plus an optional last
/// text column.
void write_csv(const std::filesystem::path& file, const std::vector<std::string>& header,
               const std::vector<std::vector<double>>& rows, const std::vector<std::string>& text = {});
/// Writes text to a file; throws cariesim::Error when it cannot.
void write_text(const std::filesystem::path& file, std::string_view text);

/// Deepest overlap (mm, 0 when none) of the graphic tool with any rigid object over a run: the
/// engine promises at most the rigid tolerance (0.01 mm) after every step (docs/step.md).
double max_rigid_penetration(const Model& model, const std::vector<SimSample>& samples);

/// Largest change of the rendered force (N) between two consecutive steps of a run, leaving out the
/// steps out of free space (a first touch may start at once); the engine promises at most 1 N per 1 ms
/// (docs/step.md).
double max_force_step(const std::vector<SimSample>& samples);

/// What every experiment reports over all its runs (summary.json): the deepest overlap with rigid
/// tissue and the largest step-to-step force change.
struct RunChecks {
  double rigid_penetration = 0.0;  ///< mm
  double force_step = 0.0;         ///< N per servo step
  /// Takes one run into account.
  void add(const Model& model, const std::vector<SimSample>& samples);
  /// Writes max_rigid_penetration_mm and max_force_step_N.
  void write(io::JsonWriter& summary) const;
};

/// Progress line on stderr unless quiet.
void say(const ExperimentOptions& options, const std::string& line);

/// Mean and maximum of |v| over samples whose time lies in [t0, t1].
struct Stats {
  double mean = 0.0;
  double peak = 0.0;
  int count = 0;
};
Stats abs_stats(const std::vector<SimSample>& samples, double t0, double t1,
                double (*value)(const SimSample&));

// One function per experiment; each fills `summary` (an open JSON object's fields).
void run_friction(const ExperimentOptions& options, io::JsonWriter& summary);
void run_boundary(const ExperimentOptions& options, io::JsonWriter& summary);
void run_insertion(const ExperimentOptions& options, io::JsonWriter& summary);
void run_oral(const ExperimentOptions& options, io::JsonWriter& summary);

}  // namespace cariesim::experiment

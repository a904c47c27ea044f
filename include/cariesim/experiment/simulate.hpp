#pragma once
/// Headless simulation: drive the haptic tool along a trajectory at a fixed servo rate and record
/// every step (`cariesim sim`, the experiments, the benchmarks).

#include <filesystem>
#include <functional>
#include <vector>

#include "cariesim/device/trajectory_csv.hpp"
#include "cariesim/io/csv.hpp"
#include "cariesim/render/step.hpp"

namespace cariesim {

/// One servo cycle of a run.
struct SimSample {
  double t = 0.0;     ///< s since the trajectory's start
  StepOutput out;     ///< what the step returned (haptic and graphic pose, wrench, state, ...)
};

/// Most servo steps one run may have: 1e8 (28 h at 1 kHz, about 25 GB of CSV). A longer run is an
/// error (sim_step_count), not an allocation failure or a loop of years.
inline constexpr double kMaxSimSteps = 1e8;

/// The number of servo steps that cover `trajectory` at `rate_hz`: floor(span * rate) + 1. Throws
/// cariesim::Error for an empty trajectory, a rate outside [1, 100000] Hz, or a span that needs more
/// than kMaxSimSteps steps (naming the span, the rate and the limit).
std::size_t sim_step_count(const Trajectory& trajectory, double rate_hz);

/// Runs the trajectory like simulate() but keeps nothing: each sample goes to `on_step` as it is
/// made, so memory stays constant however long the run. Returns the number of steps.
std::size_t simulate_each(const Model& model, const Params& params, const Trajectory& trajectory,
                          double rate_hz, const std::function<void(const SimSample&)>& on_step);

/// Runs the trajectory from its start to its end at `rate_hz` (the pose between samples is
/// interpolated: linear position, slerp rotation). The graphic tool starts at the first pose when it
/// is clear, else at the model's home pose. `params` are the materials, gains and limits of the run
/// (the model's defaults when omitted). `on_step` (optional) sees each sample as it is made.
std::vector<SimSample> simulate(const Model& model, const Params& params, const Trajectory& trajectory,
                                double rate_hz, const std::function<void(const SimSample&)>& on_step = {});
std::vector<SimSample> simulate(const Model& model, const Trajectory& trajectory, double rate_hz,
                                const std::function<void(const SimSample&)>& on_step = {});

/// Writes the rows of docs/design.md §6: t, h_px..h_qz, g_px..g_qz, fx,fy,fz,tx,ty,tz, state, depth,
/// contacts, step_us. Throws cariesim::Error when the file cannot be written.
void write_sim_csv(const std::filesystem::path& file, const std::vector<SimSample>& samples);

/// The same CSV written row by row as a run goes (`cariesim sim` streams through it), through the one
/// CSV writer (io/csv.hpp).
class SimCsvWriter {
 public:
  /// Creates `file` and writes the header; throws cariesim::Error naming it when it cannot.
  explicit SimCsvWriter(const std::filesystem::path& file);
  ~SimCsvWriter();
  SimCsvWriter(const SimCsvWriter&) = delete;
  SimCsvWriter& operator=(const SimCsvWriter&) = delete;
  /// Appends one row; throws cariesim::Error when a write fails (e.g. a full disk; rows are written
  /// in blocks, so the failure shows at the block's write or at close()).
  void write(const SimSample& sample);
  /// Flushes and closes; throws cariesim::Error when that fails. Idempotent.
  void close();

 private:
  io::CsvWriter out_;
  bool closed_ = false;
};

}  // namespace cariesim

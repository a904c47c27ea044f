// Recordings, study databases and the paper's experiments for Python (docs/python.md): each read or
// run by the library's own function (load_recording, merge_study_databases, run_experiment) with the
// GIL released, and handed over as columns of numpy arrays.

#include <pybind11/stl.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "bindings.hpp"
#include "cariesim/experiment/experiments.hpp"
#include "cariesim/record/recorder.hpp"
#include "cariesim/training/report.hpp"

namespace py = pybind11;

namespace cariesim::python {

namespace {

// A column of `n` values of type T filled by `get(i)`.
template <typename T, typename Get>
py::array_t<T> column(std::size_t n, Get get) {
  py::array_t<T> out(static_cast<py::ssize_t>(n));
  auto v = out.template mutable_unchecked<1>();
  for (std::size_t i = 0; i < n; ++i) v(static_cast<py::ssize_t>(i)) = get(i);
  return out;
}

// The samples as the columns of samples.csv (docs/records.md), in its order; `state` as its code
// (the package names it). depth, step_us and soft_tissue_force are stored as 32-bit floats and stay so.
py::dict sample_columns(const std::vector<ServoSample>& s) {
  const std::size_t n = s.size();
  py::dict d;
  d["t"] = column<double>(n, [&](std::size_t i) { return s[i].t; });
  const char* pose_names[2][7] = {{"h_px", "h_py", "h_pz", "h_qw", "h_qx", "h_qy", "h_qz"},
                                  {"g_px", "g_py", "g_pz", "g_qw", "g_qx", "g_qy", "g_qz"}};
  for (int p = 0; p < 2; ++p) {
    const auto pose = [&, p](std::size_t i) -> const Pose& { return p == 0 ? s[i].haptic : s[i].graphic; };
    for (int k = 0; k < 3; ++k)
      d[pose_names[p][k]] = column<double>(n, [&, k](std::size_t i) { return pose(i).p[k]; });
    d[pose_names[p][3]] = column<double>(n, [&](std::size_t i) { return pose(i).q.w(); });
    d[pose_names[p][4]] = column<double>(n, [&](std::size_t i) { return pose(i).q.x(); });
    d[pose_names[p][5]] = column<double>(n, [&](std::size_t i) { return pose(i).q.y(); });
    d[pose_names[p][6]] = column<double>(n, [&](std::size_t i) { return pose(i).q.z(); });
  }
  const char* force_names[3] = {"fx", "fy", "fz"};
  const char* torque_names[3] = {"tx", "ty", "tz"};
  for (int k = 0; k < 3; ++k)
    d[force_names[k]] = column<double>(n, [&, k](std::size_t i) { return s[i].force[k]; });
  for (int k = 0; k < 3; ++k)
    d[torque_names[k]] = column<double>(n, [&, k](std::size_t i) { return s[i].torque[k]; });
  d["state"] = column<uint8_t>(n, [&](std::size_t i) { return static_cast<uint8_t>(s[i].state); });
  d["depth"] = column<float>(n, [&](std::size_t i) { return s[i].depth; });
  d["contacts"] = column<int64_t>(n, [&](std::size_t i) { return static_cast<int64_t>(s[i].contacts); });
  d["step_us"] = column<float>(n, [&](std::size_t i) { return s[i].step_us; });
  d["lesion"] = column<int64_t>(n, [&](std::size_t i) { return static_cast<int64_t>(s[i].lesion); });
  d["soft_tissue_force"] = column<float>(n, [&](std::size_t i) { return s[i].soft_tissue_force; });
  d["step_flags"] = column<int64_t>(n, [&](std::size_t i) { return static_cast<int64_t>(s[i].step_flags); });
  d["safety_flags"] =
      column<int64_t>(n, [&](std::size_t i) { return static_cast<int64_t>(s[i].safety_flags); });
  d["overrun"] =
      column<int64_t>(n, [&](std::size_t i) { return static_cast<int64_t>(s[i].overrun ? 1 : 0); });
  d["buttons"] = column<int64_t>(n, [&](std::size_t i) { return static_cast<int64_t>(s[i].buttons); });
  return d;
}

// The events as the columns of events.csv.
py::dict event_columns(const std::vector<RecordedEvent>& e) {
  const std::size_t n = e.size();
  py::dict d;
  d["t"] = column<double>(n, [&](std::size_t i) { return e[i].t; });
  std::vector<std::string> kind, detail;
  for (const RecordedEvent& x : e) {
    kind.push_back(x.kind);
    detail.push_back(x.detail);
  }
  d["kind"] = kind;
  d["detail"] = detail;
  d["value"] = column<double>(n, [&](std::size_t i) { return e[i].value; });
  d["lesion"] = column<int64_t>(n, [&](std::size_t i) { return static_cast<int64_t>(e[i].lesion); });
  d["duration"] = column<double>(n, [&](std::size_t i) { return e[i].duration; });
  return d;
}

}  // namespace

void bind_records(py::module_& m) {
  m.def(
      "load_recording",
      [](const std::string& file) {
        Recording r;
        {
          py::gil_scoped_release release;
          r = load_recording(file);
        }
        py::dict session;
        session["scene"] = r.info.scene;
        session["scene_hash"] = r.info.scene_hash;
        session["device"] = r.info.device;
        session["rate_hz"] = r.info.rate_hz;
        session["version"] = r.info.version;
        session["parameters"] = r.info.parameters;
        session["started_at"] = r.info.started_at;
        session["ended_at"] = r.info.ended_at;
        session["batch_seconds"] = r.batch_seconds;
        session["soft_tissue_threshold"] = r.soft_tissue_threshold;
        py::dict out;
        out["session"] = session;
        out["samples"] = sample_columns(r.samples);
        out["events"] = event_columns(r.events);
        return out;
      },
      py::arg("file"), "A session recording as columns (docs/records.md).");

  m.def(
      "read_studies",
      [](const std::vector<std::string>& files) {
        training::MergedStudies merged;
        {
          py::gil_scoped_release release;
          std::vector<std::filesystem::path> paths(files.begin(), files.end());
          merged = training::merge_study_databases(paths);
        }
        // One row per trial (finished, then unfinished), and its scores in long form keyed by the row.
        py::dict trials, scores;
        std::vector<std::string> file, station, participant, study, kind, started, ended;
        std::vector<int64_t> id, trial, seed, s_row;
        std::vector<std::string> s_name, s_level, s_unit;
        std::vector<double> s_value;
        std::vector<bool> finished;
        for (const auto* group : {&merged.finished, &merged.unfinished}) {
          for (const training::StudyTrial& t : *group) {
            for (const training::TrialScore& s : t.scores) {
              s_row.push_back(static_cast<int64_t>(id.size()));
              s_name.push_back(s.name);
              s_level.push_back(s.level);
              s_value.push_back(s.value);
              s_unit.push_back(s.unit);
            }
            file.push_back(t.file);
            id.push_back(t.id);
            station.push_back(t.station);
            participant.push_back(t.participant);
            study.push_back(t.study);
            kind.push_back(t.kind);
            trial.push_back(t.trial);
            seed.push_back(t.seed);
            started.push_back(t.started_at);
            ended.push_back(t.ended_at.value_or(""));
            finished.push_back(group == &merged.finished);
          }
        }
        trials["file"] = file;
        trials["id"] = id;
        trials["station"] = station;
        trials["participant"] = participant;
        trials["study"] = study;
        trials["kind"] = kind;
        trials["trial"] = trial;
        trials["seed"] = seed;
        trials["started_at"] = started;
        trials["ended_at"] = ended;
        trials["finished"] = finished;
        scores["row"] = s_row;
        scores["name"] = s_name;
        scores["level"] = s_level;
        scores["value"] = s_value;
        scores["unit"] = s_unit;
        py::dict out;
        out["trials"] = trials;
        out["scores"] = scores;
        out["duplicates"] = merged.duplicates.size();
        return out;
      },
      py::arg("files"), "Study databases merged (each trial once): trials and their scores as columns.");

  m.def("experiment_names", &experiment_names, "The paper's experiments, in the order `all` runs them.");
  m.def(
      "run_experiment",
      [](const std::string& name, const std::string& out, double rate,
         const std::vector<std::pair<std::string, std::string>>& overrides) {
        ExperimentOptions options;
        options.out = out;
        options.rate_hz = rate;
        options.quiet = true;
        for (const auto& [key, value] : overrides) options.overrides.push_back(SceneOverride{key, value});
        py::gil_scoped_release release;
        return run_experiment(name, options);
      },
      py::arg("name"), py::arg("out"), py::arg("rate"), py::arg("overrides"),
      "Runs one of the paper's experiments into `out` (CSVs, summary.json); returns the summary JSON.");
}

}  // namespace cariesim::python

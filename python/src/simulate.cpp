// The Simulator for Python (docs/python.md): run(trajectory) drives the same function as `cariesim
// sim` (simulate_each, experiment/simulate.hpp) with the GIL released, into a numpy structured array
// whose fields are sim's CSV columns; step(pose) is one servo cycle at a time.

#include "cariesim/experiment/simulate.hpp"

#include <pybind11/stl.h>

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "cariesim/common/error.hpp"
#include "cariesim/device/input_guard.hpp"
#include "cariesim/render/params.hpp"
#include "cariesim/render/step.hpp"

namespace py = pybind11;

namespace cariesim::python {

// One row of `cariesim sim`'s CSV (SimCsvWriter): the numpy record the arrays are made of.
struct SimRow {
  double t;            // s
  double h[7];         // mm, then unit quaternion w, x, y, z
  double g[7];         // mm, then unit quaternion w, x, y, z
  double force[3];     // N
  double torque[3];    // N·mm
  char32_t state[10];  // "free", "sliding", "inserting", "extracting" (numpy 'U10')
  double depth;        // mm
  int64_t contacts;
  double step_us;  // µs
};

namespace {

// Characters of the longest state name, "extracting".
constexpr std::size_t kStateChars = 10;

// The numpy dtype of SimRow, field names as the CSV header's.
py::dtype row_dtype() {
  py::list names, formats, offsets;
  const auto add = [&](const char* name, const char* format, std::size_t offset) {
    names.append(name);
    formats.append(format);
    offsets.append(offset);
  };
  add("t", "<f8", offsetof(SimRow, t));
  const char* pose_names[2][7] = {{"h_px", "h_py", "h_pz", "h_qw", "h_qx", "h_qy", "h_qz"},
                                  {"g_px", "g_py", "g_pz", "g_qw", "g_qx", "g_qy", "g_qz"}};
  for (int k = 0; k < 7; ++k) add(pose_names[0][k], "<f8", offsetof(SimRow, h) + 8 * k);
  for (int k = 0; k < 7; ++k) add(pose_names[1][k], "<f8", offsetof(SimRow, g) + 8 * k);
  const char* force_names[3] = {"fx", "fy", "fz"};
  const char* torque_names[3] = {"tx", "ty", "tz"};
  for (int k = 0; k < 3; ++k) add(force_names[k], "<f8", offsetof(SimRow, force) + 8 * k);
  for (int k = 0; k < 3; ++k) add(torque_names[k], "<f8", offsetof(SimRow, torque) + 8 * k);
  add("state", "<U10", offsetof(SimRow, state));
  add("depth", "<f8", offsetof(SimRow, depth));
  add("contacts", "<i8", offsetof(SimRow, contacts));
  add("step_us", "<f8", offsetof(SimRow, step_us));
  return py::dtype(names, formats, offsets, sizeof(SimRow));
}

// A sample as a row: the values SimCsvWriter writes, unrounded.
void fill_row(SimRow& row, const SimSample& s) {
  row.t = s.t;
  const Pose* poses[2] = {&s.out.haptic, &s.out.graphic};
  double* out[2] = {row.h, row.g};
  for (int p = 0; p < 2; ++p) {
    for (int k = 0; k < 3; ++k) out[p][k] = poses[p]->p[k];
    out[p][3] = poses[p]->q.w();
    out[p][4] = poses[p]->q.x();
    out[p][5] = poses[p]->q.y();
    out[p][6] = poses[p]->q.z();
  }
  for (int k = 0; k < 3; ++k) row.force[k] = s.out.force[k];
  for (int k = 0; k < 3; ++k) row.torque[k] = s.out.torque[k];
  std::memset(row.state, 0, sizeof(row.state));
  const char* name = state_name(s.out.state);
  for (std::size_t i = 0; i < kStateChars && name[i] != '\0'; ++i)
    row.state[i] = static_cast<char32_t>(name[i]);
  row.depth = s.out.depth;
  row.contacts = s.out.contacts;
  row.step_us = s.out.step_us;
}

// A pose row (px, py, pz, qw, qx, qy, qz) by the trajectory files' rule (device/trajectory_csv.hpp):
// finite numbers, a unit quaternion within kUnitTolerance, then normalised.
Pose pose_of(const double* v, const std::string& where) {
  static constexpr const char* kNames[7] = {"px", "py", "pz", "qw", "qx", "qy", "qz"};
  for (int k = 0; k < 7; ++k)
    if (!std::isfinite(v[k])) throw Error(where + ": column '" + kNames[k] + "' is not finite");
  const Quat q(v[3], v[4], v[5], v[6]);
  if (!is_unit(q))
    throw Error(where + ": quaternion (qw,qx,qy,qz) has length " + std::to_string(q.norm()) +
                "; a unit quaternion is expected (within " + std::to_string(kUnitTolerance) + ")");
  return Pose{Vec3(v[0], v[1], v[2]), q.normalized()};
}

// An N×8 array (t, px, py, pz, qw, qx, qy, qz) as a Trajectory, checked row by row.
Trajectory trajectory_of(const py::object& given) {
  const auto input = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(given);
  if (!input) {
    PyErr_Clear();
    throw Error("trajectory: expected an N×8 array of numbers (t s, px py pz mm, qw qx qy qz)");
  }
  if (input.ndim() != 2 || input.shape(1) != 8) {
    std::string shape;
    for (py::ssize_t d = 0; d < input.ndim(); ++d) shape += (d ? ", " : "") + std::to_string(input.shape(d));
    throw Error("trajectory: expected an N×8 array (t s, px py pz mm, qw qx qy qz), got shape (" + shape +
                ")");
  }
  const auto v = input.unchecked<2>();
  if (v.shape(0) == 0) throw Error("trajectory: the array has no rows");
  Trajectory out;
  out.t.reserve(static_cast<std::size_t>(v.shape(0)));
  out.pose.reserve(static_cast<std::size_t>(v.shape(0)));
  for (py::ssize_t i = 0; i < v.shape(0); ++i) {
    const std::string where = "trajectory row " + std::to_string(i);
    const double t = v(i, 0);
    if (!std::isfinite(t)) throw Error(where + ": column 't' is not finite");
    if (!out.t.empty() && !(t > out.t.back()))
      throw Error(where + ": time " + std::to_string(t) + " s does not increase");
    out.add(t, pose_of(&v(i, 1), where));
  }
  return out;
}

// The Simulator: a model, its running Params, a rate, and the state step() carries.
class Simulator {
 public:
  Simulator(std::shared_ptr<const Model> model, double rate)
      : model_(std::move(model)), params_(model_->defaults), rate_(rate > 0.0 ? rate : model_->servo_rate) {
    if (!(rate_ >= 1.0 && rate_ <= 100000.0))
      throw Error("Simulator: rate " + std::to_string(rate_) + " Hz is outside [1, 100000]");
  }

  // The whole trajectory from a fresh state, as `cariesim sim` runs it.
  py::array run(const py::object& input) {
    const Trajectory trajectory = trajectory_of(input);
    const std::size_t steps = sim_step_count(trajectory, rate_);
    py::array out(row_dtype(), std::vector<py::ssize_t>{static_cast<py::ssize_t>(steps)});
    auto* rows = static_cast<SimRow*>(out.mutable_data());
    std::size_t i = 0;
    {
      py::gil_scoped_release release;
      simulate_each(*model_, params_, trajectory, rate_, [&](const SimSample& s) {
        if (i < steps) fill_row(rows[i++], s);
      });
    }
    return out;
  }

  // One servo cycle at the haptic pose (px, py, pz, qw, qx, qy, qz); the first makes the state.
  py::array step(const py::object& pose_input) {
    const auto pose_array =
        py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(pose_input);
    if (!pose_array || pose_array.ndim() != 1 || pose_array.shape(0) != 7)
      throw Error("step: expected a pose of 7 numbers (px py pz mm, qw qx qy qz)");
    const Pose pose = pose_of(pose_array.data(), "step pose");
    if (!state_) state_.emplace(*model_, pose);
    SimSample sample;
    sample.t = static_cast<double>(steps_) / rate_;
    sample.out = cariesim::step(*model_, params_, *state_, HapticInput{pose, 1.0 / rate_});
    ++steps_;
    py::array out(row_dtype(), std::vector<py::ssize_t>{1});
    fill_row(*static_cast<SimRow*>(out.mutable_data()), sample);
    return out;
  }

  void reset() {
    state_.reset();
    steps_ = 0;
  }

  Params& params() { return params_; }
  void set_params(const Params& p) {
    if (p.materials.size() != model_->defaults.materials.size())
      throw Error("Simulator: these Params hold " + std::to_string(p.materials.size()) +
                  " materials, the model " + std::to_string(model_->defaults.materials.size()));
    params_ = p;
  }
  [[nodiscard]] double rate() const { return rate_; }
  [[nodiscard]] std::size_t steps() const { return steps_; }

 private:
  std::shared_ptr<const Model> model_;
  Params params_;
  double rate_;
  std::optional<State> state_;
  std::size_t steps_ = 0;
};

}  // namespace

void bind_simulate(py::module_& m) {
  m.attr("UNIT_TOLERANCE") = kUnitTolerance;
  m.def("sim_dtype", &row_dtype, "The numpy dtype of Simulator.run's rows (sim's CSV columns).");
  m.def(
      "trajectory_check", [](const py::array& a) { return trajectory_of(a).t.size(); },
      "Checks an N×8 trajectory array as run() does; returns N.");
  py::class_<Simulator>(m, "Simulator")
      .def(py::init([](const std::shared_ptr<BuiltModel>& built, double rate) {
             // Shares the built model (aliasing its Model), so it lives as long as this simulator.
             return Simulator(std::shared_ptr<const Model>(built, &built->model), rate);
           }),
           py::arg("model"), py::arg("rate") = 0.0)
      .def("run", &Simulator::run, py::arg("trajectory"))
      .def("step", &Simulator::step, py::arg("pose"))
      .def("reset", &Simulator::reset)
      .def_property("params", &Simulator::params, &Simulator::set_params,
                    py::return_value_policy::reference_internal)
      .def_property_readonly("rate", &Simulator::rate)
      .def_property_readonly("steps", &Simulator::steps);
}

}  // namespace cariesim::python

#pragma once
// The C++ extension `_cariesim` of the Python package (docs/python.md): one registration function per
// file, each binding a layer of the library thinly, numpy arrays as the currency.

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include "cariesim/scene/model_builder.hpp"

namespace cariesim::python {

/// A built model with what building it measured; Python's Model and the simulators made from it share
/// it (the model lives as long as any of them).
struct BuiltModel {
  Model model;
  BuildReport report;
};

/// Scenes, models, Params (scene.cpp).
void bind_scene(pybind11::module_& m);
/// The Simulator: step(pose) and run(trajectory) (simulate.cpp).
void bind_simulate(pybind11::module_& m);
/// Recordings, study databases and the paper's experiments (records.cpp).
void bind_records(pybind11::module_& m);

}  // namespace cariesim::python

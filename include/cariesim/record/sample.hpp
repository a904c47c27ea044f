#pragma once
/// One sample of the servo loop as the record module stores it (the `samples` table, docs/records.md).
/// The record module's own type: the servo loop fills one per cycle and pushes it into the
/// recorder's queue; replay and CSV export read them back.

#include <cstdint>

#include "cariesim/common/math.hpp"
#include "cariesim/render/interaction.hpp"

namespace cariesim {

/// One recorded sample, at the servo rate.
struct ServoSample {
  double t = 0.0;                                   ///< s since the loop started
  Pose haptic;                                      ///< the device's tool pose (world, mm)
  Pose graphic;                                     ///< the graphic tool's pose (world, mm)
  Vec3 force = Vec3::Zero();                        ///< N, rendered (after safety)
  Vec3 torque = Vec3::Zero();                       ///< N·mm, rendered
  float depth = 0.0f;                               ///< mm
  float step_us = 0.0f;                             ///< µs
  float soft_tissue_force = 0.0f;                   ///< N
  uint32_t step_flags = 0;                          ///< StepFlag bits (render/interaction.hpp)
  uint32_t safety_flags = 0;                        ///< SafetyFlag bits (device/safety.hpp)
  uint16_t contacts = 0;                            ///< constraint rows from sphere pairs
  int8_t lesion = -1;                               ///< lesion probed or touched, -1 for none
  InteractionState state = InteractionState::Free;  ///< the interaction state
  bool overrun = false;                             ///< this cycle missed its deadline
  uint32_t buttons = 0;                             ///< bit i = device button i pressed
};

}  // namespace cariesim

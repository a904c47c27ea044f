#include "record/record_support.hpp"

#include <unistd.h>

#include <cmath>

namespace cariesim::test {

ServoSample synthetic_sample(std::size_t i, double rate_hz) {
  const double t = static_cast<double>(i) / rate_hz;
  const double phase = static_cast<double>(i) * 0.01;
  ServoSample s;
  s.t = t;
  s.haptic.p = Vec3(10.0 * std::cos(phase), 10.0 * std::sin(phase), 0.001 * static_cast<double>(i));
  s.haptic.q = Quat(Eigen::AngleAxisd(0.3 * std::sin(phase), Vec3(1, 2, 3).normalized()));
  s.graphic.p = s.haptic.p + Vec3(0.01, -0.02, 0.5 * std::sin(phase));
  s.graphic.q = Quat(Eigen::AngleAxisd(0.2 * std::cos(phase), Vec3(0, 1, 0)));
  s.force = Vec3(std::sin(phase), -2.0 * std::cos(phase), 3.0 + std::sin(0.5 * phase));
  s.torque = Vec3(10.0 * std::sin(phase), 0.25, -7.5 * std::cos(phase));
  // The four states in turn, 40 samples each, with a lesion while penetrating.
  s.state = static_cast<InteractionState>((i / 40) % 4);
  s.depth = static_cast<float>(penetrating(s.state) ? 0.01 * static_cast<double>(i % 40) : 0.0);
  s.lesion = static_cast<int8_t>(s.depth > 0.0f ? static_cast<int>(i % 3) : -1);
  s.step_us = static_cast<float>(20.0 + 5.0 * std::sin(3.0 * phase));
  s.soft_tissue_force = static_cast<float>(std::max(0.0, 2.0 * std::sin(0.1 * phase)));
  s.step_flags = static_cast<uint32_t>(i % 7 == 0 ? kFlagLagging : 0u);
  s.safety_flags = static_cast<uint32_t>(i < 30 ? 4u : 0u);
  s.contacts = static_cast<uint16_t>(i % 13);
  s.overrun = i % 500 == 499;
  s.buttons = static_cast<uint32_t>((i / 100) % 4);
  return s;
}

SessionInfo synthetic_session(double rate_hz) {
  SessionInfo info;
  info.scene = "oral-cavity, \"test\" copy";
  info.scene_hash = 0xfedcba9876543210ull;
  info.device = "scripted:traj,1.csv";
  info.rate_hz = rate_hz;
  info.parameters = R"({"lesion1": {"mu_s": 0.51, "mu_d": 0.45}, "note": "a,b"})";
  info.started_at = "2024-05-01T12:00:00.000Z";
  return info;
}

bool same(double a, double b) {
  if (std::isnan(a) || std::isnan(b)) return std::isnan(a) && std::isnan(b);
  return a == b;
}

ScratchDir::ScratchDir(const std::string& name)
    : path_(std::filesystem::temp_directory_path() /
            ("cariesim_record_" + name + "_" + std::to_string(::getpid()))) {
  std::filesystem::remove_all(path_);
  std::filesystem::create_directories(path_);
}

ScratchDir::~ScratchDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

}  // namespace cariesim::test

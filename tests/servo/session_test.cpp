// Session: one place builds the device (from a spec or ready-made), the servo loop and the recorder,
// fills the record's session row (scene hash, running Params, start time), starts and stops them in
// order, posts parameter changes (noted as "param" events) and keeps the published Params.
#include "cariesim/servo/session.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <regex>
#include <string>

#include "cariesim/common/error.hpp"
#include "servo/servo_support.hpp"

namespace cariesim {
namespace {

namespace fs = std::filesystem;
using test::friction_block;
using test::wait_for;

// A fresh file name under the temp directory, removed (with SQLite's side files) at the end.
class TempRecord {
 public:
  explicit TempRecord(const std::string& name)
      : path_(fs::temp_directory_path() /
              ("cariesim_session_test_" + name + "_" + std::to_string(::getpid()) + ".db")) {
    remove();
  }
  ~TempRecord() { remove(); }
  [[nodiscard]] const fs::path& path() const { return path_; }

 private:
  void remove() const {
    for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(path_.string() + suffix);
  }
  fs::path path_;
};

// A device made by the caller, holding a pose, with a name of its own.
class HeldDevice : public Device {
 public:
  explicit HeldDevice(const Pose& pose) : pose_(pose) {}
  [[nodiscard]] DeviceInfo info() const override { return DeviceInfo{"held", "test", DeviceLimits{}, true}; }
  DeviceState read(double now) override {
    DeviceState s;
    s.pose = pose_;
    s.stamp = now;
    s.sequence = ++sequence_;
    s.valid = true;
    return s;
  }
  void write(const Vec3& /*force*/, const Vec3& /*torque*/) override {}

 private:
  Pose pose_;
  uint64_t sequence_ = 0;
};

SessionOptions quiet(const std::string& device = "null") {
  SessionOptions o;
  o.scene = "friction-block";
  o.device = device;
  o.realtime = false;
  return o;
}

TEST(Session, FillsTheSessionRowOnce) {
  const Model& m = friction_block();
  Session session(m, quiet());
  const SessionInfo& info = session.info();
  EXPECT_EQ(info.scene, "friction-block");
  EXPECT_NE(info.scene_hash, 0u);
  EXPECT_EQ(info.scene_hash, m.scene_hash);
  EXPECT_EQ(info.device, "null");
  EXPECT_DOUBLE_EQ(info.rate_hz, m.servo_rate);  // 0 asked: the model's
  EXPECT_TRUE(std::regex_match(info.started_at, std::regex(R"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{3}Z)")))
      << info.started_at;
  // The running Params as JSON: the lesion's material, the gains, the limits.
  EXPECT_NE(info.parameters.find("\"lesions\":[{\"name\":\"" + m.lesions[0].name + "\""), std::string::npos)
      << info.parameters;
  EXPECT_NE(info.parameters.find("\"gains\":{\"k_trans\":"), std::string::npos) << info.parameters;
  EXPECT_NE(info.parameters.find("\"max_force\":22"), std::string::npos) << info.parameters;
  EXPECT_EQ(session.device_info().name, "null");
  EXPECT_EQ(session.recorder(), nullptr);
  // The loop polls what the options ask before each deadline.
  EXPECT_DOUBLE_EQ(session.loop().spin_us(), kDefaultSpinUs);
  SessionOptions sleeping = quiet();
  sleeping.spin_us = 0.0;
  EXPECT_DOUBLE_EQ(Session(m, sleeping).loop().spin_us(), 0.0);
}

TEST(Session, RecordsWithTheSessionRowAndParamEvents) {
  const Model& m = friction_block();
  TempRecord file("record");
  {
    SessionOptions o = quiet();
    o.record = file.path().string();
    o.rate_hz = 500.0;
    Session session(m, o);
    ASSERT_NE(session.recorder(), nullptr);
    session.start();
    EXPECT_TRUE(session.running());
    ServoSnapshot s;
    ASSERT_TRUE(wait_for([&] { return session.latest(s) && s.cycle >= 50; }));
    ASSERT_TRUE(session.post(ParamChange{ParamChange::Field::MuS, 0, 0.8}));
    // The servo thread applies it and publishes the Params the session hands out.
    ASSERT_TRUE(wait_for([&] { return session.params().materials[m.lesions[0].material].mu_s == 0.8; }));
    EXPECT_GT(session.params_version(), 0u);
    EXPECT_FALSE(session.restart());  // not while recording
    session.stop();
    EXPECT_FALSE(session.running());
    session.stop();                        // twice is fine
    EXPECT_THROW(session.start(), Error);  // the record was closed
  }
  const Recording rec = load_recording(file.path());
  EXPECT_EQ(rec.info.scene, "friction-block");
  EXPECT_EQ(rec.info.scene_hash, m.scene_hash);
  EXPECT_EQ(rec.info.device, "null");
  EXPECT_DOUBLE_EQ(rec.info.rate_hz, 500.0);
  EXPECT_NE(rec.info.parameters.find("\"lesions\""), std::string::npos);
  EXPECT_FALSE(rec.info.ended_at.empty());
  EXPECT_GT(rec.samples.size(), 50u);
  const auto param = std::find_if(rec.events.begin(), rec.events.end(),
                                  [](const RecordedEvent& e) { return e.kind == "param"; });
  ASSERT_NE(param, rec.events.end());
  EXPECT_EQ(param->detail, "mu_s");
  EXPECT_DOUBLE_EQ(param->value, 0.8);
  EXPECT_EQ(param->lesion, 0);
  EXPECT_GT(param->t, 0.0);  // the servo time of the snapshot seen before posting
}

TEST(Session, TakesAReadyMadeDeviceAndRestartsKeepingTheParams) {
  const Model& m = friction_block();
  auto device = std::make_unique<HeldDevice>(m.tool_home);
  HeldDevice* held = device.get();
  Session session(m, std::move(device), quiet("held:test"));
  EXPECT_EQ(&session.device(), held);
  EXPECT_EQ(session.info().device, "held:test");
  session.start();
  ASSERT_TRUE(session.post(ParamChange{ParamChange::Field::KE, 0, 0.9}));
  ASSERT_TRUE(wait_for([&] { return session.params().materials[m.lesions[0].material].k_e == 0.9; }));

  // A restart is a new loop (a new engine state, its cycle count from zero) with the tuned Params.
  ServoSnapshot s;
  ASSERT_TRUE(wait_for([&] { return session.latest(s) && s.cycle >= 100; }));
  ASSERT_TRUE(session.restart());
  EXPECT_TRUE(session.running());
  EXPECT_DOUBLE_EQ(session.params().materials[m.lesions[0].material].k_e, 0.9);
  ASSERT_TRUE(wait_for([&] { return session.latest(s) && s.cycle >= 5; }));
  EXPECT_LT(s.cycle, 100u);
  session.stop();
  EXPECT_THROW(Session(m, nullptr, quiet()), Error);
}

TEST(Session, BadInputsNameWhatWasWrongAndLeaveNoRecord) {
  const Model& m = friction_block();
  TempRecord file("bad");
  SessionOptions o = quiet("bogus:1");
  o.record = file.path().string();
  try {
    Session session(m, o);
    ADD_FAILURE() << "accepted the device spec 'bogus:1'";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("'bogus:1'"), std::string::npos) << e.what();
  }
  o.device = "null";
  o.rate_hz = 20000.0;
  try {
    Session session(m, o);
    ADD_FAILURE() << "accepted a rate of 20 kHz";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("servo rate"), std::string::npos) << e.what();
  }
  o.rate_hz = 0.0;
  o.spin_us = -1.0;
  try {
    Session session(m, o);
    ADD_FAILURE() << "accepted a spin of -1 us";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("servo spin"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(file.path()));  // refused before the recorder made the file
}

}  // namespace
}  // namespace cariesim

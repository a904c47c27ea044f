// `cariesim servo`: the headless servo loop from the command line, driven by a scripted path onto the
// friction block, recorded, then replayed from the recording; and its errors.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "apps/apps_support.hpp"
#include "cariesim/record/recorder.hpp"
#include "servo/servo_support.hpp"
#include "support/files.hpp"

namespace cariesim {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

using cariesim::test::read_text;

class ServoCommand : public test::ScratchTest {
 protected:
  ServoCommand() : ScratchTest("cariesim_servo_cmd_") {}

  // Runs `cariesim ARGS`; returns the exit status, keeps stderr in err_.
  int run(const std::string& args) {
    const test::CommandResult r = test::run_cariesim(args);
    err_ = r.err;
    return r.status;
  }

  std::string err_;
};

TEST_F(ServoCommand, RunsAScriptedPathRecordsItAndReplaysIt) {
  // From the home pose down to 0.5 mm into the friction block's caries top, sliding for 0.4 s.
  const fs::path path = dir_ / "press.csv";
  save_trajectory_csv(test::press_and_slide(test::friction_block(), 0.5, 0.4), path);
  const fs::path db = dir_ / "session.db";
  ASSERT_EQ(run("servo --scene friction-block --device 'scripted:" + path.string() +
                "' --rate 1000 --record '" + db.string() + "' --no-realtime"),
            0)
      << err_;
  // It ran until the path ended and reported the timing and the recording.
  EXPECT_THAT(err_, HasSubstr("until the path ends"));
  EXPECT_THAT(err_, HasSubstr("step time (us): p50"));
  EXPECT_THAT(err_, HasSubstr("jitter    (us): p50"));
  EXPECT_THAT(err_, HasSubstr("overruns"));
  EXPECT_THAT(err_, HasSubstr("real-time: not requested"));
  EXPECT_THAT(err_, HasSubstr("polls the last 150 us of each wait"));
  EXPECT_THAT(err_, HasSubstr("cycles run by the standby thread"));
  EXPECT_THAT(err_, testing::AnyOf(HasSubstr("; standby thread on CPU "),
                                   HasSubstr("; no standby thread (one CPU)")));
  const Recording rec = load_recording(db);
  EXPECT_EQ(rec.info.scene, "friction-block");
  EXPECT_EQ(rec.info.device, "scripted:" + path.string());
  // The session row is the viewer's: the scene's hash and the running parameters as JSON.
  EXPECT_EQ(rec.info.scene_hash, test::friction_block().scene_hash);
  EXPECT_NE(rec.info.scene_hash, 0u);
  EXPECT_THAT(rec.info.parameters, HasSubstr("\"lesions\":[{\"name\":"));
  EXPECT_THAT(rec.info.parameters, HasSubstr("\"limits\":{\"max_force\":22"));
  EXPECT_DOUBLE_EQ(rec.info.rate_hz, 1000.0);
  EXPECT_FALSE(rec.info.started_at.empty());
  ASSERT_GT(rec.samples.size(), 500u);
  bool touched = false;
  for (const ServoSample& s : rec.samples) {
    touched = touched || s.state != InteractionState::Free;
    EXPECT_LE(s.force.norm(), 22.0 + 1e-9);
  }
  EXPECT_TRUE(touched) << "the path never reached the block";

  // The recording drives the loop again through replay:FILE.
  ASSERT_EQ(run("servo --scene friction-block --device 'replay:" + db.string() +
                "' --quiet --no-realtime --no-standby"),
            0)
      << err_;
  EXPECT_THAT(err_, HasSubstr("cycles at"));
  EXPECT_THAT(err_,
              HasSubstr(", 0 cycles run by the standby thread; real-time: not requested (normal priority); "
                        "no standby thread;"));
}

// Issue #11/#14 item 10: steps the work budget cuts short are counted on the status line and in the
// final report. A tool of extreme but valid parameters pressed through a block of almost no
// stiffness reaches the budget; the default scene's touch does not.
TEST_F(ServoCommand, CountsTheStepsTheWorkBudgetCutShort) {
  const fs::path scene = fs::path(CARIESIM_SOURCE_DIR) / "scenes/examples/extreme-parameters.yaml";
  const fs::path press = dir_ / "press.csv";
  std::ofstream(press) << "t,px,py,pz,qw,qx,qy,qz\n"
                          "0,-15,0,8,0.766044443,0,-0.642787610,0\n"
                          "0.06,-15,0,-20,0.766044443,0,-0.642787610,0\n"
                          "1.2,-15,0,-20,0.766044443,0,-0.642787610,0\n";
  ASSERT_EQ(run("servo --scene '" + scene.string() + "' --device 'scripted:" + press.string() +
                "' --rate 1000 --no-realtime"),
            0)
      << err_;
  // The status line (once a second) and the report both count them.
  const auto counted = [&](const std::string& before) {
    const std::size_t at = err_.find(before);
    return at == std::string::npos ? -1L : std::atol(err_.c_str() + at + before.size());
  };
  EXPECT_GT(counted("work-budget="), 0) << err_;
  const std::size_t report = err_.find(" steps cut short by the work budget");
  ASSERT_NE(report, std::string::npos) << err_;
  const std::size_t comma = err_.rfind(", ", report);
  EXPECT_GT(std::atol(err_.c_str() + comma + 2), 0) << err_;
}

TEST_F(ServoCommand, UdpBridgeRunsForADurationAndCountsPackets) {
  ASSERT_EQ(run("servo --scene friction-block --device udp:0 --duration 0.3 --quiet --no-realtime"), 0)
      << err_;
  // No client: the bridge counted nothing, the loop still ran.
  EXPECT_THAT(err_, HasSubstr("device udp: received=0"));
  EXPECT_THAT(err_, HasSubstr("rejected_stale=0"));
  EXPECT_THAT(err_, HasSubstr("bridge threads: not requested"));  // --no-realtime
}

TEST_F(ServoCommand, BadDeviceIsAnErrorNamingTheSpec) {
  EXPECT_EQ(run("servo --scene friction-block --device bogus:1 --quiet"), 2);
  EXPECT_THAT(err_, HasSubstr("'bogus:1'"));
  EXPECT_EQ(run("servo --scene friction-block --device 'replay:" + (dir_ / "none.db").string() + "' --quiet"),
            2);
  EXPECT_THAT(err_, HasSubstr("none.db"));
}

}  // namespace
}  // namespace cariesim

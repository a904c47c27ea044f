// The device factory (servo/device_factory.hpp): every spec kind, replay from the record module
// included, and errors that name the spec.
#include "cariesim/servo/device_factory.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include "cariesim/common/error.hpp"
#include "cariesim/device/udp_device.hpp"
#include "cariesim/record/recorder.hpp"
#include "cariesim/record/replay.hpp"
#include "support/fifo.hpp"

namespace cariesim {
namespace {

std::filesystem::path temp_file(const std::string& name, const std::string& text) {
  const auto path = std::filesystem::temp_directory_path() / ("cariesim_factory_test_" + name);
  std::ofstream(path) << text;
  return path;
}

TEST(DeviceFactory, MakesEachKind) {
  DeviceOptions options;
  options.home.p = Vec3(4, 5, 6);
  auto null = make_device("null", options);
  EXPECT_EQ(null->info().name, "null");
  EXPECT_EQ(null->read(0.0).pose.p, Vec3(4, 5, 6));

  const auto csv = temp_file("line.csv", "t,px,py,pz,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n1,10,0,0,1,0,0,0\n");
  auto once = make_device("scripted:" + csv.string(), options);
  EXPECT_EQ(once->info().name, "scripted");
  EXPECT_EQ(once->info().description.find("loop"), std::string::npos);
  auto looped = make_device("scripted:" + csv.string() + ":loop", options);
  looped->start();
  looped->read(0.0);
  EXPECT_TRUE(looped->read(5.5).valid);

  auto udp = make_device("udp:0:127.0.0.1", options);
  EXPECT_EQ(udp->info().name, "udp");
  udp->start();
  EXPECT_GT(dynamic_cast<UdpDevice&>(*udp).port(), 0);
  EXPECT_FALSE(udp->read(0.0).valid);  // no client yet
  // Real-time priority for the bridge threads was asked for, and the answer is reported either way.
  EXPECT_EQ(dynamic_cast<UdpDevice&>(*udp).realtime_status().find("not requested"), std::string::npos);
  EXPECT_FALSE(dynamic_cast<UdpDevice&>(*udp).realtime_status().empty());
  EXPECT_EQ(udp->read(0.0).pose.p, Vec3(4, 5, 6));
  udp->stop();
  udp->stop();
  DeviceOptions normal = options;
  normal.realtime = false;
  auto plain = make_device("udp:0", normal);
  plain->start();
  EXPECT_EQ(dynamic_cast<UdpDevice&>(*plain).realtime_status().find("not requested"), 0u);
  plain->stop();
  std::filesystem::remove(csv);
}

TEST(DeviceFactory, BadSpecsNameTheSpec) {
  const auto bad_csv = temp_file("bad.csv", "t,px\n0,1\n");
  for (const std::string& spec :
       {std::string("nul"), std::string(""), std::string("null:x"), std::string("scripted"),
        std::string("scripted:"), std::string("scripted:/no/such/file.csv"), "scripted:" + bad_csv.string(),
        std::string("udp"), std::string("udp:"), std::string("udp:port"), std::string("udp:70000"),
        std::string("udp:-1"), std::string("udp:47000:"), std::string("replay:x.db"), std::string("mouse")}) {
    try {
      make_device(spec);
      ADD_FAILURE() << "no error for '" << spec << "'";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("'" + spec + "'"), std::string::npos) << e.what();
    }
  }
  std::filesystem::remove(bad_csv);
}

// Issue 26 item 15: `--device scripted:FIFO` blocked forever; /dev/zero read over 1 GB. Both are
// refused at once, naming the spec and the file's kind.
TEST(DeviceFactory, AScriptedFifoOrDeviceIsRefusedWithoutBlocking) {
  const auto fifo =
      std::filesystem::temp_directory_path() / ("cariesim_factory_fifo_" + std::to_string(::getpid()));
  ASSERT_TRUE(test::make_fifo(fifo));
  const test::FifoOutcome outcome =
      test::read_fifo(fifo, [fifo] { (void)make_device("scripted:" + fifo.string()); });
  std::filesystem::remove(fifo);
  EXPECT_FALSE(outcome.blocked) << "scripted:FIFO blocked";
  EXPECT_NE(outcome.error.find("device spec 'scripted:" + fifo.string() + "'"), std::string::npos)
      << outcome.error;
  EXPECT_NE(outcome.error.find("not a regular file (a FIFO (named pipe))"), std::string::npos)
      << outcome.error;
  try {
    (void)make_device("scripted:/dev/zero");
    FAIL() << "scripted:/dev/zero made a device";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("not a regular file (a character device)"), std::string::npos)
        << e.what();
  }
}

TEST(DeviceFactory, ReplayReachesTheRecordModule) {
  // A 1 s recording at 100 Hz: the tool moves 10 mm along x.
  const auto file = std::filesystem::temp_directory_path() /
                    ("cariesim_factory_test_replay_" + std::to_string(::getpid()) + ".db");
  std::filesystem::remove(file);
  {
    SessionInfo info;
    info.scene = "friction-block";
    info.device = "scripted:line.csv";
    info.rate_hz = 100.0;
    Recorder recorder(file, info);
    recorder.start();
    for (int i = 0; i <= 100; ++i) {
      ServoSample s;
      s.t = 0.01 * i;
      s.haptic.p = Vec3(0.1 * i, 0, 1);
      s.graphic.p = Vec3(0.1 * i, 0, 1.5);
      ASSERT_TRUE(recorder.queue().push(s));
    }
    recorder.stop();
  }

  // The factory hands out the record module's ReplayDevice, which plays the recorded haptic poses.
  auto once = make_device("replay:" + file.string());
  EXPECT_EQ(once->info().name, "replay");
  auto* replay = dynamic_cast<ReplayDevice*>(once.get());
  ASSERT_NE(replay, nullptr);
  EXPECT_EQ(replay->size(), 101u);
  once->start();
  for (int wait = 0; !replay->ready(0.5) && wait < 10000; ++wait)  // the loader streams the file
    std::this_thread::sleep_for(std::chrono::microseconds(100));
  const DeviceState mid = once->read(0.5);
  EXPECT_TRUE(mid.valid);
  EXPECT_NEAR(mid.pose.p.x(), 5.0, 1e-9);
  EXPECT_NEAR(replay->recorded_graphic(0.5).p.z(), 1.5, 1e-9);
  EXPECT_FALSE(once->read(2.0).valid);  // past the end without looping

  // With ":loop" it starts over instead of ending.
  auto looped = make_device("replay:" + file.string() + ":loop");
  looped->start();
  // The file streams: wait (as replay_test does) until the loader has the second pass in.
  auto* looping = dynamic_cast<ReplayDevice*>(looped.get());
  ASSERT_NE(looping, nullptr);
  // The playback rule's period: 1 s, first to last sample (common/trajectory.hpp).
  for (int wait = 0; !looping->ready(1.0 + 0.5) && wait < 10000; ++wait)
    std::this_thread::sleep_for(std::chrono::microseconds(100));
  const DeviceState again = looped->read(1.0 + 0.5);
  EXPECT_TRUE(again.valid);
  EXPECT_NEAR(again.pose.p.x(), 5.0, 1e-6);
  once.reset();
  looped.reset();
  std::filesystem::remove(file);
}

TEST(DeviceFactory, UdpBindFailureNamesTheAddress) {
  auto a = make_device("udp:0");
  a->start();
  const uint16_t port = dynamic_cast<UdpDevice&>(*a).port();
  auto b = make_device("udp:" + std::to_string(port));
  try {
    b->start();
    ADD_FAILURE() << "bound the same port twice";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(std::to_string(port)), std::string::npos) << e.what();
  }
  auto c = make_device("udp:0:192.0.2.1");  // a documentation address no interface has
  EXPECT_THROW(c->start(), Error);
}

}  // namespace
}  // namespace cariesim

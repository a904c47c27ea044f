// The device factory (device/factory.hpp): every built-in spec kind, a backend registered from
// above, and errors that name the spec. The record module's replay backend: tests/record.
#include "cariesim/device/factory.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include "cariesim/common/error.hpp"
#include "cariesim/device/devices.hpp"
#include "cariesim/device/udp_device.hpp"
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

// A trajectory file that is not a regular file (a FIFO, which would block the reader forever; a
// character device such as /dev/zero, which never ends) is refused at once, naming the spec and the
// file's kind.
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

// A module above registers its own backend (as the record module does "replay"): the factory hands
// its specs to it, a second registration replaces the first, and an unknown spec lists the backends.
TEST(DeviceFactory, ABackendRegisteredFromAbove) {
  DeviceOptions options;
  options.home.p = Vec3(1, 2, 3);
  std::string seen;
  register_device_backend({"test-arm", "test-arm:ID",
                           [&seen](const std::string& spec, std::optional<std::string_view> argument,
                                   const DeviceOptions& o) -> std::unique_ptr<Device> {
                             if (!argument || argument->empty()) bad_device_spec(spec, "missing ID");
                             seen = std::string(*argument);
                             return std::make_unique<NullDevice>(o.home, o.limits);
                           }});
  auto arm = make_device("test-arm:7", options);
  EXPECT_EQ(seen, "7");
  EXPECT_EQ(arm->read(0.0).pose.p, Vec3(1, 2, 3));
  try {
    (void)make_device("test-arm");
    ADD_FAILURE() << "no error without an ID";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "device spec 'test-arm': missing ID");
  }
  register_device_backend({"test-arm", "test-arm:ID",
                           [](const std::string& spec, std::optional<std::string_view>, const DeviceOptions&)
                               -> std::unique_ptr<Device> { bad_device_spec(spec, "replaced"); }});
  EXPECT_THROW((void)make_device("test-arm:7"), Error);
  const std::vector<std::string> usages = device_spec_usages();
  EXPECT_EQ(std::count(usages.begin(), usages.end(), "test-arm:ID"), 1);
  EXPECT_EQ(usages.front(), "null");
  try {
    (void)make_device("nothing:here");
    ADD_FAILURE() << "an unknown spec made a device";
  } catch (const Error& e) {
    // Every registered backend, the built-in ones (the hardware ones among them) first.
    const std::string what = e.what();
    EXPECT_NE(what.find("null, scripted:FILE[:loop], udp:PORT[:HOST], "), std::string::npos) << what;
    for (const std::string& usage : device_spec_usages())
      EXPECT_NE(std::string(e.what()).find(usage + ", "), std::string::npos) << usage << " in " << e.what();
    EXPECT_NE(what.find(", test-arm:ID, or mouse"), std::string::npos) << what;
  }
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

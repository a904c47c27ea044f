// The Haply Inverse Service's protocol as parsed by the backend (device/haply_protocol.hpp): the
// address of `haply[:URL]`, `/version` and its check (the 3.1 JSON format of services 3.1 to 3.4,
// others refused by name), `/devices`, and state messages, hostile ones included (not JSON, missing or
// non-numeric fields, out-of-range values, a quaternion that is not unit): each refused with what was
// wrong, never a NaN or a huge position through.
#include "device/haply_protocol.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

#include "cariesim/common/error.hpp"

namespace cariesim {
namespace {

using ::testing::HasSubstr;

// The message of what `f` threw ("" when it threw nothing).
template <typename F>
std::string thrown(F f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(HaplyEndpoint, DefaultsNextPortAndBothNamed) {
  const haply::Endpoint d = haply::parse_endpoint("");
  EXPECT_EQ(d.http_host, "localhost");
  EXPECT_EQ(d.http_port, "10000");
  EXPECT_EQ(d.ws_port, "10001");
  const haply::Endpoint one = haply::parse_endpoint("http://10.0.0.5:12000/");
  EXPECT_EQ(one.http_host, "10.0.0.5");
  EXPECT_EQ(one.http_port, "12000");
  EXPECT_EQ(one.ws_host, "10.0.0.5");
  EXPECT_EQ(one.ws_port, "12001");
  const haply::Endpoint both = haply::parse_endpoint("http://127.0.0.1:10001,ws://127.0.0.1:10001");
  EXPECT_EQ(both.http_port, "10001");
  EXPECT_EQ(both.ws_port, "10001");
}

TEST(HaplyEndpoint, BadUrlsNameTheirFault) {
  EXPECT_THAT(thrown([] { haply::parse_endpoint("localhost:10000"); }),
              HasSubstr("expected http://HOST:PORT"));
  EXPECT_THAT(thrown([] { haply::parse_endpoint("http://localhost"); }), HasSubstr("no port"));
  EXPECT_THAT(thrown([] { haply::parse_endpoint("http://localhost:99999"); }), HasSubstr("'99999'"));
  EXPECT_THAT(thrown([] { haply::parse_endpoint("http://localhost:65535"); }),
              HasSubstr("no port after 65535"));
  EXPECT_THAT(thrown([] { haply::parse_endpoint("http://h:1,wss://h:2"); }), HasSubstr("expected ws://"));
}

TEST(HaplyVersion, ParsesProjectVersionElseGitTag) {
  const haply::ServiceVersion v = haply::parse_version(R"({"project_version":"3.2.1.0","git_tag":"3.2.1"})");
  EXPECT_EQ(v.major, 3);
  EXPECT_EQ(v.minor, 2);
  EXPECT_EQ(v.patch, 1);
  EXPECT_EQ(v.text, "3.2.1.0");
  EXPECT_EQ(haply::parse_version(R"({"git_tag":"3.4"})").minor, 4);
  EXPECT_THAT(thrown([] { haply::parse_version("<html>"); }), HasSubstr("not a JSON object"));
  EXPECT_THAT(thrown([] { haply::parse_version(R"({"build_time":"x"})"); }),
              HasSubstr("neither project_version nor git_tag"));
  EXPECT_THAT(thrown([] { haply::parse_version(R"({"project_version":"three"})"); }),
              HasSubstr("'three' is not MAJOR.MINOR.PATCH"));
}

TEST(HaplyVersion, OnlyTheThreeOneFormatIsSpoken) {
  EXPECT_EQ(thrown([] { haply::check_version(haply::parse_version(R"({"project_version":"3.1.0.0"})")); }),
            "");
  EXPECT_EQ(thrown([] { haply::check_version(haply::parse_version(R"({"project_version":"3.4.9.0"})")); }),
            "");
  const std::string old =
      thrown([] { haply::check_version(haply::parse_version(R"({"project_version":"3.0.7.0"})")); });
  EXPECT_THAT(old, HasSubstr("Inverse Service 3.0.7.0 is too old"));
  EXPECT_THAT(old, HasSubstr("3.0 JSON format"));
  EXPECT_THAT(thrown([] { haply::check_version(haply::parse_version(R"({"project_version":"2.1.0"})")); }),
              HasSubstr("2.1.0 is too old"));
  const std::string newer =
      thrown([] { haply::check_version(haply::parse_version(R"({"project_version":"3.5.0.0"})")); });
  EXPECT_THAT(newer, HasSubstr("3.5.0.0 is newer than cariesim knows"));
  EXPECT_THAT(newer, HasSubstr("3.1 to 3.4"));
  EXPECT_THAT(thrown([] { haply::check_version(haply::parse_version(R"({"project_version":"4.0.0.0"})")); }),
              HasSubstr("4.0.0.0 is newer"));
}

TEST(HaplyInventory, ListsInverse3sGripsAndHandedness) {
  const haply::Inventory inv = haply::parse_inventory(
      R"({"inverse3":[{"device_id":"049D","config":{"handedness":"left"},"state":{}}],
          "wireless_verse_grip":[{"device_id":"A1"}],"verse_grip":[{"device_id":"B2"}]})");
  ASSERT_EQ(inv.inverse3.size(), 1u);
  EXPECT_EQ(inv.inverse3[0], "049D");
  EXPECT_EQ(inv.grips.size(), 2u);
  EXPECT_EQ(inv.handedness, "left");
  EXPECT_TRUE(haply::parse_inventory("{}").inverse3.empty());
  EXPECT_THAT(thrown([] { haply::parse_inventory(R"({"inverse3":{"049D":{}}})"); }),
              HasSubstr("'inverse3' is not an array"));
  EXPECT_THAT(thrown([] { haply::parse_inventory(R"({"inverse3":[{"id":"049D"}]})"); }),
              HasSubstr("inverse3[0].device_id missing"));
}

// A state message with the cursor at `position` (JSON text of the object) and a grip.
std::string state_with(const std::string& position,
                       const std::string& orientation = R"({"w":1,"x":0,"y":0,"z":0})") {
  return R"({"inverse3":[{"device_id":"049D","state":{"cursor_position":)" + position +
         R"(,"cursor_velocity":{"x":0.1,"y":0,"z":-0.2}}}],"wireless_verse_grip":[{"device_id":"A1","state":{"orientation":)" +
         orientation + R"(,"buttons":{"a":true,"b":false,"c":true}}}]})";
}

TEST(HaplyState, ReadsCursorGripAndButtons) {
  std::string error;
  bool absent = true;
  const auto s = haply::parse_state(
      state_with(R"({"x":0.01,"y":0.12,"z":-0.03})", R"({"w":0.7071068,"x":0,"y":0,"z":0.7071068})"), "049D",
      error, absent);
  ASSERT_TRUE(s.has_value()) << error;
  EXPECT_FALSE(absent);
  EXPECT_DOUBLE_EQ(s->position.y(), 0.12);
  EXPECT_DOUBLE_EQ(s->velocity.z(), -0.2);
  EXPECT_TRUE(s->grip);
  EXPECT_NEAR(s->orientation.angularDistance(Quat(Eigen::AngleAxisd(M_PI / 2, Vec3::UnitZ()))), 0.0, 1e-6);
  EXPECT_EQ(s->buttons, 0b101u);
}

TEST(HaplyState, HostileMessagesAreRefusedWithTheirFault) {
  std::string error;
  bool absent = false;
  const auto refused = [&](const std::string& message) {
    const bool got = haply::parse_state(message, "049D", error, absent).has_value();
    return got ? std::string("accepted") : error;
  };
  EXPECT_THAT(refused("{\"inverse3\":[{"), HasSubstr("not a JSON object"));
  EXPECT_THAT(refused(R"({"inverse3":[{"device_id":"0000","state":{}}]})"), HasSubstr("049D absent"));
  EXPECT_TRUE(absent);
  EXPECT_THAT(refused(R"({"inverse3":[{"device_id":"049D"}]})"), HasSubstr("state missing"));
  EXPECT_FALSE(absent);
  EXPECT_THAT(refused(state_with(R"({"x":0,"y":0})")), HasSubstr("cursor_position.z missing"));
  EXPECT_THAT(refused(state_with(R"({"x":"0","y":0,"z":0})")),
              HasSubstr("cursor_position.x is not a number"));
  EXPECT_THAT(refused(state_with(R"({"x":1e300,"y":0,"z":0})")),
              HasSubstr("cursor_position.x = 1e+300 out of range"));
  EXPECT_THAT(refused(state_with(R"({"x":0,"y":0,"z":0})", R"({"w":0,"x":0,"y":0,"z":0})")),
              HasSubstr("not a unit quaternion"));
  EXPECT_THAT(refused(state_with(R"({"x":0,"y":0,"z":0})", R"({"w":1,"x":0,"y":0})")),
              HasSubstr("orientation.z missing"));
}

TEST(HaplyState, NoGripMeansNoOrientation) {
  std::string error;
  bool absent = false;
  const auto s = haply::parse_state(
      R"({"inverse3":[{"device_id":"049D","state":{"cursor_position":{"x":0,"y":0,"z":0},"cursor_velocity":{"x":0,"y":0,"z":0}}}]})",
      "049D", error, absent);
  ASSERT_TRUE(s.has_value()) << error;
  EXPECT_FALSE(s->grip);
  EXPECT_EQ(s->buttons, 0u);
}

TEST(HaplyCommand, SetCursorForceValuesInNewtons) {
  const auto doc = nlohmann::json::parse(haply::force_command("049D", Vec3(0.5, -1.0, 2.0)));
  const auto& d = doc.at("inverse3").at(0);
  EXPECT_EQ(d.at("device_id"), "049D");
  const auto& values = d.at("commands").at("set_cursor_force").at("values");
  EXPECT_DOUBLE_EQ(values.at("x").get<double>(), 0.5);
  EXPECT_DOUBLE_EQ(values.at("y").get<double>(), -1.0);
  EXPECT_DOUBLE_EQ(values.at("z").get<double>(), 2.0);
}

}  // namespace
}  // namespace cariesim

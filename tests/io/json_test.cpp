#include "cariesim/io/json.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace cariesim::io {
namespace {

TEST(JsonWriter, NestsEscapesAndNullsNonFinite) {
  JsonWriter j;
  j.begin_object()
      .field("name", "a \"b\"\n")
      .field("n", 3)
      .field("x", 0.25)
      .field("bad", std::nan(""))
      .key("list")
      .begin_array()
      .value(true)
      .begin_object()
      .field("k", 1)
      .end_object()
      .end_array()
      .end_object();
  EXPECT_EQ(j.str(), R"({"name":"a \"b\"\n","n":3,"x":0.25,"bad":null,"list":[true,{"k":1}]})");
}

// Issue 26 item 16: invalid UTF-8 in a name (a station database's participant, a level) went into
// report.json as it was, and the file was no longer JSON. Each invalid sequence is now U+FFFD; valid
// text (including 2-, 3- and 4-byte characters) is kept; control characters are escaped.
TEST(JsonWriter, InvalidUtf8IsReplacedAndControlsEscaped) {
  const std::string fffd = "\xEF\xBF\xBD";
  const auto quoted = [](std::string_view s) {
    JsonWriter j;
    j.value(s);
    return j.str();
  };
  EXPECT_EQ(quoted("µs €5 \xF0\x9F\xA6\xB7"), "\"µs €5 \xF0\x9F\xA6\xB7\"");
  EXPECT_EQ(quoted("a\xFF"
                   "b"),
            "\"a" + fffd + "b\"");                // a byte no UTF-8 has
  EXPECT_EQ(quoted("\xC3"), "\"" + fffd + "\"");  // truncated at the end
  EXPECT_EQ(quoted("\xC3"
                   "A"),
            "\"" + fffd + "A\"");                              // truncated before an ASCII byte
  EXPECT_EQ(quoted("\xC0\xAF"), "\"" + fffd + fffd + "\"");    // overlong '/': no lead, a stray byte
  EXPECT_EQ(quoted("\xED\xA0\x80"), "\"" + fffd + "\"");       // a UTF-16 surrogate
  EXPECT_EQ(quoted("\xF4\x90\x80\x80"), "\"" + fffd + "\"");   // past U+10FFFF
  EXPECT_EQ(quoted("\x80\x80x"), "\"" + fffd + fffd + "x\"");  // stray continuation bytes
  EXPECT_EQ(quoted(std::string("\x01\x1f\x7f\0", 4)), "\"\\u0001\\u001f\\u007f\\u0000\"");
  // Keys too.
  JsonWriter k;
  k.begin_object().field("n\xFE", 1).end_object();
  EXPECT_EQ(k.str(), "{\"n" + fffd + "\":1}");
}

}  // namespace
}  // namespace cariesim::io

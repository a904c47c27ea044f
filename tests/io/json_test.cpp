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

}  // namespace
}  // namespace cariesim::io

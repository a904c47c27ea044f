// The step's codes on their own (render/interaction.hpp): the penetration predicate and the state
// names the record stores.
#include "cariesim/render/interaction.hpp"

#include <gtest/gtest.h>

#include <string>

namespace cariesim {
namespace {

TEST(Interaction, PenetratingIsInsertingOrExtracting) {
  EXPECT_FALSE(penetrating(InteractionState::Free));
  EXPECT_FALSE(penetrating(InteractionState::Sliding));
  EXPECT_TRUE(penetrating(InteractionState::Inserting));
  EXPECT_TRUE(penetrating(InteractionState::Extracting));
  static_assert(penetrating(InteractionState::Inserting), "usable in constant expressions");
}

TEST(Interaction, StateNamesAreTheStoredOnes) {
  // The names of the records' `state_names` table (docs/records.md), by code.
  const char* const stored[] = {"free", "sliding", "inserting", "extracting"};
  for (int code = 0; code < 4; ++code)
    EXPECT_EQ(std::string(state_name(static_cast<InteractionState>(code))), stored[code]) << code;
}

}  // namespace
}  // namespace cariesim

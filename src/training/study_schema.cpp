#include "training/study_schema.hpp"

namespace cariesim::training {

static_assert(kStudySchemaVersion > 0, "a study database has a positive schema version");

}  // namespace cariesim::training

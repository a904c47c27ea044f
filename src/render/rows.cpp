// Stage 3, rows: the RowSet every row builder appends to (contact_rows.cpp, friction.cpp, tunnel.cpp),
// emptied before each solve.
#include "render/rows.hpp"

namespace cariesim::detail {

void RowSet::clear(const Mat6& G, const Vec6& x_target) {
  problem.row_count = 0;
  problem.G = G;
  problem.x_target = x_target;
  contacts = 0;
  full = false;
  for (auto& anchor : anchor_rows) anchor = {-1, -1};
}

bool RowSet::add(const QpRow& row, const RowMeta& row_meta) {
  if (!problem.add(row)) {
    full = true;
    return false;
  }
  meta[problem.row_count - 1] = row_meta;
  return true;
}

}  // namespace cariesim::detail

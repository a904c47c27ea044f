#pragma once
// Stage 3, rows: the QP problem of one solve and what each of its rows stands for (rows.cpp). One
// builder per row kind fills it (contact_rows.hpp, friction.hpp, tunnel.hpp), each owning one
// warm-start key space.

#include <array>
#include <cstdint>

#include "cariesim/solver/qp.hpp"
#include "render/stages.hpp"

namespace cariesim::detail {

/// What a QP row stands for.
enum class RowKind : uint8_t { Contact, Friction, TunnelLateral, TunnelRotation, TunnelBottom, TunnelHold };

struct RowMeta {
  RowKind kind = RowKind::Contact;
  int16_t region = -1;  ///< contact region of a Contact or Friction row
  int16_t anchor = -1;  ///< anchor slot of a Friction row
  int16_t pair = -1;    ///< pair index of a Contact row
};

/// The rows stage's output: the QP problem and what each row stands for.
struct RowSet {
  QpProblem problem;
  std::array<RowMeta, kQpMaxRows> meta{};
  int contacts = 0;   ///< contact rows
  bool full = false;  ///< a row did not fit (kFlagQpRowsFull)
  /// The two tangent rows of each anchor, -1 when it has none in this problem.
  std::array<std::array<int8_t, 2>, kMaxAnchors> anchor_rows{};

  /// Empties the set for a problem with weight G and target x_target.
  void clear(const Mat6& G, const Vec6& x_target);
  /// Appends a row; false (and `full` set) when the problem has no room.
  bool add(const QpRow& row, const RowMeta& row_meta);
};

// Warm-start keys (QpRow::key). A row keeps its key from one solve to the next, so the QP can start
// from the rows that were active last time. Each row builder owns one key space, told apart by the
// top 16 bits:
//   contact rows   the object index (< 64) | tool leaf (bits 32-47) | object node (bits 0-31)
//                  (contact_key, contact_rows.hpp)
//   tunnel rows    kTunnelKeys | TunnelRow (tunnel_key, tunnel.hpp)
//   friction rows  kFrictionKeys | 2 anchor + tangent (friction_key, friction.hpp)
inline constexpr uint64_t kTunnelKeys = uint64_t{0x7A00} << 48;
inline constexpr uint64_t kFrictionKeys = uint64_t{0xF1C0} << 48;
static_assert((kTunnelKeys >> 48) >= 64 && (kFrictionKeys >> 48) >= 64,
              "key spaces overlap the contact rows'");

}  // namespace cariesim::detail

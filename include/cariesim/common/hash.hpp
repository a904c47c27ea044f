#pragma once
/// Keys of everything that determines a result (the tree cache, scene and study source hashes): an
/// incremental 64-bit FNV-1a, and one way for a parameter struct to add itself to a key, every field
/// of it. A struct declares its field count beside itself (kKeyFields); the key then binds that many
/// fields by a structured binding, so a field added to the struct without raising the count does not
/// compile, and every field counted is hashed. docs/scene-format.md ("What building makes of it")
/// lists what a part's key holds.

#include <concepts>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>

namespace cariesim {

/// How many fields of T a key hashes: all of them. 0 (the default) for types without the trait;
/// a struct sets it beside its definition: `template <> inline constexpr std::size_t
/// kKeyFields<MolarParams> = 8;`.
template <typename T>
inline constexpr std::size_t kKeyFields = 0;

/// Calls `f` on each of the `N` fields of the aggregate `value`, in declaration order. `N` must be the
/// struct's number of non-static data members: the structured binding fails to compile otherwise.
template <std::size_t N, typename T, typename F>
void for_each_field(T& value, F&& f) {
  static_assert(N >= 1 && N <= 12, "for_each_field binds 1 to 12 fields");
  if constexpr (N == 1) {
    auto& [a] = value;
    f(a);
  } else if constexpr (N == 2) {
    auto& [a, b] = value;
    f(a), f(b);
  } else if constexpr (N == 3) {
    auto& [a, b, c] = value;
    f(a), f(b), f(c);
  } else if constexpr (N == 4) {
    auto& [a, b, c, d] = value;
    f(a), f(b), f(c), f(d);
  } else if constexpr (N == 5) {
    auto& [a, b, c, d, e] = value;
    f(a), f(b), f(c), f(d), f(e);
  } else if constexpr (N == 6) {
    auto& [a, b, c, d, e, g] = value;
    f(a), f(b), f(c), f(d), f(e), f(g);
  } else if constexpr (N == 7) {
    auto& [a, b, c, d, e, g, h] = value;
    f(a), f(b), f(c), f(d), f(e), f(g), f(h);
  } else if constexpr (N == 8) {
    auto& [a, b, c, d, e, g, h, i] = value;
    f(a), f(b), f(c), f(d), f(e), f(g), f(h), f(i);
  } else if constexpr (N == 9) {
    auto& [a, b, c, d, e, g, h, i, j] = value;
    f(a), f(b), f(c), f(d), f(e), f(g), f(h), f(i), f(j);
  } else if constexpr (N == 10) {
    auto& [a, b, c, d, e, g, h, i, j, k] = value;
    f(a), f(b), f(c), f(d), f(e), f(g), f(h), f(i), f(j), f(k);
  } else if constexpr (N == 11) {
    auto& [a, b, c, d, e, g, h, i, j, k, l] = value;
    f(a), f(b), f(c), f(d), f(e), f(g), f(h), f(i), f(j), f(k), f(l);
  } else {
    auto& [a, b, c, d, e, g, h, i, j, k, l, m] = value;
    f(a), f(b), f(c), f(d), f(e), f(g), f(h), f(i), f(j), f(k), f(l), f(m);
  }
}

class BuildKey;

namespace detail {
// Eigen's fixed-size vectors and matrices (size and coefficients), its quaternions and boxes.
template <typename T>
concept KeyMatrix = requires(const T& v) {
  typename T::Scalar;
  { v.size() } -> std::convertible_to<std::ptrdiff_t>;
  v.coeff(0);
};
template <typename T>
concept KeyQuaternion = requires(const T& v) {
  v.coeffs();
  v.w();
};
template <typename T>
concept KeyBox = requires(const T& v) {
  v.min();
  v.max();
  v.isEmpty();
};
template <typename T>
concept KeyRange = requires(const T& v) {
  v.begin();
  v.end();
  v.size();
};
// A struct with its own key function (found by argument-dependent lookup).
template <typename T>
concept KeyHashable = requires(BuildKey& key, const T& v) {
  hash_fields(key, v);
};
}  // namespace detail

/// Incremental 64-bit hash (FNV-1a) of everything that determines a build.
class BuildKey {
 public:
  BuildKey& add(std::string_view bytes);
  BuildKey& add(const void* data, std::size_t size);
  BuildKey& add(double value);
  BuildKey& add(int64_t value);

  /// Adds a value of any type a parameter struct holds: numbers, bools and enums; strings and paths
  /// (the name); Eigen vectors, quaternions and boxes; optionals (presence, then the value); vectors
  /// (length, then each element); a struct with its own `hash_fields(BuildKey&, const T&)` (found by
  /// argument-dependent lookup; it wins); a struct with kKeyFields (each field).
  template <typename T>
  BuildKey& add_value(const T& value) {
    if constexpr (detail::KeyHashable<T>) {
      hash_fields(*this, value);
    } else if constexpr (kKeyFields<T> > 0) {
      for_each_field<kKeyFields<T>>(value, [this](const auto& field) { add_value(field); });
    } else if constexpr (std::is_enum_v<T>) {
      add(static_cast<int64_t>(value));
    } else if constexpr (std::is_integral_v<T>) {
      add(static_cast<int64_t>(value));
    } else if constexpr (std::is_floating_point_v<T>) {
      add(static_cast<double>(value));
    } else if constexpr (std::is_convertible_v<const T&, std::string_view>) {
      add(std::string_view(value));
    } else if constexpr (std::is_same_v<T, std::filesystem::path>) {
      add(std::string_view(value.native()));
    } else if constexpr (detail::KeyQuaternion<T>) {
      add_value(value.coeffs());
    } else if constexpr (detail::KeyMatrix<T>) {
      add(static_cast<int64_t>(value.size()));
      for (std::ptrdiff_t i = 0; i < value.size(); ++i) add(static_cast<double>(value.coeff(i)));
    } else if constexpr (detail::KeyBox<T>) {
      add_value(value.min()).add_value(value.max());
    } else if constexpr (requires {
                           value.has_value();
                           *value;
                         }) {
      add(static_cast<int64_t>(value.has_value()));
      if (value) add_value(*value);
    } else if constexpr (detail::KeyRange<T>) {
      add(static_cast<int64_t>(value.size()));
      for (const auto& element : value) add_value(element);
    } else {
      static_assert(sizeof(T) == 0, "BuildKey::add_value: give this type kKeyFields or hash_fields");
    }
    return *this;
  }

  [[nodiscard]] uint64_t value() const { return hash_; }

 private:
  uint64_t hash_ = 1469598103934665603ull;
};

/// FNV-1a 64 of `size` bytes, continuing from `hash` (start with kFnvOffset).
inline constexpr uint64_t kFnvOffset = 1469598103934665603ull;
uint64_t fnv1a(uint64_t hash, const void* data, std::size_t size);

}  // namespace cariesim

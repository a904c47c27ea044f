// The FNV-1a 64 key of common/hash.hpp.
#include "cariesim/common/hash.hpp"

namespace cariesim {

namespace {
constexpr uint64_t kFnvPrime = 1099511628211ull;
}  // namespace

uint64_t fnv1a(uint64_t hash, const void* data, std::size_t size) {
  const auto* bytes = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < size; ++i) {
    hash ^= bytes[i];
    hash *= kFnvPrime;
  }
  return hash;
}

BuildKey& BuildKey::add(std::string_view bytes) {
  // The length first, so that ("ab", "c") and ("a", "bc") differ.
  const uint64_t size = bytes.size();
  hash_ = fnv1a(hash_, &size, sizeof(size));
  hash_ = fnv1a(hash_, bytes.data(), bytes.size());
  return *this;
}

BuildKey& BuildKey::add(const void* data, std::size_t size) {
  hash_ = fnv1a(hash_, data, size);
  return *this;
}

BuildKey& BuildKey::add(double value) {
  // -0.0 and 0.0 describe the same build.
  const double canonical = value == 0.0 ? 0.0 : value;
  hash_ = fnv1a(hash_, &canonical, sizeof(canonical));
  return *this;
}

BuildKey& BuildKey::add(int64_t value) {
  hash_ = fnv1a(hash_, &value, sizeof(value));
  return *this;
}

}  // namespace cariesim

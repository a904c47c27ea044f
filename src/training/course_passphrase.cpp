// The instructor passphrase's hash (training/course.hpp): PBKDF2-HMAC-SHA256 (RFC 8018 §5.2) through
// OpenSSL, a random salt from RAND_bytes, stored as `pbkdf2-sha256$ITER$SALT_HEX$HASH_HEX`.
#include <fmt/format.h>
#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/rand.h>

#include <charconv>

#include "cariesim/common/error.hpp"
#include "cariesim/training/course.hpp"

namespace cariesim::training {

namespace {

constexpr std::string_view kScheme = "pbkdf2-sha256";
constexpr std::size_t kMinSaltBytes = 8;  // RFC 8018 §4.1: at least eight octets

// Lower-case hex of bytes.
std::string to_hex(const std::vector<unsigned char>& bytes) {
  std::string out;
  out.reserve(2 * bytes.size());
  for (const unsigned char b : bytes) out += fmt::format("{:02x}", b);
  return out;
}

// Bytes of a hex string; false when it has an odd length or a non-hex character.
bool from_hex(std::string_view hex, std::vector<unsigned char>& out) {
  if (hex.size() % 2 != 0) return false;
  out.clear();
  for (std::size_t i = 0; i < hex.size(); i += 2) {
    unsigned value = 0;
    const auto [end, ec] = std::from_chars(hex.data() + i, hex.data() + i + 2, value, 16);
    if (ec != std::errc() || end != hex.data() + i + 2) return false;
    out.push_back(static_cast<unsigned char>(value));
  }
  return true;
}

// PBKDF2-HMAC-SHA256 of a passphrase with a salt.
std::vector<unsigned char> derive(std::string_view passphrase, const std::vector<unsigned char>& salt,
                                  int iterations, std::size_t bytes) {
  std::vector<unsigned char> key(bytes);
  if (PKCS5_PBKDF2_HMAC(passphrase.data(), static_cast<int>(passphrase.size()), salt.data(),
                        static_cast<int>(salt.size()), iterations, EVP_sha256(), static_cast<int>(bytes),
                        key.data()) != 1)
    throw Error("OpenSSL PKCS5_PBKDF2_HMAC failed");
  return key;
}

}  // namespace

PassphraseHash parse_passphrase_hash(std::string_view encoded) {
  // Four fields separated by '$'.
  std::vector<std::string_view> fields;
  std::size_t start = 0;
  while (true) {
    const std::size_t dollar = encoded.find('$', start);
    fields.push_back(encoded.substr(start, dollar == std::string_view::npos ? encoded.npos : dollar - start));
    if (dollar == std::string_view::npos) break;
    start = dollar + 1;
  }
  if (fields.size() != 4 || fields[0] != kScheme)
    throw Error(
        fmt::format("expected {}$ITERATIONS$SALT_HEX$HASH_HEX (made by `cariesim course hash`)", kScheme));
  // The iteration count, within the accepted range.
  PassphraseHash h;
  const std::string_view iter = fields[1];
  const auto [end, ec] = std::from_chars(iter.data(), iter.data() + iter.size(), h.iterations);
  if (ec != std::errc() || end != iter.data() + iter.size() || iter.empty())
    throw Error(fmt::format("iteration count '{}' is not an integer", iter));
  if (h.iterations < kPassphraseMinIterations || h.iterations > kPassphraseMaxIterations)
    throw Error(fmt::format("iteration count {} is outside [{}, {}]", h.iterations, kPassphraseMinIterations,
                            kPassphraseMaxIterations));
  // Salt and hash in hex; the salt's length is bounded before it is decoded.
  if (fields[2].size() > 2 * kPassphraseMaxSaltBytes)
    throw Error(fmt::format("the salt has {} bytes; at most {} are allowed", fields[2].size() / 2,
                            kPassphraseMaxSaltBytes));
  if (!from_hex(fields[2], h.salt)) throw Error("the salt is not hexadecimal");
  if (h.salt.size() < kMinSaltBytes)
    throw Error(fmt::format("the salt has {} bytes; at least {} are needed", h.salt.size(), kMinSaltBytes));
  if (!from_hex(fields[3], h.hash)) throw Error("the hash is not hexadecimal");
  if (h.hash.size() != kPassphraseHashBytes)
    throw Error(fmt::format("the hash has {} bytes, not {}", h.hash.size(), kPassphraseHashBytes));
  return h;
}

std::string hash_passphrase(std::string_view passphrase, int iterations) {
  if (passphrase.size() < kPassphraseMinLength)
    throw Error(fmt::format("the passphrase has {} characters; at least {} are needed", passphrase.size(),
                            kPassphraseMinLength));
  if (iterations < kPassphraseMinIterations || iterations > kPassphraseMaxIterations)
    throw Error(fmt::format("iteration count {} is outside [{}, {}]", iterations, kPassphraseMinIterations,
                            kPassphraseMaxIterations));
  // A fresh random salt, then the derived key.
  std::vector<unsigned char> salt(kPassphraseSaltBytes);
  if (RAND_bytes(salt.data(), static_cast<int>(salt.size())) != 1)
    throw Error("OpenSSL RAND_bytes could not make a salt");
  const std::vector<unsigned char> key = derive(passphrase, salt, iterations, kPassphraseHashBytes);
  return fmt::format("{}${}${}${}", kScheme, iterations, to_hex(salt), to_hex(key));
}

bool verify_passphrase(std::string_view passphrase, std::string_view encoded) {
  // The same derivation with the stored salt and count, compared in constant time.
  const PassphraseHash stored = parse_passphrase_hash(encoded);
  const std::vector<unsigned char> key =
      derive(passphrase, stored.salt, stored.iterations, stored.hash.size());
  return CRYPTO_memcmp(key.data(), stored.hash.data(), key.size()) == 0;
}

}  // namespace cariesim::training

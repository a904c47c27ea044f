#pragma once
/// The course file (docs/instructors.md): what one station of a class runs in trainee mode
/// (`cariesim run --course FILE`): the course's name, the study, where the study databases go, the
/// station's name, the participants allowed, and the hash of the instructor's passphrase that unlocks
/// the full panel. YAML, read as strictly as scenes: unknown keys, wrong types and bad values are
/// errors naming file:line:column and the field.
///
/// The passphrase is stored as a PBKDF2-HMAC-SHA256 hash (RFC 8018 §5.2, through OpenSSL's
/// PKCS5_PBKDF2_HMAC) with a random salt: `pbkdf2-sha256$ITERATIONS$SALT_HEX$HASH_HEX`.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_set>
#include <vector>

namespace cariesim::training {

/// Iterations of a new passphrase hash (OWASP's 2023 figure for PBKDF2-HMAC-SHA256; ~0.16 s here).
inline constexpr int kPassphraseIterations = 600000;
/// Fewest and most iterations a course file's hash may have (weaker is refused; more would make
/// every unlock attempt cost over half a second here: ~0.53 s at the maximum).
inline constexpr int kPassphraseMinIterations = 100000;
inline constexpr int kPassphraseMaxIterations = 2000000;
/// Bytes of a new hash's salt and of the derived key.
inline constexpr std::size_t kPassphraseSaltBytes = 16;
/// Most bytes a stored hash's salt may have (RFC 8018 asks for at least 8; 16 are made).
inline constexpr std::size_t kPassphraseMaxSaltBytes = 64;
inline constexpr std::size_t kPassphraseHashBytes = 32;
/// Shortest passphrase `hash_passphrase` accepts (characters).
inline constexpr std::size_t kPassphraseMinLength = 8;

/// A decoded `pbkdf2-sha256$ITER$SALT$HASH`.
struct PassphraseHash {
  int iterations = 0;               ///< PBKDF2 iteration count
  std::vector<unsigned char> salt;  ///< random salt, 8 to kPassphraseMaxSaltBytes bytes
  std::vector<unsigned char> hash;  ///< derived key, 32 bytes
};

/// Decodes a stored hash; throws cariesim::Error saying which part is wrong (scheme, iteration
/// count, salt or hash hex, their lengths).
PassphraseHash parse_passphrase_hash(std::string_view encoded);

/// A new hash of `passphrase` with a fresh random salt (OpenSSL RAND_bytes) in the stored format.
/// Throws cariesim::Error for a passphrase shorter than kPassphraseMinLength, or when OpenSSL fails.
std::string hash_passphrase(std::string_view passphrase, int iterations = kPassphraseIterations);

/// True when `passphrase` hashes to `encoded` (compared in constant time). Throws cariesim::Error
/// when `encoded` is malformed (parse_passphrase_hash).
bool verify_passphrase(std::string_view passphrase, std::string_view encoded);

/// What a trainee must achieve over their diagnosis cases to pass (the course file's optional
/// `criteria`, docs/instructors.md); `cariesim report --course FILE` grades each trainee against them
/// (docs/reports.md, "The gradebook"). An absent criterion is not graded.
struct PassCriteria {
  std::optional<double> detection_rate;     ///< fraction of the lesions found over all cases, at least
  std::optional<double> severity_accuracy;  ///< fraction of the found lesions graded right, at least
  std::optional<int> false_marks;           ///< false marks in any one case, at most
  std::optional<double> time_per_lesion;    ///< s, mean time to find a lesion, at most
  std::optional<double> soft_tissue_time;   ///< s pressing on gum or tongue in any one case, at most
};

/// A parsed course file.
struct Course {
  std::filesystem::path file;  ///< the course file (messages name it)
  std::string name;            ///< the course's name, shown to the trainee
  /// The study to run: a built-in study name as written, or a study file's path resolved against
  /// the course file's folder (`study_is_file`)
  std::string study;
  bool study_is_file = false;     ///< `study` is a file path (it ends in .yaml/.yml or has a '/')
  std::filesystem::path records;  ///< folder of the study databases, resolved against the course file's
  std::string station;            ///< this station's name (letters, digits, '.', '_', '-')
  std::vector<std::string> participants;  ///< participant IDs allowed; empty: any valid ID
  std::string instructor_hash;            ///< the instructor passphrase's hash (stored format above)
  std::optional<PassCriteria> criteria;   ///< what the report grades (`criteria`); none: not graded
  /// `exam_seed`: every participant gets the same cases, those of this study seed (RunOptions::
  /// same_cases); unset: each participant gets cases of their own
  std::optional<uint64_t> exam_seed;

  /// The study database this station writes: records/STATION.db.
  [[nodiscard]] std::filesystem::path database() const;
  /// Whether `id` may take part (a valid ID, and in `participants` when that list is given).
  [[nodiscard]] bool allows(std::string_view id) const;
};

/// True for a name usable as a station name, a participant ID or a study name: 1-64 characters,
/// letters, digits, '.', '_' and '-', not starting with '.' (it becomes part of file names, so it can
/// never hold a '/' or be "." or ".."). The one rule for every name that reaches a path.
bool valid_identifier(std::string_view id);
/// valid_identifier's rule in words, for messages.
inline constexpr std::string_view kIdentifierRule =
    "1-64 letters, digits, '.', '_' or '-', not starting with '.'";

/// Index of the first of `items` equal to an earlier one; items.size() when all differ. One
/// hash-set insertion each (equality only on equal hashes): linear, where comparing every pair took
/// tens of seconds for a course of 100 000 participants. `Hash` hashes a T (default std::hash<T>).
template <typename T, typename Hash = std::hash<T>>
std::size_t first_repeated(const std::vector<T>& items) {
  std::unordered_set<T, Hash> seen;
  seen.reserve(items.size());
  for (std::size_t i = 0; i < items.size(); ++i)
    if (!seen.insert(items[i]).second) return i;
  return items.size();
}

/// Parses course YAML; `origin` names it in messages and relative paths resolve against its folder.
/// Throws cariesim::Error "file:line:column: field: message".
Course parse_course(std::string_view yaml, const std::filesystem::path& origin);

/// Reads and parses a course file; throws cariesim::Error (a missing or unreadable file by name).
Course load_course(const std::filesystem::path& file);

}  // namespace cariesim::training

// Course files (training/course.hpp): parsing, located errors, and the instructor passphrase's
// PBKDF2-HMAC-SHA256 hash checked against Python's hashlib (an independent implementation).
#include "cariesim/training/course.hpp"

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <string>
#include <vector>

#include "cariesim/common/error.hpp"

namespace {

namespace fs = std::filesystem;
using cariesim::Error;
using cariesim::training::Course;
using cariesim::training::hash_passphrase;
using cariesim::training::parse_course;
using cariesim::training::parse_passphrase_hash;
using cariesim::training::verify_passphrase;
using ::testing::HasSubstr;

// PBKDF2-HMAC-SHA256("correct horse battery", salt 00..0f, 100000 iterations, 32 bytes), computed by
// Python's hashlib.pbkdf2_hmac.
constexpr const char* kKnownHash =
    "pbkdf2-sha256$100000$000102030405060708090a0b0c0d0e0f$"
    "c8d122ecdb9477cd48a6b1750c5985c0b8b05158d040d20517ccdb49865de436";
constexpr const char* kKnownPassphrase = "correct horse battery";

std::string course_yaml(const std::string& extra = "") {
  return std::string(
             "format: 1\n"
             "course: Caries diagnosis, group A\n"
             "study: diagnosis\n"
             "records: records\n"
             "station: chair-3\n"
             "instructor: ") +
         kKnownHash + "\n" + extra;
}

// The message of the Error that parsing `yaml` throws ("" when it parses).
std::string parse_error(const std::string& yaml) {
  try {
    (void)parse_course(yaml, "class/course.yaml");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(Course, ParsesEveryField) {
  const Course c = parse_course(course_yaml("participants: [P01, P02, s-17]\n"), "class/course.yaml");
  EXPECT_EQ(c.name, "Caries diagnosis, group A");
  EXPECT_EQ(c.study, "diagnosis");
  EXPECT_FALSE(c.study_is_file);
  EXPECT_EQ(c.records, fs::path("class/records"));
  EXPECT_EQ(c.station, "chair-3");
  EXPECT_EQ(c.database(), fs::path("class/records/chair-3.db"));
  EXPECT_EQ(c.instructor_hash, kKnownHash);
  ASSERT_EQ(c.participants.size(), 3u);
  EXPECT_TRUE(c.allows("P02"));
  EXPECT_FALSE(c.allows("P03")) << "not on the list";
  EXPECT_FALSE(c.allows("../P01")) << "not an identifier";
}

// The optional pass/fail criteria of the report (docs/instructors.md "Pass or fail"): each read in
// its range, absent ones not graded; a course without them grades nothing.
TEST(Course, CriteriaAreReadStrictly) {
  const Course c = parse_course(course_yaml("criteria:\n  detection_rate: 0.8\n  false_marks: 1\n"
                                            "  time_per_lesion: 30\n"),
                                "class/course.yaml");
  ASSERT_TRUE(c.criteria.has_value());
  EXPECT_EQ(c.criteria->detection_rate, 0.8);
  EXPECT_EQ(c.criteria->false_marks, 1);
  EXPECT_EQ(c.criteria->time_per_lesion, 30.0);
  EXPECT_FALSE(c.criteria->severity_accuracy.has_value());
  EXPECT_FALSE(c.criteria->soft_tissue_time.has_value());
  EXPECT_FALSE(parse_course(course_yaml(), "class/course.yaml").criteria.has_value());

  EXPECT_THAT(parse_error(course_yaml("criteria:\n  detection_rate: 1.5\n")),
              HasSubstr("class/course.yaml:8:19: criteria.detection_rate: 1.5 is out of range [0, 1]"));
  EXPECT_THAT(parse_error(course_yaml("criteria:\n  false_marks: 0.5\n")),
              HasSubstr("criteria.false_marks: expected an integer"));
  EXPECT_THAT(parse_error(course_yaml("criteria:\n  time_per_lesion: 0\n")),
              HasSubstr("criteria.time_per_lesion"));
  EXPECT_THAT(parse_error(course_yaml("criteria:\n  soft_tissue_time: -1\n")),
              HasSubstr("criteria.soft_tissue_time: -1 is out of range"));
  EXPECT_THAT(parse_error(course_yaml("criteria:\n  detection_rat: 1\n")), HasSubstr("detection_rate"));
  EXPECT_THAT(parse_error(course_yaml("criteria: {}\n")), HasSubstr("criteria: no criterion given"));
  EXPECT_THAT(parse_error(course_yaml("criteria: [1]\n")), HasSubstr("criteria"));
}

TEST(Course, WithoutAListAnyValidIdTakesPart) {
  const Course c = parse_course(course_yaml(), "course.yaml");
  EXPECT_TRUE(c.participants.empty());
  EXPECT_TRUE(c.allows("anyone_7"));
  EXPECT_FALSE(c.allows(""));
  EXPECT_FALSE(c.allows("a b"));
  EXPECT_FALSE(c.allows(".hidden"));
  EXPECT_FALSE(c.allows(std::string(65, 'x')));
}

TEST(Course, AStudyFileResolvesAgainstTheCourseFileAndMustExist) {
  const fs::path dir = fs::temp_directory_path() / "cariesim-course-test";
  fs::create_directories(dir / "studies");
  std::ofstream(dir / "studies" / "mine.yaml") << "# a study\n";
  std::string yaml = course_yaml();
  yaml.replace(yaml.find("study: diagnosis"), 16, "study: studies/mine.yaml");
  const Course c = parse_course(yaml, dir / "course.yaml");
  EXPECT_TRUE(c.study_is_file);
  EXPECT_EQ(fs::path(c.study), dir / "studies" / "mine.yaml");

  yaml.replace(yaml.find("mine.yaml"), 9, "gone.yaml");
  try {
    (void)parse_course(yaml, dir / "course.yaml");
    FAIL() << "a missing study file parses";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("course.yaml:3:8: study: study file not found"));
    EXPECT_THAT(e.what(), HasSubstr("gone.yaml"));
  }
  fs::remove_all(dir);
}

TEST(Course, ErrorsNameFileLineColumnAndField) {
  // Unknown key, with a hint.
  EXPECT_THAT(parse_error(course_yaml("stations: 4\n")), HasSubstr("class/course.yaml:7:1"));
  EXPECT_THAT(parse_error(course_yaml("stations: 4\n")), HasSubstr("station"));
  // Missing fields.
  std::string no_study = course_yaml();
  no_study.erase(no_study.find("study: diagnosis\n"), 17);
  EXPECT_THAT(parse_error(no_study), HasSubstr("study: missing required field"));
  std::string no_hash = course_yaml();
  no_hash.erase(no_hash.find("instructor:"));
  EXPECT_THAT(parse_error(no_hash), HasSubstr("instructor: missing required field"));
  // Bad values.
  std::string bad_station = course_yaml();
  bad_station.replace(bad_station.find("chair-3"), 7, "chair 3/../x");
  EXPECT_THAT(parse_error(bad_station),
              HasSubstr("course.yaml:5:10: station: 'chair 3/../x' is not a valid name"));
  EXPECT_THAT(parse_error(course_yaml("participants: [P01, P01]\n")),
              HasSubstr("7:21: participants[1]: participant 'P01' is listed twice"));
  EXPECT_THAT(parse_error(course_yaml("participants: P01\n")), HasSubstr("participants"));
  std::string empty_name = course_yaml();
  empty_name.replace(empty_name.find("Caries diagnosis, group A"), 25, "''");
  EXPECT_THAT(parse_error(empty_name), HasSubstr("2:9: course: must not be empty"));
  std::string unknown_study = course_yaml();
  unknown_study.replace(unknown_study.find("study: diagnosis"), 16, "study: diagnosys");
  EXPECT_THAT(parse_error(unknown_study),
              HasSubstr("3:8: study: no built-in study 'diagnosys' (built-ins: "));
  std::string format2 = course_yaml();
  format2.replace(format2.find("format: 1"), 9, "format: 2");
  EXPECT_THAT(parse_error(format2), HasSubstr("1:9: format"));
  // A hash that is not one.
  std::string weak = course_yaml();
  weak.replace(weak.find("$100000$"), 8, "$1000$");
  EXPECT_THAT(parse_error(weak), HasSubstr("6:13: instructor: iteration count 1000 is outside"));
  std::string plain = course_yaml();
  plain.replace(plain.find(kKnownHash), std::string(kKnownHash).size(), "letmein");
  EXPECT_THAT(parse_error(plain), HasSubstr("6:13: instructor: expected pbkdf2-sha256$ITERATIONS"));
  // A salt beyond kPassphraseMaxSaltBytes (20 MB was accepted), and a cost beyond the bound.
  std::string long_salt = course_yaml();
  long_salt.replace(long_salt.find("000102030405060708090a0b0c0d0e0f"), 32, std::string(2 * 65, 'a'));
  EXPECT_THAT(parse_error(long_salt), HasSubstr("6:13: instructor: the salt has 65 bytes; at most 64"));
  std::string huge_salt = course_yaml();
  huge_salt.replace(huge_salt.find("000102030405060708090a0b0c0d0e0f"), 32, std::string(2 << 20, 'a'));
  EXPECT_THAT(parse_error(huge_salt), HasSubstr("6:13: instructor: the salt has 1048576 bytes; at most 64"));
  std::string costly = course_yaml();
  costly.replace(costly.find("$100000$"), 8, "$10000000$");
  EXPECT_THAT(parse_error(costly), HasSubstr("6:13: instructor: iteration count 10000000 is outside"));
  // A records folder that is a system folder, the root or a top-level folder.
  for (const char* records :
       {"/", "/etc", "/proc/self", "../../../../../../../../../../etc", "/tmp", "/usr/share/x"}) {
    std::string yaml = course_yaml();
    yaml.replace(yaml.find("records: records"), 16, std::string("records: '") + records + "'");
    EXPECT_THAT(parse_error(yaml),
                HasSubstr("class/course.yaml:4:10: records: '" + std::string(records) + "' is "))
        << records;
  }
  // Syntax, and a document that is not a mapping.
  EXPECT_THAT(parse_error("course: [unclosed\n"), HasSubstr("class/course.yaml:"));
  EXPECT_THAT(parse_error("course: [unclosed\n"), HasSubstr("YAML syntax error"));
  EXPECT_NE(parse_error("- a list\n"), "");
  EXPECT_EQ(parse_error(course_yaml()), "");
}

// The course with `records: RECORDS`, parsed as class/course.yaml: its error ("" when it parses).
std::string records_error(const std::string& records) {
  std::string yaml = course_yaml();
  yaml.replace(yaml.find("records: records"), 16, "records: '" + records + "'");
  return parse_error(yaml);
}

// `records:` took any folder: `/`, `/etc`, `/proc/self` (the station then wrote its database there, or
// failed at the first trial). It must be a folder of its own outside the system's folders, also when
// `..` or a symbolic link leads there; the message names the field and what the folder resolved to.
TEST(Course, RecordsMustBeAFolderOfItsOwnOutsideTheSystemFolders) {
  EXPECT_THAT(records_error("/"), HasSubstr("records: '/' is the root folder (/)"));
  EXPECT_THAT(records_error("/etc"), HasSubstr("records: '/etc' is inside the system folder /etc"));
  EXPECT_THAT(records_error("/proc/self"), HasSubstr("inside the system folder /proc"));
  EXPECT_THAT(records_error("/sys/kernel"), HasSubstr("inside the system folder /sys"));
  EXPECT_THAT(records_error("/dev/shm/x"), HasSubstr("inside the system folder /dev"));
  EXPECT_THAT(records_error("/var/log/cariesim"), HasSubstr("inside the system folder /var"));
  EXPECT_THAT(records_error("/home"), HasSubstr("the top-level folder /home"));
  EXPECT_THAT(records_error("/var/tmp"), HasSubstr("the shared folder /var/tmp"));
  EXPECT_THAT(records_error("../../../../../../../../../../../../../../etc"),
              HasSubstr("inside the system folder /etc"));
  // A symbolic link to a system folder counts as that folder.
  const fs::path dir = fs::temp_directory_path() / ("cariesim-records-link-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  fs::create_directory_symlink("/etc", dir / "records");
  std::string yaml = course_yaml();
  try {
    (void)parse_course(yaml, dir / "course.yaml");
    ADD_FAILURE() << "records through a link to /etc parses";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("records: 'records' is inside the system folder /etc (/etc)"));
  }
  fs::remove_all(dir);
  // Folders of their own are taken: beside the course file, below /tmp, /var/lib, /media, a home.
  for (const char* good :
       {"records", "r/a/b", "/tmp/class/records", "/var/tmp/cariesim", "/var/lib/cariesim/records",
        "/media/usb-stick/records", "/home/lab/records", "/srv/cariesim"})
    EXPECT_EQ(records_error(good), "") << good;
}

// A participant ID that counts the equality comparisons made on it.
struct CountedId {
  std::string id;
  static inline long comparisons = 0;
  bool operator==(const CountedId& other) const {
    ++comparisons;
    return id == other.id;
  }
};
struct CountedIdHash {
  std::size_t operator()(const CountedId& c) const { return std::hash<std::string>{}(c.id); }
};

// Duplicates were found by comparing every pair (a course of 100 000 participants took minutes to
// check: 5e9 comparisons). first_repeated makes one hash-set insertion per ID: for 100 000 distinct
// IDs and a repeat at the end it compares a handful of times per ID, not 100 000 (counted, not timed).
TEST(Course, RepeatedParticipantsAreFoundInLinearTime) {
  constexpr std::size_t kCount = 100000;
  std::vector<CountedId> ids;
  for (std::size_t i = 0; i < kCount; ++i) ids.push_back({fmt::format("P{:06d}", i)});
  ids.push_back({"P000017"});
  CountedId::comparisons = 0;
  const auto first_repeated = [](const std::vector<CountedId>& v) {
    return cariesim::training::first_repeated<CountedId, CountedIdHash>(v);
  };
  EXPECT_EQ(first_repeated(ids), kCount);
  EXPECT_LT(CountedId::comparisons, static_cast<long>(2 * kCount)) << "comparisons for " << kCount << " IDs";
  ids.pop_back();
  EXPECT_EQ(first_repeated(ids), kCount) << "all differ";
  EXPECT_EQ(cariesim::training::first_repeated(std::vector<std::string>{"a", "b", "a", "b"}), 2u);
  EXPECT_EQ(cariesim::training::first_repeated(std::vector<std::string>{}), 0u);
}

// A course file listing 100 000 participants parses (in about a second) and names a repeat at its line.
TEST(Course, AHundredThousandParticipantsAreChecked) {
  constexpr int kCount = 100000;
  std::string list = "participants:\n";
  list.reserve(kCount * 12);
  for (int i = 0; i < kCount; ++i) list += fmt::format("  - P{:06d}\n", i);
  const Course c = parse_course(course_yaml(list), "class/course.yaml");
  ASSERT_EQ(c.participants.size(), static_cast<std::size_t>(kCount));
  EXPECT_EQ(c.participants.back(), "P099999");
  EXPECT_TRUE(c.allows("P054321"));
  EXPECT_THAT(
      parse_error(course_yaml(list + "  - P000017\n")),
      HasSubstr(fmt::format("class/course.yaml:{}:5: participants[{}]: participant 'P000017' is listed "
                            "twice",
                            7 + kCount + 1, kCount)));
}

TEST(Course, AMissingFileIsNamed) {
  try {
    (void)cariesim::training::load_course("/nonexistent/course.yaml");
    FAIL() << "a missing course file loads";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("/nonexistent/course.yaml: course: file not found"));
  }
}

TEST(Passphrase, MatchesAnIndependentPbkdf2Implementation) {
  EXPECT_TRUE(verify_passphrase(kKnownPassphrase, kKnownHash));
  EXPECT_FALSE(verify_passphrase("correct horse battery ", kKnownHash));
  EXPECT_FALSE(verify_passphrase("Correct horse battery", kKnownHash));
  EXPECT_FALSE(verify_passphrase("", kKnownHash));
}

TEST(Passphrase, NewHashesVerifyAndEachHasItsOwnSalt) {
  const std::string a = hash_passphrase("open sesame", cariesim::training::kPassphraseMinIterations);
  const std::string b = hash_passphrase("open sesame", cariesim::training::kPassphraseMinIterations);
  EXPECT_NE(a, b) << "a random salt per hash";
  EXPECT_THAT(a, ::testing::StartsWith("pbkdf2-sha256$100000$"));
  EXPECT_TRUE(verify_passphrase("open sesame", a));
  EXPECT_TRUE(verify_passphrase("open sesame", b));
  EXPECT_FALSE(verify_passphrase("open sesamE", a));
  const auto decoded = parse_passphrase_hash(a);
  EXPECT_EQ(decoded.salt.size(), cariesim::training::kPassphraseSaltBytes);
  EXPECT_EQ(decoded.hash.size(), cariesim::training::kPassphraseHashBytes);
  // The default count.
  EXPECT_EQ(parse_passphrase_hash(hash_passphrase("open sesame")).iterations,
            cariesim::training::kPassphraseIterations);
}

TEST(Passphrase, RefusesShortPassphrasesAndMalformedHashes) {
  EXPECT_THROW((void)hash_passphrase("short"), Error);
  EXPECT_THROW((void)hash_passphrase("long enough", 10), Error);
  const std::set<std::string> bad = {
      "",
      "pbkdf2-sha1$100000$00010203040506070809$" + std::string(64, 'a'),
      "pbkdf2-sha256$100000$0001020304050607$" + std::string(63, 'a'),
      "pbkdf2-sha256$100000$000102030405060g$" + std::string(64, 'a'),
      "pbkdf2-sha256$100000$00010203$" + std::string(64, 'a'),
      "pbkdf2-sha256$100000$0001020304050607$" + std::string(62, 'a'),
      "pbkdf2-sha256$1e5$0001020304050607$" + std::string(64, 'a'),
      "pbkdf2-sha256$99999999999$0001020304050607$" + std::string(64, 'a'),
      "pbkdf2-sha256$100000$0001020304050607$" + std::string(64, 'a') + "$extra",
      // A salt longer than kPassphraseMaxSaltBytes (it was unbounded), a cost above the bound.
      "pbkdf2-sha256$100000$" + std::string(2 * 65, '0') + "$" + std::string(64, 'a'),
      "pbkdf2-sha256$2000001$0001020304050607$" + std::string(64, 'a'),
  };
  for (const std::string& h : bad) {
    EXPECT_THROW((void)parse_passphrase_hash(h), Error) << h;
    EXPECT_THROW((void)verify_passphrase("anything", h), Error) << h;
  }
  EXPECT_NO_THROW(
      (void)parse_passphrase_hash("pbkdf2-sha256$100000$0001020304050607$" + std::string(64, 'a')));
  EXPECT_NO_THROW((void)parse_passphrase_hash("pbkdf2-sha256$2000000$" + std::string(2 * 64, '0') + "$" +
                                              std::string(64, 'a')))
      << "the largest salt and cost";
}

// docs/instructors.md's example course file parses, and its hash is of the passphrase the page names.
TEST(Course, TheInstructorsPageExampleIsValid) {
  std::ifstream in(fs::path(CARIESIM_SOURCE_DIR) / "docs" / "instructors.md");
  const std::string doc((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::size_t section = doc.find("## 2. The course file");
  ASSERT_NE(section, std::string::npos);
  const std::size_t open = doc.find("```yaml\n", section);
  ASSERT_NE(open, std::string::npos);
  const std::size_t close = doc.find("```", open + 8);
  const Course c = parse_course(doc.substr(open + 8, close - open - 8), "docs/course.yaml");
  EXPECT_EQ(c.study, "diagnosis");
  EXPECT_EQ(c.station, "chair-3");
  EXPECT_EQ(c.database(), fs::path("docs/records/chair-3.db"));
  EXPECT_EQ(c.participants.size(), 3u);
  ASSERT_TRUE(c.criteria.has_value());
  EXPECT_EQ(c.criteria->detection_rate, 1.0);
  EXPECT_EQ(c.criteria->time_per_lesion, 30.0);
  EXPECT_NE(doc.find("hash of `change me please`"), std::string::npos);
  EXPECT_TRUE(verify_passphrase("change me please", c.instructor_hash));
  EXPECT_EQ(parse_passphrase_hash(c.instructor_hash).iterations, cariesim::training::kPassphraseIterations);
}

}  // namespace

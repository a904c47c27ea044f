// Round trip: a synthetic stream recorded through the real Recorder, read back with load_recording
// and exported as CSV; the CSV is parsed again and every field compared with what was pushed.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <thread>

#include "cariesim/common/error.hpp"
#include "cariesim/device/trajectory_csv.hpp"
#include "cariesim/record/recorder.hpp"
#include "record/record_support.hpp"
#include "support/files.hpp"

namespace cariesim {
namespace {

using test::same;
using ::testing::ElementsAreArray;
using ::testing::HasSubstr;

using Table = std::vector<std::vector<std::string>>;

// RFC 4180 reader: quoted fields may hold commas, doubled quotes and line breaks.
Table read_csv(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  const std::string s = text.str();
  Table rows;
  std::vector<std::string> row;
  std::string field;
  bool quoted = false;
  for (std::size_t i = 0; i < s.size(); ++i) {
    const char c = s[i];
    if (quoted) {
      if (c == '"' && i + 1 < s.size() && s[i + 1] == '"') {
        field += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        field += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      row.push_back(field);
      field.clear();
    } else if (c == '\n') {
      row.push_back(field);
      field.clear();
      rows.push_back(row);
      row.clear();
    } else {
      field += c;
    }
  }
  EXPECT_TRUE(row.empty() && field.empty()) << file << " does not end with a line break";
  return rows;
}

double as_double(const std::string& text) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  EXPECT_EQ(*end, '\0') << "not a number: '" << text << "'";
  return v;
}

float as_float(const std::string& text) {
  char* end = nullptr;
  const float v = std::strtof(text.c_str(), &end);
  EXPECT_EQ(*end, '\0') << "not a number: '" << text << "'";
  return v;
}

long long as_int(const std::string& text) {
  char* end = nullptr;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  EXPECT_EQ(*end, '\0') << "not an integer: '" << text << "'";
  return v;
}

// The stream: the synthetic samples, one with a NaN pose and an infinite force (a broken device),
// one with every flag bit and the largest codes.
std::vector<ServoSample> make_stream(double rate) {
  std::vector<ServoSample> stream;
  for (std::size_t i = 0; i < 2000; ++i) stream.push_back(test::synthetic_sample(i, rate));
  stream[777].haptic.p.x() = std::numeric_limits<double>::quiet_NaN();
  stream[777].haptic.q = Quat(std::numeric_limits<double>::quiet_NaN(), 0, 0, 0);
  stream[777].force.z() = std::numeric_limits<double>::infinity();
  stream[778].step_flags = 0xffffffffu;
  stream[778].safety_flags = 0x3fu;
  stream[778].buttons = 0xffffffffu;
  stream[778].contacts = 65535;
  stream[778].lesion = 127;
  stream[779].lesion = -128;
  stream[779].step_us = 1e-30f;
  return stream;
}

void expect_same_sample(const ServoSample& a, const ServoSample& b, std::size_t i) {
  ASSERT_TRUE(same(a.t, b.t)) << i;
  for (int k = 0; k < 3; ++k) {
    EXPECT_TRUE(same(a.haptic.p[k], b.haptic.p[k])) << i << " haptic p" << k;
    EXPECT_TRUE(same(a.graphic.p[k], b.graphic.p[k])) << i << " graphic p" << k;
    EXPECT_TRUE(same(a.force[k], b.force[k])) << i << " force" << k;
    EXPECT_TRUE(same(a.torque[k], b.torque[k])) << i << " torque" << k;
  }
  for (int k = 0; k < 4; ++k) {
    EXPECT_TRUE(same(a.haptic.q.coeffs()[k], b.haptic.q.coeffs()[k])) << i << " haptic q" << k;
    EXPECT_TRUE(same(a.graphic.q.coeffs()[k], b.graphic.q.coeffs()[k])) << i << " graphic q" << k;
  }
  EXPECT_EQ(a.state, b.state) << i;
  EXPECT_EQ(a.depth, b.depth) << i;
  EXPECT_EQ(a.contacts, b.contacts) << i;
  EXPECT_EQ(a.lesion, b.lesion) << i;
  EXPECT_EQ(a.step_us, b.step_us) << i;
  EXPECT_EQ(a.soft_tissue_force, b.soft_tissue_force) << i;
  EXPECT_EQ(a.step_flags, b.step_flags) << i;
  EXPECT_EQ(a.safety_flags, b.safety_flags) << i;
  EXPECT_EQ(a.overrun, b.overrun) << i;
  EXPECT_EQ(a.buttons, b.buttons) << i;
}

// A samples.csv row back into a sample.
ServoSample parse_sample(const std::vector<std::string>& f) {
  ServoSample s;
  std::size_t i = 0;
  s.t = as_double(f[i++]);
  for (Pose* pose : {&s.haptic, &s.graphic}) {
    for (int k = 0; k < 3; ++k) pose->p[k] = as_double(f[i++]);
    const double w = as_double(f[i++]);
    const double x = as_double(f[i++]);
    const double y = as_double(f[i++]);
    const double z = as_double(f[i++]);
    pose->q = Quat(w, x, y, z);
  }
  for (int k = 0; k < 3; ++k) s.force[k] = as_double(f[i++]);
  for (int k = 0; k < 3; ++k) s.torque[k] = as_double(f[i++]);
  const std::string state = f[i++];
  for (int code = 0; code < 4; ++code)
    if (state == state_name(static_cast<InteractionState>(code)))
      s.state = static_cast<InteractionState>(code);
  EXPECT_EQ(state, state_name(s.state));
  s.depth = as_float(f[i++]);
  s.contacts = static_cast<uint16_t>(as_int(f[i++]));
  s.step_us = as_float(f[i++]);
  s.lesion = static_cast<int8_t>(as_int(f[i++]));
  s.soft_tissue_force = as_float(f[i++]);
  s.step_flags = static_cast<uint32_t>(as_int(f[i++]));
  s.safety_flags = static_cast<uint32_t>(as_int(f[i++]));
  s.overrun = as_int(f[i++]) != 0;
  s.buttons = static_cast<uint32_t>(as_int(f[i++]));
  return s;
}

TEST(Export, RoundTripsEveryField) {
  test::ScratchDir dir("export");
  const auto file = dir / "session.db";
  const double rate = 1000.0;
  const std::vector<ServoSample> stream = make_stream(rate);
  const SessionInfo info = test::synthetic_session(rate);
  {
    Recorder recorder(file, info);
    recorder.start();
    recorder.record_event({0.5, "param", "lesion1 \"mu_s\", severe", 0.51, 1, 0.0});
    for (const ServoSample& s : stream)
      while (!recorder.queue().push(s)) std::this_thread::yield();
    recorder.stop();
    ASSERT_TRUE(recorder.status().ok) << recorder.status().message;
  }

  // The database holds exactly what was pushed.
  const Recording recording = load_recording(file);
  ASSERT_EQ(recording.samples.size(), stream.size());
  for (std::size_t i = 0; i < stream.size(); ++i) expect_same_sample(recording.samples[i], stream[i], i);
  EXPECT_EQ(recording.info.scene, info.scene);
  EXPECT_EQ(recording.info.scene_hash, info.scene_hash);
  EXPECT_EQ(recording.info.device, info.device);
  EXPECT_EQ(recording.info.rate_hz, info.rate_hz);
  EXPECT_EQ(recording.info.version, info.version);
  EXPECT_EQ(recording.info.parameters, info.parameters);
  EXPECT_EQ(recording.info.started_at, info.started_at);
  EXPECT_FALSE(recording.info.ended_at.empty());
  EXPECT_EQ(recording.schema_version, 1);
  ASSERT_FALSE(recording.events.empty());

  // The CSV files hold the same.
  const auto out = dir / "csv";
  const ExportSummary summary = export_recording_csv(file, out);
  EXPECT_EQ(summary.samples, stream.size());
  EXPECT_EQ(summary.events, recording.events.size());

  const Table session = read_csv(out / "session.csv");
  ASSERT_EQ(session.size(), 2u);
  EXPECT_THAT(session[0],
              ElementsAreArray({"scene", "scene_hash", "device", "rate_hz", "version", "parameters",
                                "started_at", "ended_at", "batch_seconds", "soft_tissue_threshold"}));
  ASSERT_EQ(session[1].size(), 10u);
  EXPECT_EQ(session[1][0], info.scene);
  EXPECT_EQ(session[1][1], "fedcba9876543210");
  EXPECT_EQ(session[1][2], info.device);
  EXPECT_EQ(as_double(session[1][3]), info.rate_hz);
  EXPECT_EQ(session[1][4], info.version);
  EXPECT_EQ(session[1][5], info.parameters);
  EXPECT_EQ(session[1][6], info.started_at);
  EXPECT_EQ(session[1][7], recording.info.ended_at);
  EXPECT_EQ(as_double(session[1][8]), RecorderOptions{}.batch_seconds);
  EXPECT_EQ(as_double(session[1][9]), RecorderOptions{}.soft_tissue_threshold);

  const Table samples = read_csv(out / "samples.csv");
  ASSERT_EQ(samples.size(), stream.size() + 1);
  EXPECT_THAT(samples[0], ElementsAreArray({"t",          "h_px",         "h_py",
                                            "h_pz",       "h_qw",         "h_qx",
                                            "h_qy",       "h_qz",         "g_px",
                                            "g_py",       "g_pz",         "g_qw",
                                            "g_qx",       "g_qy",         "g_qz",
                                            "fx",         "fy",           "fz",
                                            "tx",         "ty",           "tz",
                                            "state",      "depth",        "contacts",
                                            "step_us",    "lesion",       "soft_tissue_force",
                                            "step_flags", "safety_flags", "overrun",
                                            "buttons"}));
  for (std::size_t i = 0; i < stream.size(); ++i) {
    ASSERT_EQ(samples[i + 1].size(), samples[0].size()) << i;
    expect_same_sample(parse_sample(samples[i + 1]), stream[i], i);
  }

  const Table events = read_csv(out / "events.csv");
  ASSERT_EQ(events.size(), recording.events.size() + 1);
  EXPECT_THAT(events[0], ElementsAreArray({"t", "kind", "detail", "value", "lesion", "duration"}));
  bool param_seen = false;
  for (std::size_t i = 0; i < recording.events.size(); ++i) {
    const RecordedEvent& e = recording.events[i];
    const std::vector<std::string>& row = events[i + 1];
    ASSERT_EQ(row.size(), 6u);
    EXPECT_TRUE(same(as_double(row[0]), e.t)) << i;
    EXPECT_EQ(row[1], e.kind) << i;
    EXPECT_EQ(row[2], e.detail) << i;
    EXPECT_TRUE(same(as_double(row[3]), e.value)) << i;
    EXPECT_EQ(as_int(row[4]), e.lesion) << i;
    EXPECT_TRUE(same(as_double(row[5]), e.duration)) << i;
    param_seen = param_seen || (e.kind == "param" && e.detail == "lesion1 \"mu_s\", severe");
  }
  EXPECT_TRUE(param_seen);

  // trajectory.csv is a `cariesim sim` trajectory of the finite haptic poses.
  const Trajectory trajectory = load_trajectory_csv(out / "trajectory.csv");
  EXPECT_EQ(trajectory.t.size(), stream.size() - 1);
  EXPECT_EQ(summary.trajectory_rows, stream.size() - 1);
  EXPECT_EQ(trajectory.t[800], stream[801].t);
  EXPECT_LT((trajectory.pose[800].p - stream[801].haptic.p).norm(), 1e-12);
}

// Text from a recording (a scene name, a device spec, an event's detail) that a spreadsheet would run
// as a formula is neutralised in the CSV with a leading quote; numbers are not (a negative value
// stays a number).
TEST(Export, FormulaLeadingTextIsNeutralised) {
  test::ScratchDir dir("export_formula");
  const auto file = dir / "session.db";
  SessionInfo info = test::synthetic_session(1000.0);
  info.scene = "=HYPERLINK(\"http://x\",\"y\")";
  info.device = "-2+3";
  {
    Recorder recorder(file, info);
    recorder.start();
    recorder.record_event({0.5, "param", "@SUM(A1:A9)", -0.25, 1, 0.0});
    for (std::size_t i = 0; i < 10; ++i)
      while (!recorder.queue().push(test::synthetic_sample(i, 1000.0))) std::this_thread::yield();
    recorder.stop();
    ASSERT_TRUE(recorder.status().ok) << recorder.status().message;
  }
  const auto out = dir / "csv";
  export_recording_csv(file, out);
  const Table session = read_csv(out / "session.csv");
  ASSERT_EQ(session.size(), 2u);
  EXPECT_EQ(session[1][0], "'=HYPERLINK(\"http://x\",\"y\")");
  EXPECT_EQ(session[1][2], "'-2+3");
  bool seen = false;
  for (const auto& row : read_csv(out / "events.csv"))
    if (row[1] == "param") {
      EXPECT_EQ(row[2], "'@SUM(A1:A9)");
      EXPECT_EQ(row[3], "-0.25");
      seen = true;
    }
  EXPECT_TRUE(seen);
}

TEST(Export, UnreadableInputsThrowNamingTheFile) {
  test::ScratchDir dir("export_errors");
  const auto missing = dir / "missing.db";
  try {
    export_recording_csv(missing, dir / "out");
    FAIL() << "exported a missing file";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr(missing.string()));
  }
  const auto text = dir / "text.db";
  std::ofstream(text) << "this is not a database, it is a text file with enough bytes to be read as a header "
                         "by SQLite and rejected";
  EXPECT_THROW(load_recording(text), Error);
  try {
    load_recording(text);
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("not a cariesim recording"));
  }
}

// An export that fails part way (here a recording whose samples table is gone) leaves the earlier
// good export's files (samples.csv, trajectory.csv) as they were: it writes into a staging folder
// and moves the files into place only when all are complete.
TEST(Export, AFailedExportLeavesAnEarlierOneAsItWas) {
  test::ScratchDir dir("export_atomic");
  const auto good = dir / "good.db";
  const auto broken = dir / "broken.db";
  for (const auto& file : {good, broken}) {
    Recorder recorder(file, test::synthetic_session(1000.0));
    for (std::size_t i = 0; i < 300; ++i)
      ASSERT_TRUE(recorder.queue().push(test::synthetic_sample(i, 1000.0)));
    recorder.start();
    recorder.stop();
  }
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(broken.c_str(), &db), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(db, "DROP TABLE samples", nullptr, nullptr, nullptr), SQLITE_OK);
    sqlite3_close(db);
  }
  const auto out = dir / "export";
  const ExportSummary first = export_recording_csv(good, out);
  ASSERT_EQ(first.samples, 300u);
  std::map<std::string, std::string> before;
  for (const auto& f : first.files) before[f.filename().string()] = test::read_text(f);
  EXPECT_THROW(export_recording_csv(broken, out), Error);
  for (const auto& [name, text] : before) EXPECT_EQ(test::read_text(out / name), text) << name;
  // Nothing is left behind but the export itself.
  std::size_t entries = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir.path())) {
    (void)entry;
    ++entries;
  }
  EXPECT_EQ(entries, 3u) << "good.db, broken.db, export";
  // Exporting into a new folder by a relative path with a trailing slash works too.
  const ExportSummary fresh = export_recording_csv(good, (dir / "fresh/").string());
  EXPECT_EQ(fresh.files.front().parent_path(), (dir / "fresh"));
  EXPECT_EQ(test::read_text(dir / "fresh" / "samples.csv"), before["samples.csv"]);
}

}  // namespace
}  // namespace cariesim

#include "cariesim/io/csv.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cstring>
#include <iterator>

#include "cariesim/common/error.hpp"

namespace cariesim::io {

namespace {

// Buffered bytes written out at once.
constexpr std::size_t kFlushBytes = std::size_t{1} << 16;

}  // namespace

std::string csv_text(std::string_view text) {
  // A spreadsheet runs a cell starting with one of these as a formula: make it text.
  std::string cell;
  if (!text.empty() && std::string_view("=+-@\t\r").find(text.front()) != std::string_view::npos)
    cell += '\'';
  cell += text;
  if (cell.find_first_of(",\"\r\n") == std::string::npos) return cell;
  // RFC 4180: the whole field in double quotes, each double quote doubled.
  std::string quoted = "\"";
  for (const char c : cell) {
    if (c == '"') quoted += '"';
    quoted += c;
  }
  return quoted + '"';
}

CsvWriter::CsvWriter(const std::filesystem::path& file) : file_(file), out_(std::fopen(file.c_str(), "wb")) {
  if (out_ == nullptr) throw Error(file.string() + ": cannot write: " + std::strerror(errno));
}

CsvWriter::~CsvWriter() {
  // What is buffered goes out as far as it can; only close() reports.
  if (out_ == nullptr) return;
  if (!buffer_.empty()) (void)std::fwrite(buffer_.data(), 1, buffer_.size(), out_);
  std::fclose(out_);
}

CsvWriter& CsvWriter::header(std::initializer_list<std::string_view> keys) {
  for (const std::string_view key : keys) text(key);
  end_row();
  return *this;
}

CsvWriter& CsvWriter::header(const std::vector<std::string>& keys) {
  for (const std::string& key : keys) text(key);
  end_row();
  return *this;
}

void CsvWriter::separate() {
  if (row_started_) buffer_ += ',';
  row_started_ = true;
}

CsvWriter& CsvWriter::text(std::string_view value) {
  separate();
  buffer_ += csv_text(value);
  return *this;
}

CsvWriter& CsvWriter::number(double value) {
  separate();
  fmt::format_to(std::back_inserter(buffer_), "{}", value);
  return *this;
}

CsvWriter& CsvWriter::number(float value) {
  separate();
  fmt::format_to(std::back_inserter(buffer_), "{}", value);
  return *this;
}

CsvWriter& CsvWriter::number(double value, int significant) {
  separate();
  char text[64];
  std::snprintf(text, sizeof text, "%.*g", significant, value);
  buffer_ += text;
  return *this;
}

CsvWriter& CsvWriter::fixed(double value, int decimals) {
  separate();
  // %f of 1e308 has 309 digits before the point.
  char text[400];
  std::snprintf(text, sizeof text, "%.*f", decimals, value);
  buffer_ += text;
  return *this;
}

CsvWriter& CsvWriter::integer(std::int64_t value) {
  separate();
  fmt::format_to(std::back_inserter(buffer_), "{}", value);
  return *this;
}

CsvWriter& CsvWriter::empty() {
  separate();
  return *this;
}

void CsvWriter::end_row() {
  buffer_ += '\n';
  row_started_ = false;
  if (buffer_.size() >= kFlushBytes) flush();
}

void CsvWriter::flush() {
  if (out_ == nullptr) throw Error(file_.string() + ": write failed (already closed)");
  if (!buffer_.empty() && std::fwrite(buffer_.data(), 1, buffer_.size(), out_) != buffer_.size())
    throw Error(file_.string() + ": write failed: " + std::strerror(errno));
  buffer_.clear();
}

void CsvWriter::close() {
  flush();
  const int rc = std::fclose(out_);
  out_ = nullptr;
  if (rc != 0) throw Error(file_.string() + ": write failed: " + std::strerror(errno));
}

}  // namespace cariesim::io

#pragma once
/// The one CSV writer of cariesim (`cariesim export`, the report's tables, the experiments' data): it
/// keeps quoting and cell safety in one place. Every text cell and every column key is quoted when it
/// needs to be (RFC 4180: a comma, a double quote, CR or LF; quotes doubled), and a text cell that a
/// spreadsheet would run as a formula (starting with =, +, -, @, TAB or CR) gets a leading single
/// quote first (OWASP's "CSV injection" rule). Numbers are written as numbers, never changed. Rows
/// end with '\n'. The file is written through a buffer; every failure names it.
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <initializer_list>
#include <string>
#include <string_view>
#include <vector>

namespace cariesim::io {

/// A text cell as a CSV field: neutralised when formula-leading, then quoted when needed.
std::string csv_text(std::string_view text);

class CsvWriter {
 public:
  /// Creates (or truncates) `file`; throws cariesim::Error "FILE: cannot write: reason".
  explicit CsvWriter(const std::filesystem::path& file);
  /// Writes what is buffered and closes the file without reporting (call close() to know the file is
  /// whole).
  ~CsvWriter();
  CsvWriter(const CsvWriter&) = delete;
  CsvWriter& operator=(const CsvWriter&) = delete;

  /// The header row: each key a text cell.
  CsvWriter& header(std::initializer_list<std::string_view> keys);
  CsvWriter& header(const std::vector<std::string>& keys);
  /// A text cell (see csv_text).
  CsvWriter& text(std::string_view value);
  /// A number in its shortest exact form (it reads back bit for bit); NaN and infinities as fmt
  /// writes them ("nan", "inf", "-inf").
  CsvWriter& number(double value);
  /// A float in its shortest exact form as a float (0.1f is "0.1").
  CsvWriter& number(float value);
  /// A number with `significant` digits, as printf's %.Ng writes it (the experiments' CSVs: %.6g).
  CsvWriter& number(double value, int significant);
  /// A number with `decimals` digits after the point, as printf's %.Nf writes it (`cariesim sim`).
  CsvWriter& fixed(double value, int decimals);
  /// An integer.
  CsvWriter& integer(std::int64_t value);
  /// An empty cell (a value that does not exist).
  CsvWriter& empty();
  /// Ends the row.
  void end_row();
  /// Writes what is buffered and closes the file; throws cariesim::Error "FILE: write failed".
  void close();

  [[nodiscard]] const std::filesystem::path& file() const { return file_; }

 private:
  void separate();
  void flush();

  std::filesystem::path file_;
  std::FILE* out_ = nullptr;
  std::string buffer_;
  bool row_started_ = false;
};

}  // namespace cariesim::io

#pragma once
/// The one JSON writer of cariesim (experiment summaries, `cariesim tree --json`, reports, session
/// parameters): it keeps escaping and number formatting (finite numbers only: NaN/inf become null) in
/// one place.

#include <string>
#include <string_view>

namespace cariesim::io {

class JsonWriter {
 public:
  JsonWriter& begin_object();
  JsonWriter& end_object();
  JsonWriter& begin_array();
  JsonWriter& end_array();
  /// Writes a key inside an object; the next value call gives its value.
  JsonWriter& key(std::string_view k);
  JsonWriter& value(double v);
  JsonWriter& value(long long v);
  JsonWriter& value(int v) { return value(static_cast<long long>(v)); }
  JsonWriter& value(std::size_t v) { return value(static_cast<long long>(v)); }
  JsonWriter& value(bool v);
  JsonWriter& value(std::string_view v);
  JsonWriter& value(const char* v) { return value(std::string_view(v)); }
  JsonWriter& null();
  /// key + value in one call.
  template <typename T>
  JsonWriter& field(std::string_view k, const T& v) {
    key(k);
    return value(v);
  }
  [[nodiscard]] const std::string& str() const { return out_; }

 private:
  void separate();
  void write_string(std::string_view v);
  std::string out_;
  bool need_comma_ = false;
  bool after_key_ = false;
};

}  // namespace cariesim::io

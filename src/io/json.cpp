#include "cariesim/io/json.hpp"

#include <boost/locale/utf.hpp>
#include <cmath>
#include <cstdio>

namespace cariesim::io {

void JsonWriter::separate() {
  if (after_key_) {
    after_key_ = false;
    return;
  }
  if (need_comma_) out_ += ',';
}

JsonWriter& JsonWriter::begin_object() {
  separate();
  out_ += '{';
  need_comma_ = false;
  return *this;
}

JsonWriter& JsonWriter::end_object() {
  out_ += '}';
  need_comma_ = true;
  return *this;
}

JsonWriter& JsonWriter::begin_array() {
  separate();
  out_ += '[';
  need_comma_ = false;
  return *this;
}

JsonWriter& JsonWriter::end_array() {
  out_ += ']';
  need_comma_ = true;
  return *this;
}

JsonWriter& JsonWriter::key(std::string_view k) {
  separate();
  write_string(k);
  out_ += ':';
  after_key_ = true;
  need_comma_ = false;
  return *this;
}

JsonWriter& JsonWriter::value(double v) {
  if (!std::isfinite(v)) return null();
  separate();
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  out_ += buf;
  need_comma_ = true;
  return *this;
}

JsonWriter& JsonWriter::value(long long v) {
  separate();
  out_ += std::to_string(v);
  need_comma_ = true;
  return *this;
}

JsonWriter& JsonWriter::value(bool v) {
  separate();
  out_ += v ? "true" : "false";
  need_comma_ = true;
  return *this;
}

JsonWriter& JsonWriter::value(std::string_view v) {
  separate();
  write_string(v);
  need_comma_ = true;
  return *this;
}

// A JSON string: '"', '\\' and every control character escaped, valid UTF-8 kept as it is, and each
// invalid sequence (a stray or truncated byte, an overlong form, a surrogate, past U+10FFFF) replaced
// by U+FFFD, so the output is always valid JSON (RFC 8259 §8.1) whatever a name or file held.
void JsonWriter::write_string(std::string_view v) {
  using Utf8 = boost::locale::utf::utf_traits<char>;
  out_ += '"';
  const char* p = v.data();
  const char* const end = v.data() + v.size();
  while (p < end) {
    const char c = *p;
    if (static_cast<unsigned char>(c) >= 0x80) {
      // Boost.Locale's decoder checks the whole sequence; on a failure one U+FFFD stands for the
      // lead byte and the continuation bytes it announced (a stray continuation byte is one alone).
      const char* q = p;
      const boost::locale::utf::code_point cp = Utf8::decode(q, end);
      if (cp != boost::locale::utf::illegal && cp != boost::locale::utf::incomplete) {
        out_.append(p, q);
        p = q;
      } else {
        out_ += "\xEF\xBF\xBD";
        const int announced = Utf8::trail_length(*p++);
        for (int i = 0; i < announced && p < end && Utf8::is_trail(*p); ++i) ++p;
      }
      continue;
    }
    ++p;
    switch (c) {
      case '"': out_ += "\\\""; break;
      case '\\': out_ += "\\\\"; break;
      case '\n': out_ += "\\n"; break;
      case '\t': out_ += "\\t"; break;
      case '\r': out_ += "\\r"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(static_cast<unsigned char>(c)));
          out_ += buf;
        } else {
          out_ += c;
        }
    }
  }
  out_ += '"';
}

JsonWriter& JsonWriter::null() {
  separate();
  out_ += "null";
  need_comma_ = true;
  return *this;
}

}  // namespace cariesim::io

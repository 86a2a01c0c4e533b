// What the fast paths of the text mesh readers share (obj_reader.h,
// off_reader.h, ply_reader.h): lines, words and numbers of the forms Python
// reads the same.
#pragma once

#include <charconv>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string_view>
#include <system_error>

namespace zbuffer::text {

inline bool is_blank(char c) { return c == ' ' || c == '\t'; }
inline bool is_digit(char c) { return c >= '0' && c <= '9'; }
// Printable ASCII, the space excluded.
inline bool is_graphic(char c) { return c > ' ' && c < '\x7f'; }

// Whether the text holds only printable ASCII, spaces, tabs and line ends
// (\n, \r): the bytes every fast path takes.
inline bool is_plain(std::string_view text) {
  for (char c : text)
    if (!(is_graphic(c) || is_blank(c) || c == '\n' || c == '\r')) return false;
  return true;
}

// The text without a UTF-8 byte order mark.
inline std::string_view without_bom(std::string_view text) {
  if (text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);
  return text;
}

// Calls line(view) for each line of the text (lines end at \n, \r\n or \r,
// as Python's universal newlines count them), until it returns false.
// Returns false if a call did.
template <class Line>
bool for_each_line(std::string_view text, Line&& line) {
  size_t at = 0;
  while (at < text.size()) {
    size_t end = at;
    while (end < text.size() && text[end] != '\n' && text[end] != '\r') ++end;
    const std::string_view view = text.substr(at, end - at);
    at = end + (end + 1 < text.size() && text[end] == '\r' && text[end + 1] == '\n' ? 2 : 1);
    if (!line(view)) return false;
  }
  return true;
}

// The words of a line, split at spaces and tabs.
class Words {
 public:
  explicit Words(std::string_view line) : rest_(line) {}
  // The next word, or an empty view at the end.
  std::string_view next() {
    size_t start = 0;
    while (start < rest_.size() && is_blank(rest_[start])) ++start;
    size_t end = start;
    while (end < rest_.size() && !is_blank(rest_[end])) ++end;
    const std::string_view word = rest_.substr(start, end - start);
    rest_.remove_prefix(end);
    return word;
  }

 private:
  std::string_view rest_;
};

inline size_t skip_digits(std::string_view s, size_t at) {
  while (at < s.size() && is_digit(s[at])) ++at;
  return at;
}

// A number of the grammar [+-]?(d+[.d*] | .d+)([eE][+-]?d+)?, as the
// correctly rounded double Python's float() also gives; false for anything
// else, and for results out of range or subnormal (Python: inf, or a
// subnormal or zero; left to it).
inline bool parse_number(std::string_view word, double& value) {
  size_t at = 0;
  if (at < word.size() && (word[at] == '+' || word[at] == '-')) ++at;
  const size_t mantissa = at;
  const size_t int_end = skip_digits(word, at);
  size_t digits = int_end - at;
  at = int_end;
  if (at < word.size() && word[at] == '.') {
    const size_t frac_end = skip_digits(word, at + 1);
    digits += frac_end - (at + 1);
    at = frac_end;
  }
  if (digits == 0) return false;
  if (at < word.size() && (word[at] == 'e' || word[at] == 'E')) {
    size_t exp = at + 1;
    if (exp < word.size() && (word[exp] == '+' || word[exp] == '-')) ++exp;
    const size_t exp_end = skip_digits(word, exp);
    if (exp_end == exp) return false;
    at = exp_end;
  }
  if (at != word.size()) return false;
  // from_chars takes no '+'; it reads the rest of this grammar as strtod does.
  const size_t from = word[0] == '+' ? mantissa : 0;
  const auto result = std::from_chars(word.data() + from, word.data() + word.size(), value);
  return result.ec == std::errc() && result.ptr == word.data() + word.size() &&
         std::isfinite(value) &&
         (value == 0.0 || std::abs(value) >= std::numeric_limits<double>::min());
}

// An integer [+-]?digits of magnitude at most `largest`, as Python's int()
// reads it; false for anything else, and for more than kMaxIntegerDigits
// digits (leading zeros count: Python's int() refuses over 4300 digits,
// or as few as 640 as sys.set_int_max_str_digits may set).
constexpr size_t kMaxIntegerDigits = 20;
inline bool parse_integer(std::string_view word, int64_t largest, int64_t& value) {
  size_t at = 0;
  const bool negative = !word.empty() && word[0] == '-';
  if (!word.empty() && (word[0] == '+' || word[0] == '-')) ++at;
  if (at == word.size() || skip_digits(word, at) != word.size()) return false;
  if (word.size() - at > kMaxIntegerDigits) return false;
  int64_t k = 0;
  for (size_t i = at; i < word.size(); ++i) {
    k = 10 * k + (word[i] - '0');
    if (k > largest) return false;
  }
  value = negative ? -k : k;
  return true;
}

}  // namespace zbuffer::text

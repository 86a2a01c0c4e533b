// The fast path of the OBJ reader (obj_reader.h).
#include "zbuffer/obj_reader.h"

#include <charconv>
#include <cmath>
#include <system_error>

namespace zbuffer {

namespace {

bool is_blank(char c) { return c == ' ' || c == '\t'; }
bool is_digit(char c) { return c >= '0' && c <= '9'; }
// Printable ASCII, the space excluded.
bool is_graphic(char c) { return c > ' ' && c < '\x7f'; }

// The words of one record, split at spaces and tabs.
class Words {
 public:
  explicit Words(std::string_view record) : rest_(record) {}
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

// Digits from `at`: where they end.
size_t skip_digits(std::string_view s, size_t at) {
  while (at < s.size() && is_digit(s[at])) ++at;
  return at;
}

// A number of the subset's grammar, [+-]?(d+[.d*] | .d+)([eE][+-]?d+)?,
// as the correctly rounded double Python's float() also gives; false for
// anything else, and for results out of range (Python: inf or a subnormal
// or zero, left to it).
bool parse_number(std::string_view word, double& value) {
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
         std::isfinite(value) && (value == 0.0 || std::abs(value) >= 2.2250738585072014e-308);
}

// A face corner's vertex, `[+-]?digits` up to the first '/' or the end, as
// a 0-based index (relative ones from `defined`, the vertices so far);
// false for anything else, for 0 and beyond 2^31.
bool parse_corner(std::string_view word, int64_t defined, int64_t& index) {
  size_t at = 0;
  const bool negative = at < word.size() && word[at] == '-';
  if (at < word.size() && (word[at] == '+' || word[at] == '-')) ++at;
  const size_t end = skip_digits(word, at);
  if (end == at || (end < word.size() && word[end] != '/')) return false;
  int64_t k = 0;
  for (size_t i = at; i < end; ++i) {
    k = 10 * k + (word[i] - '0');
    if (k > (int64_t(1) << 31)) return false;
  }
  if (k == 0) return false;
  index = negative ? defined - k : k - 1;
  return true;
}

// One `v` or `f` record (the line up to its comment); false outside the subset.
bool read_record(std::string_view record, ObjRecords& out, int64_t& colored) {
  for (char c : record)
    if (!(is_graphic(c) || is_blank(c)) || c == '_' || c == '\\') return false;
  Words words(record);
  const std::string_view tag = words.next();
  const int64_t defined = int64_t(out.positions.size() / 3);
  if (tag == "v") {
    double v[6];
    int n = 0;
    for (std::string_view w = words.next(); !w.empty(); w = words.next()) {
      if (n == 6 || !parse_number(w, v[n])) return false;
      ++n;
    }
    if (n != 3 && n != 4 && n != 6) return false;
    out.positions.insert(out.positions.end(), v, v + 3);
    if (n == 6) {
      for (int c = 3; c < 6; ++c)
        if (!(v[c] >= 0.0 && v[c] <= 255.0)) return false;
      // (kept only while every vertex so far has colours)
      if (colored == defined) out.colors.insert(out.colors.end(), v + 3, v + 6);
      ++colored;
    }
  } else if (tag == "f") {
    int64_t corners = 0;
    for (std::string_view w = words.next(); !w.empty(); w = words.next()) {
      int64_t index = 0;
      if (!parse_corner(w, defined, index)) return false;
      out.indices.push_back(index);
      ++corners;
    }
    if (corners < 3) return false;
    out.sizes.push_back(corners);
  }
  return true;  // (vt, vn, vp, fo, ...: skipped)
}

}  // namespace

bool read_obj_records(std::string_view text, ObjRecords& out) {
  out = ObjRecords();
  if (text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);
  int64_t colored = 0;  // v records with colours
  size_t at = 0;
  while (at < text.size()) {
    size_t end = at;
    while (end < text.size() && text[end] != '\n' && text[end] != '\r') ++end;
    std::string_view line = text.substr(at, end - at);
    at = end + (end + 1 < text.size() && text[end] == '\r' && text[end + 1] == '\n' ? 2 : 1);
    size_t first = 0;
    while (first < line.size() && is_blank(line[first])) ++first;
    if (first == line.size()) continue;
    if (!is_graphic(line[first])) return false;  // (Python's lstrip may strip it)
    if (line[first] != 'v' && line[first] != 'f') continue;
    line.remove_prefix(first);
    if (!read_record(line.substr(0, line.find('#')), out, colored)) return false;
  }
  const int64_t n = int64_t(out.positions.size() / 3);
  if (colored != n || n == 0) out.colors.clear();
  for (int64_t k : out.indices)
    if (k < 0 || k >= n) return false;
  return true;
}

}  // namespace zbuffer

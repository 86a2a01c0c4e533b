// The fast path of the OBJ reader (obj_reader.h).
#include "zbuffer/obj_reader.h"

#include <cmath>

#include "text_records.h"

namespace zbuffer {

namespace {

using text::is_blank;
using text::is_graphic;

// A face corner's vertex, `[+-]?digits` up to the first '/' or the end, as
// a 0-based index (relative ones from `defined`, the vertices so far);
// false for anything else, for 0 and beyond 2^31.
bool parse_corner(std::string_view word, int64_t defined, int64_t& index) {
  int64_t k = 0;
  if (!text::parse_integer(word.substr(0, word.find('/')), int64_t(1) << 31, k) || k == 0)
    return false;
  index = k < 0 ? defined + k : k - 1;
  return true;
}

// One `v` or `f` record (the line up to its comment); false outside the subset.
bool read_record(std::string_view record, ObjRecords& out, int64_t& colored) {
  // (A record holds no line end.)
  if (!text::is_plain(record) || record.find_first_of("_\\") != std::string_view::npos)
    return false;
  text::Words words(record);
  const std::string_view tag = words.next();
  const int64_t defined = int64_t(out.positions.size() / 3);
  if (tag == "v") {
    double v[6];
    int n = 0;
    for (std::string_view w = words.next(); !w.empty(); w = words.next()) {
      if (n == 6 || !text::parse_number(w, v[n])) return false;
      ++n;
    }
    if (n != 3 && n != 4 && n != 6) return false;
    out.positions.insert(out.positions.end(), v, v + 3);
    if (n == 6) {
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
  int64_t colored = 0;  // v records with colours
  const bool taken = text::for_each_line(text::without_bom(text), [&](std::string_view line) {
    size_t first = 0;
    while (first < line.size() && is_blank(line[first])) ++first;
    if (first == line.size()) return true;
    if (!is_graphic(line[first])) return false;  // (Python's lstrip may strip it)
    if (line[first] != 'v' && line[first] != 'f') return true;
    line.remove_prefix(first);
    return read_record(line.substr(0, line.find('#')), out, colored);
  });
  if (!taken) return false;
  const int64_t n = int64_t(out.positions.size() / 3);
  if (colored != n || n == 0) out.colors.clear();
  // Colours (read only when every vertex has one): fractions in [0, 1], or
  // bytes 0-255 when every value is a whole number (obj.py); the others
  // are left to the Python reader's message.
  bool whole = true, above_one = false;
  for (double c : out.colors) {
    if (!(c >= 0.0 && c <= 255.0)) return false;
    whole &= c == std::floor(c);
    above_one |= c > 1.0;
  }
  if (above_one && !whole) return false;
  for (int64_t k : out.indices)
    if (k < 0 || k >= n) return false;
  return true;
}

}  // namespace zbuffer

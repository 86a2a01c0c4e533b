// The fast path of the ASCII OFF reader (off_reader.h).
#include "zbuffer/off_reader.h"

#include <array>

#include "text_records.h"

namespace zbuffer {

namespace {

// The words of a line up to its comment, at most kMax of them, or false
// for a line outside the subset (a `_`, more than kMax words).
constexpr int kMax = 16;
struct LineWords {
  std::array<std::string_view, kMax> word;
  int n = 0;
};
bool split(std::string_view line, LineWords& out) {
  line = line.substr(0, line.find('#'));
  if (line.find('_') != std::string_view::npos) return false;
  text::Words words(line);
  out.n = 0;
  for (std::string_view w = words.next(); !w.empty(); w = words.next()) {
    if (out.n == kMax) return false;
    out.word[size_t(out.n++)] = w;
  }
  return true;
}

bool has_point_or_exponent(std::string_view w) {
  return w.find_first_of(".eE") != std::string_view::npos;
}

// A colour of 3 or 4 numbers: its first three into `rgb`, `floats` set if
// one is written with a point or an exponent.
bool read_colour(const std::string_view* w, int n, std::vector<double>& rgb, bool& floats) {
  double v[4];
  for (int k = 0; k < n; ++k) {
    if (!text::parse_number(w[k], v[k])) return false;
    floats = floats || has_point_or_exponent(w[k]);
  }
  rgb.insert(rgb.end(), v, v + 3);
  return true;
}

class Reader {
 public:
  // `bytes`: the text's size, a bound on its records.
  Reader(OffRecords& out, size_t bytes) : out_(out), bytes_(bytes) {}

  bool line(std::string_view line) {
    LineWords w;
    if (!split(line, w)) return false;
    if (w.n == 0) return true;
    switch (stage_) {
      case kHeader: return header(w);
      case kCounts: return counts(w.word.data(), w.n);
      case kVertices: return vertex(w);
      case kFaces: return face(w);
      case kDone: return false;  // more records than the counts say
    }
    return false;
  }

  bool finish() {
    if (stage_ != kDone) return false;
    if (out_.face_colors.size() != 3 * out_.sizes.size()) out_.face_colors.clear();
    return true;
  }

 private:
  enum Stage { kHeader, kCounts, kVertices, kFaces, kDone };

  bool header(const LineWords& w) {
    const std::string_view h = w.word[0];
    normals_ = h == "NOFF" || h == "CNOFF";
    colours_ = h == "COFF" || h == "CNOFF";
    if (!normals_ && !colours_ && h != "OFF") return false;
    stage_ = kCounts;
    return w.n == 1 || counts(w.word.data() + 1, w.n - 1);
  }

  bool counts(const std::string_view* w, int n) {
    if (n != 3) return false;
    int64_t c[3];
    for (int k = 0; k < 3; ++k)
      if (w[k][0] == '+' || w[k][0] == '-' || !text::parse_integer(w[k], int64_t(1) << 40, c[k]))
        return false;
    if (c[0] + c[1] > int64_t(bytes_)) return false;  // (not that many lines)
    n_vertices_ = c[0];
    n_faces_ = c[1];
    out_.positions.reserve(size_t(3 * n_vertices_));
    out_.sizes.reserve(size_t(n_faces_));
    next_stage();
    return true;
  }

  void next_stage() {
    if (stage_ == kCounts) stage_ = kVertices;
    if (stage_ == kVertices && int64_t(out_.positions.size()) == 3 * n_vertices_) stage_ = kFaces;
    if (stage_ == kFaces && int64_t(out_.sizes.size()) == n_faces_) stage_ = kDone;
  }

  bool vertex(const LineWords& w) {
    const int width = normals_ ? 6 : 3, extra = w.n - width;
    if (extra < 0 || (!colours_ && extra) || (colours_ && extra != 3 && extra != 4)) return false;
    double p[3];
    for (int k = 0; k < 3; ++k)
      if (!text::parse_number(w.word[size_t(k)], p[k])) return false;
    out_.positions.insert(out_.positions.end(), p, p + 3);
    if (colours_ && !read_colour(w.word.data() + width, extra, out_.vertex_colors, out_.vertex_floats))
      return false;
    next_stage();
    return true;
  }

  bool face(const LineWords& w) {
    int64_t n = 0;
    if (!text::parse_integer(w.word[0], kMax, n) || n < 3 || w.n < 1 + n) return false;
    for (int k = 1; k <= n; ++k) {
      int64_t index = 0;
      if (!text::parse_integer(w.word[size_t(k)], int64_t(1) << 40, index) || index < 0 ||
          index >= n_vertices_)
        return false;
      out_.indices.push_back(index);
    }
    out_.sizes.push_back(n);
    const int extra = w.n - 1 - int(n);
    if (extra == 1) {  // a colour-map index: no face colours
      double unused;
      if (!text::parse_number(w.word[size_t(1 + n)], unused)) return false;
      face_colours_ = false;
    } else if (extra == 3 || extra == 4) {
      if (!read_colour(w.word.data() + 1 + n, extra, out_.face_colors, out_.face_floats))
        return false;
    } else if (extra == 0) {
      face_colours_ = false;
    } else {
      return false;
    }
    if (!face_colours_) out_.face_colors.clear();  // (not every face has a colour)
    next_stage();
    return true;
  }

  OffRecords& out_;
  size_t bytes_;
  Stage stage_ = kHeader;
  bool normals_ = false, colours_ = false, face_colours_ = true;
  int64_t n_vertices_ = 0, n_faces_ = 0;
};

}  // namespace

bool read_off_records(std::string_view text, OffRecords& out) {
  out = OffRecords();
  text = text::without_bom(text);
  for (char c : text)
    if (!(text::is_graphic(c) || text::is_blank(c) || c == '\n' || c == '\r')) return false;
  Reader reader(out, text.size());
  return text::for_each_line(text, [&](std::string_view line) { return reader.line(line); }) &&
         reader.finish();
}

}  // namespace zbuffer

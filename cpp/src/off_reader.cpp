// The fast path of the ASCII OFF reader (off_reader.h).
#include "zbuffer/off_reader.h"

#include "text_records.h"

namespace zbuffer {

namespace {

// Up to `most` of the words left into `out`: how many, or most + 1 if more
// are left.
int take(text::Words& words, std::string_view* out, int most) {
  int n = 0;
  for (std::string_view w = words.next(); !w.empty(); w = words.next()) {
    if (n == most) return most + 1;
    out[n++] = w;
  }
  return n;
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

// The shortest records a file of so many vertices and faces can hold, in
// bytes with their line ends: "0 0 0" and "3 0 0 0".
constexpr int64_t kLeastVertexBytes = 6, kLeastFaceBytes = 8;

class Reader {
 public:
  // `bytes`: the text's size, which bounds the counts a file can hold.
  Reader(OffRecords& out, size_t bytes) : out_(out), bytes_(int64_t(bytes)) {}

  // One line; false outside the subset.
  bool line(std::string_view line) {
    line = line.substr(0, line.find('#'));
    if (line.find('_') != std::string_view::npos) return false;
    text::Words words(line);
    const std::string_view first = words.next();
    if (first.empty()) return true;  // (blank)
    switch (stage_) {
      case kHeader: return header(first, words);
      case kCounts: return counts(first, words);
      case kVertices: return vertex(first, words);
      case kFaces: return face(first, words);
      case kDone: return false;  // more records than the counts say
    }
    return false;
  }

  bool finish() {
    if (stage_ != kDone) return false;
    // (Some face had no colour: the faces have none.)
    if (out_.face_colors.size() != 3 * out_.sizes.size()) out_.face_colors.clear();
    return true;
  }

 private:
  enum Stage { kHeader, kCounts, kVertices, kFaces, kDone };

  bool header(std::string_view h, text::Words& words) {
    // The header, or the header run into the vertex count ("OFF9278", as
    // many files of the ModelNet datasets begin).
    std::string_view first;
    for (std::string_view name : {"CNOFF", "NOFF", "COFF", "OFF"})
      if (h.substr(0, name.size()) == name &&
          (h.size() == name.size() || text::is_digit(h[name.size()]))) {
        first = h.substr(name.size());
        h = name;
        break;
      }
    normals_ = h == "NOFF" || h == "CNOFF";
    colours_ = h == "COFF" || h == "CNOFF";
    if (!normals_ && !colours_ && h != "OFF") return false;
    stage_ = kCounts;
    if (first.empty()) first = words.next();
    return first.empty() || counts(first, words);
  }

  bool counts(std::string_view first, text::Words& words) {
    std::string_view w[3] = {first};
    if (take(words, w + 1, 2) != 2) return false;
    int64_t c[3];
    for (int k = 0; k < 3; ++k)
      if (w[k][0] == '+' || w[k][0] == '-' || !text::parse_integer(w[k], bytes_, c[k]))
        return false;
    if (kLeastVertexBytes * c[0] + kLeastFaceBytes * c[1] > bytes_ + 1) return false;
    n_vertices_ = c[0];
    n_faces_ = c[1];
    out_.positions.reserve(size_t(3 * n_vertices_));
    out_.sizes.reserve(size_t(n_faces_));
    out_.indices.reserve(size_t(3 * n_faces_));
    next_stage();
    return true;
  }

  void next_stage() {
    if (stage_ == kCounts) stage_ = kVertices;
    if (stage_ == kVertices && int64_t(out_.positions.size()) == 3 * n_vertices_) stage_ = kFaces;
    if (stage_ == kFaces && int64_t(out_.sizes.size()) == n_faces_) stage_ = kDone;
  }

  bool vertex(std::string_view first, text::Words& words) {
    // x y z, a normal's 3 words, a colour's 3 or 4 numbers
    std::string_view w[10] = {first};
    const int n = 1 + take(words, w + 1, 9);
    const int width = normals_ ? 6 : 3, extra = n - width;
    if (extra < 0 || (!colours_ && extra) || (colours_ && extra != 3 && extra != 4)) return false;
    double p[3];
    for (int k = 0; k < 3; ++k)
      if (!text::parse_number(w[k], p[k])) return false;
    out_.positions.insert(out_.positions.end(), p, p + 3);
    if (colours_ && !read_colour(w + width, extra, out_.vertex_colors, out_.vertex_floats))
      return false;
    next_stage();
    return true;
  }

  bool face(std::string_view first, text::Words& words) {
    int64_t n = 0;
    if (!text::parse_integer(first, bytes_, n) || n < 3) return false;
    for (int64_t k = 0; k < n; ++k) {
      int64_t index = 0;
      if (!text::parse_integer(words.next(), bytes_, index) || index < 0 || index >= n_vertices_)
        return false;
      out_.indices.push_back(index);
    }
    out_.sizes.push_back(n);
    // Nothing, a colour-map index, or a colour (finish() keeps the faces'
    // colours only if every face has one).
    std::string_view colour[4];
    const int extra = take(words, colour, 4);
    bool read = extra == 0;
    if (extra == 1) {
      double unused;
      read = text::parse_number(colour[0], unused);
    } else if (extra == 3 || extra == 4) {
      read = read_colour(colour, extra, out_.face_colors, out_.face_floats);
    }
    if (!read) return false;
    next_stage();
    return true;
  }

  OffRecords& out_;
  int64_t bytes_;
  Stage stage_ = kHeader;
  bool normals_ = false, colours_ = false;
  int64_t n_vertices_ = 0, n_faces_ = 0;
};

}  // namespace

bool read_off_records(std::string_view text, OffRecords& out) {
  out = OffRecords();
  text = text::without_bom(text);
  if (!text::is_plain(text)) return false;
  Reader reader(out, text.size());
  return text::for_each_line(text, [&](std::string_view line) { return reader.line(line); }) &&
         reader.finish();
}

}  // namespace zbuffer

// ASCII OFF files, read fast: the files of the forms tools write, parsed
// in one pass over the bytes.
#pragma once

#include <cstdint>
#include <string_view>
#include <vector>

namespace zbuffer {

// What an ASCII OFF file holds (python/zbuffer/off.py reads the same).
struct OffRecords {
  std::vector<double> positions;      // x y z of each vertex
  std::vector<int64_t> sizes;         // corners of each face
  std::vector<int64_t> indices;       // their vertex indices, concatenated
  // Colours as written, the first three numbers of each record, when every
  // vertex (a COFF or CNOFF file) or every face has 3 or 4 numbers of one;
  // `*_floats`: whether any of those numbers is written with a point or an
  // exponent (then they are 0-1, else 0-255: polygons.file_rgb).
  std::vector<double> vertex_colors, face_colors;
  bool vertex_floats = false, face_floats = false;
};

// The fast path of python/zbuffer/off.py's reader, as read_obj_records is
// the OBJ reader's (obj_reader.h: a fast path, not a second reader): false
// for anything outside the subset below, errors included, and that reader
// reads the file. Armadillo_86k as a 2.9 MB OFF file parsed in 7.5 ms
// against 458 ms in Python (benchmarks/results/load.md).
//
// The subset: only printable ASCII, spaces, tabs and line ends (\n, \r\n, \r)
// after an optional UTF-8 byte order mark, no `_` before a line's `#` (which
// starts a comment). Blank lines are skipped; the first line is the header
// OFF, COFF, NOFF or CNOFF, optionally followed by the counts (vertices,
// faces, edges: three digit strings; the first may be run into the header,
// "OFF9278 6940 0", as in many ModelNet files), else the next line
// holds them; then exactly that many vertex and face lines. A vertex: x y z
// (numbers of text_records.h's parse_number), with NOFF/CNOFF three words of
// a normal (not read), with COFF/CNOFF 3 or 4 numbers of a colour. A face:
// its corner count n >= 3, n indices in [0, vertices) ([+-]?digits), then
// nothing, a colour-map index, or 3 or 4 colour numbers.
bool read_off_records(std::string_view text, OffRecords& out);

}  // namespace zbuffer

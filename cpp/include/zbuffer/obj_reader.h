// Wavefront OBJ files, read fast: the v and f records of the files almost
// every tool writes, parsed in one pass over the bytes.
#pragma once

#include <cstdint>
#include <string_view>
#include <vector>

namespace zbuffer {

// What an OBJ file's v and f records hold (python/zbuffer/obj.py reads the
// same: polygons as written, 0-based indices, relative ones resolved).
struct ObjRecords {
  std::vector<double> positions;  // x y z of each v record
  std::vector<double> colors;     // r g b of each v record, when every one has them
  std::vector<int64_t> sizes;     // corners of each f record
  std::vector<int64_t> indices;   // their vertex indices, concatenated
};

// Design decision: a fast path, not a second reader. `read_obj_records`
// takes the common subset of the format and returns false on anything
// else -- or on anything wrong -- leaving the file to the Python reader
// (python/zbuffer/obj.py), which reads every file it reads and names the
// line of any error. So the two never disagree on a file this one takes
// (tests compare them on generated files), and there is one set of error
// messages. Good: armadillo_86k's 4 MB parsed in 9.4 ms against 144 ms in
// Python (benchmarks/results/load.md), and, measured once by hand, a 158 MB
// file of a million quads in 0.64 s with a peak of 0.5 GB (the file's bytes
// and the arrays) against 9 s and 2.2 GB. Bad: files
// outside the subset (a line continued by a backslash, a record with a
// character other than printable ASCII, spaces and tabs, a number Python
// reads but this grammar does not: inf, nan) still take the slow path.
//
// The subset, line by line (lines end at \n, \r\n or \r; a UTF-8 byte
// order mark is skipped): a line whose first byte after spaces and tabs is
// neither `v` nor `f` is skipped, as long as that byte is printable ASCII
// (or the line is blank). A `v`/`f` line up to its first `#` holds only
// printable ASCII but `_` and `\`, spaces and tabs; its first word is `v`
// or `f` (otherwise -- vt, vn, fo -- it is skipped). `v x y z`, `v x y z
// w` or `v x y z r g b`, each number [+-]?(digits[.digits?] | .digits)
// ([eE][+-]?digits)? whose double is finite and not subnormal (nor a
// nonzero number rounded to zero: text_records.h, parse_number); colours
// kept when every v record has them, and then each in [0, 1], or each a
// whole number in [0, 255] (bytes). `f` with
// at least 3 corners, each an integer [+-]?digits (at most 20 digits,
// |k| <= 2^31, not 0; negative: relative to the vertices defined so far)
// optionally followed by `/` and anything; every index resolved into
// [0, vertices in the file). Returns false, with `out` in an unspecified
// state, outside the subset.
bool read_obj_records(std::string_view text, ObjRecords& out);

}  // namespace zbuffer

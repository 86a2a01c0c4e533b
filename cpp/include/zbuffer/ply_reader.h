// The records of ASCII PLY files, read fast: the number tables of the
// files whose every element's records are as long as its first.
#pragma once

#include <cstdint>
#include <string_view>
#include <vector>

namespace zbuffer {

// A fast path of python/zbuffer/ply.py's ASCII reading, as
// read_obj_records is the OBJ reader's (obj_reader.h: a fast path, not a
// second reader). The Python reader parses the header; this reads the body
// after it, `counts[e]` records for element e, into tables[e]: row-major,
// `columns[e]` numbers a record (0 where counts[e] is 0) -- what the
// Python reader's `np.array([line.split() ...], float64)` makes of them,
// from which it then takes the properties. Returns false, and the Python
// reader reads the file, for anything else: a byte other than printable
// ASCII, spaces, tabs and line ends (\n, \r\n, \r); a record of another
// length than its element's first; a word that is not a number of
// text_records.h's parse_number; fewer records than the counts, or
// anything but blank lines after them. Blank lines (spaces and tabs) are
// skipped, as the Python reader skips them. Armadillo_86k as a 3.2 MB
// ASCII PLY file: read_ply 9.4 ms, 122 ms without this
// (benchmarks/results/load.md).
bool read_ascii_ply_tables(std::string_view body, const std::vector<int64_t>& counts,
                           std::vector<std::vector<double>>& tables,
                           std::vector<int64_t>& columns);

}  // namespace zbuffer

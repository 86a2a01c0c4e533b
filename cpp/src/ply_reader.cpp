// The fast path of the ASCII PLY reader (ply_reader.h).
#include "zbuffer/ply_reader.h"

#include "text_records.h"

namespace zbuffer {

bool read_ascii_ply_tables(std::string_view body, const std::vector<int64_t>& counts,
                           std::vector<std::vector<double>>& tables,
                           std::vector<int64_t>& columns) {
  tables.assign(counts.size(), {});
  columns.assign(counts.size(), 0);
  if (!text::is_plain(body)) return false;
  size_t element = 0;
  int64_t records = 0;  // of the current element
  auto next_element = [&] {
    while (element < counts.size() && records == counts[element]) {
      ++element;
      records = 0;
    }
  };
  next_element();
  const bool read = text::for_each_line(body, [&](std::string_view line) {
    text::Words words(line);
    std::string_view w = words.next();
    if (w.empty()) return true;                  // (blank)
    if (element == counts.size()) return false;  // more records than the counts
    std::vector<double>& table = tables[element];
    int64_t n = 0;
    for (; !w.empty(); w = words.next(), ++n) {
      double value;
      if (!text::parse_number(w, value)) return false;
      table.push_back(value);
    }
    if (records == 0)
      columns[element] = n;
    else if (n != columns[element])
      return false;
    ++records;
    next_element();
    return true;
  });
  return read && element == counts.size();
}

}  // namespace zbuffer

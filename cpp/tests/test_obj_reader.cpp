// The OBJ reader's fast path: the records of the common forms, and false
// for anything outside them (the Python reader's to read; the Python tests
// hold the two readers to the same data on generated files).
#include <string>
#include <vector>

#include "check.h"
#include "zbuffer/obj_reader.h"

using namespace zbuffer;

namespace {

bool takes(const std::string& text) {
  ObjRecords r;
  return read_obj_records(text, r);
}

void test_common_forms() {
  ObjRecords r;
  const std::string text =
      "\xEF\xBB\xBF# exported\r\no a\r\nv 0 0 0\r\nv 1.5 -2e-3 +3\r\n\tv .5 5. 1E+2 1\r\n"
      "vt 0 1\nvn 0 0 1\rv 1 1 1 # note\ng b\nf 1/1/1 2//1 3\nf -4 -3 -2 -1\n  f 1 2 4 # x";
  CHECK(read_obj_records(text, r));
  const std::vector<double> positions = {0, 0, 0, 1.5, -2e-3, 3, 0.5, 5, 100, 1, 1, 1};
  CHECK(r.positions == positions);
  CHECK(r.colors.empty());
  CHECK((r.sizes == std::vector<int64_t>{3, 4, 3}));
  CHECK((r.indices == std::vector<int64_t>{0, 1, 2, 0, 1, 2, 3, 0, 1, 3}));
  // Colours only when every vertex has them.
  CHECK(read_obj_records("v 0 0 0 255 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 51\nf 1 2 3\n", r));
  CHECK((r.colors == std::vector<double>{255, 0, 0, 0, 1, 0, 0, 0, 51}));
  CHECK(read_obj_records("v 0 0 0 255 0 0\nv 1 0 0\nv 0 1 0 0 0 51\nf 1 2 3\n", r));
  CHECK(r.colors.empty() && r.positions.size() == 9);
  CHECK(read_obj_records("", r) && r.positions.empty() && r.sizes.empty());
}

void test_anything_else_is_refused() {
  const char* head = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  for (const char* line :
       {"v 1 2 3 \\\n4", "v inf 0 0", "v nan 0 0", "v 1e400 0 0", "v 1e-400 0 0", "v 1_0 0 0",
        "v 0x10 0 0", "v +-1 0 0", "v 1e 0 0", "v . 0 0", "\x0cv 1 2 3", "\xC2\xA0v 1 2 3",
        "v 1\x0b" "2 3", "v 1 2", "v 1 2 3 4 5", "v 1 2 3 4 5 6 7", "f 1 2", "f 1 0 2",
        "f 1 2 4", "f 1 -4 2", "f 1 a 2", "f 1 2x 3", "f 1 2 2147483649", "v 1 2 3 300 0 0",
        "v 1 2 3 -1 0 0", "vt 0_5 1", "f 1 2 3 \xC3\xA9"}) {
    const bool taken = takes(std::string(head) + line + "\nf 1 2 3\n");
    if (taken) std::fprintf(stderr, "taken: %s\n", line);
    CHECK(!taken);
  }
  // Comments hold anything.
  CHECK(takes(std::string(head) + "f 1 2 3 # \xC3\xA9 \\ _\n# \x01\n"));
}

}  // namespace

int main() {
  test_common_forms();
  test_anything_else_is_refused();
  return check_report("test_obj_reader");
}

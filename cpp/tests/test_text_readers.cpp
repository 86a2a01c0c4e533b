// The fast paths of the OBJ, OFF and ASCII PLY readers: the records of the
// common forms, and false for anything outside them (the Python readers'
// to read; the Python tests hold each pair of readers to the same data on
// generated files).
#include <string>
#include <vector>

#include "check.h"
#include "zbuffer/obj_reader.h"
#include "zbuffer/off_reader.h"
#include "zbuffer/ply_reader.h"

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
  // Colours out of range: refused when every vertex has one, ignored else.
  CHECK(!read_obj_records("v 0 0 0 300 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 -1\nf 1 2 3\n", r));
  CHECK(read_obj_records("v 0 0 0 300 0 0\nv 1 0 0\nv 0 1 0 0 0 -1\nf 1 2 3\n", r));
  CHECK(r.colors.empty());
  CHECK(read_obj_records("", r) && r.positions.empty() && r.sizes.empty());
}

void test_anything_else_is_refused() {
  const char* head = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  for (const char* line :
       {"v 1 2 3 \\\n4", "v inf 0 0", "v nan 0 0", "v 1e400 0 0", "v 1e-400 0 0", "v 1_0 0 0",
        "v 0x10 0 0", "v +-1 0 0", "v 1e 0 0", "v . 0 0", "\x0cv 1 2 3", "\xC2\xA0v 1 2 3",
        "v 1\x0b" "2 3", "v 1 2", "v 1 2 3 4 5", "v 1 2 3 4 5 6 7", "f 1 2", "f 1 0 2",
        "f 1 2 4", "f 1 -4 2", "f 1 a 2", "f 1 2x 3", "f 1 2 2147483649", "vt 0_5 1", "f 1 2 3 \xC3\xA9", "f 0000000000000000000001 2 3"}) {
    const bool taken = takes(std::string(head) + line + "\nf 1 2 3\n");
    if (taken) std::fprintf(stderr, "taken: %s\n", line);
    CHECK(!taken);
  }
  // Comments hold anything.
  CHECK(takes(std::string(head) + "f 1 2 3 # \xC3\xA9 \\ _\n# \x01\n"));
}

void test_off_files() {
  OffRecords r;
  CHECK(read_off_records("\xEF\xBB\xBF# a square\r\nOFF\r\n4 2 0\r\n0 0 0\r\n1 0 0\r\n"
                         "1 1 0 # corner\r\n0 1 0\r\n\r\n3 0 1 2 1 0 0\r\n3 0 2 3 0 0.5 1 1\r\n",
                         r));
  CHECK((r.positions == std::vector<double>{0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}));
  CHECK((r.sizes == std::vector<int64_t>{3, 3}));
  CHECK((r.indices == std::vector<int64_t>{0, 1, 2, 0, 2, 3}));
  CHECK((r.face_colors == std::vector<double>{1, 0, 0, 0, 0.5, 1}) && r.face_floats);
  CHECK(r.vertex_colors.empty());
  // Counts on the header's line, colours per vertex, normals skipped; a
  // face without a colour drops the faces' colours.
  CHECK(read_off_records("CNOFF 3 2 0\n0 0 0 0 0 1 255 0 0\n1 0 0 x y z 0 255 0 255\n"
                         "0 1 0 0 0 1 0 0 255\n3 0 1 2 9 9 9\n3 2 1 0\n",
                         r));
  CHECK((r.vertex_colors == std::vector<double>{255, 0, 0, 0, 255, 0, 0, 0, 255}));
  CHECK(!r.vertex_floats && r.face_colors.empty());
  // Counts run into the header (many ModelNet files).
  CHECK(read_off_records("COFF3 1 0\n0 0 0 1 0 0\n1 0 0 0 1 0\n0 1 0 0 0 1\n3 0 1 2\n", r) &&
        r.positions.size() == 9 && r.vertex_colors.size() == 9 && r.sizes.size() == 1);
  CHECK(!read_off_records("OFFx3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", r));
  CHECK(!read_off_records("OFF+3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", r));
  // Polygons of any size.
  std::string polygon = "OFF 20 1 0\n";
  for (int k = 0; k < 20; ++k) polygon += std::to_string(k) + " 0 0\n";
  polygon += "20";
  for (int k = 0; k < 20; ++k) polygon += " " + std::to_string(k);
  CHECK(read_off_records(polygon + " 1 0 0\n", r) && r.sizes == std::vector<int64_t>{20});
  CHECK(r.indices.size() == 20 && r.indices[19] == 19 && r.face_colors.size() == 3);
  for (const char* text :
       {"", "OFF\n", "OFF\n1 0 0\n", "OFF\n1 0 0\n0 0 0\n0 0 0\n", "OFF\n1 0\n0 0 0\n",
        "OFF -1 0 0\n", "OFF 1 0 0\n0 0\n", "OFF 1 0 0\n0 0 inf\n", "OFF 3 1 0\n0 0 0\n0 0 0\n"
        "0 0 0\n3 0 1 3\n", "OFF 3 1 0\n0 0 0\n0 0 0\n0 0 0\n2 0 1\n",
        "OFF 1 0 0\n0 0 0 # \xC3\xA9\n", "OFF 1 0 0\n0_0 0 0\n", "OFF BINARY\n",
        "OFF 1 0 0\n0\x0c" "0 0\n", "4OFF 1 0 0\n0 0 0\n", "OFF 99999999999999 0 0\n",
        "OFF 3 0 0\n0 0 0\n0 0 0\n", "OFF 1 1 2 3\n0 0 0\n"}) {
    const bool taken = read_off_records(text, r);
    if (taken) std::fprintf(stderr, "taken: %s\n", text);
    CHECK(!taken);
  }
}

void test_ascii_ply_tables() {
  std::vector<std::vector<double>> tables;
  std::vector<int64_t> columns;
  const std::vector<int64_t> counts = {3, 0, 2};
  CHECK(read_ascii_ply_tables("0 0 0 1\r\n1 0 0 2\r\n\r\n0 1.5 0 3\r\n3 0 1 2\n  \n3\t0 2 1\n\n",
                              counts, tables, columns));
  CHECK((columns == std::vector<int64_t>{4, 0, 4}));
  CHECK((tables[0] == std::vector<double>{0, 0, 0, 1, 1, 0, 0, 2, 0, 1.5, 0, 3}));
  CHECK(tables[1].empty() && (tables[2] == std::vector<double>{3, 0, 1, 2, 3, 0, 2, 1}));
  for (const char* body :
       {"0 0 0 1\n1 0 0 2\n0 1 0 3\n3 0 1 2\n", "0 0 0 1\n1 0 0 2\n0 1 0 3\n3 0 1 2\n"
        "3 0 2 1\n3 0 2 1\n", "0 0 0 1\n1 0 0\n0 1 0 3\n3 0 1 2\n3 0 2 1\n",
        "0 0 0 1\n1 0 0 2\n0 1 0 inf\n3 0 1 2\n3 0 2 1\n",
        "0 0 0 1\n1 0 0 2\n0 1 0 3\n3 0 1 2\n3 0 2 1 \xC3\xA9\n",
        "0 0 0 1\n1 0\x0c" "0 2\n0 1 0 3\n3 0 1 2\n3 0 2 1\n"}) {
    const bool taken = read_ascii_ply_tables(body, counts, tables, columns);
    if (taken) std::fprintf(stderr, "taken: %s\n", body);
    CHECK(!taken);
  }
}

}  // namespace

int main() {
  test_common_forms();
  test_anything_else_is_refused();
  test_off_files();
  test_ascii_ply_tables();
  return check_report("test_text_readers");
}

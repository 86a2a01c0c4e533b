// A minimal check macro for the C++ tests: report and count failures, keep
// going, and make main() return non-zero if anything failed.
#pragma once

#include <cstdio>

inline int& check_failures() {
  static int failures = 0;
  return failures;
}

#define CHECK(cond)                                                       \
  do {                                                                    \
    if (!(cond)) {                                                        \
      std::fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond); \
      ++check_failures();                                                 \
    }                                                                     \
  } while (0)

inline int check_report(const char* name) {
  if (check_failures() == 0) std::printf("%s: all checks passed\n", name);
  return check_failures() == 0 ? 0 : 1;
}

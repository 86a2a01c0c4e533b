// A minimal check macro for the C++ tests: report and count failures, keep
// going, and make main() return non-zero if anything failed.
#pragma once

#include <cstdio>

inline int& check_failures() {
  static int failures = 0;
  return failures;
}

// A small deterministic generator: the tests need no <random> distributions
// whose output differs between standard libraries.
struct Lcg {
  unsigned long long state;
  unsigned long long bits() {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return state;
  }
  // An integer in [lo, hi].
  long long operator()(long long lo, long long hi) {
    return lo + (long long)((bits() >> 33) % (unsigned long long)(hi - lo + 1));
  }
  // A double in [lo, hi).
  double uniform(double lo, double hi) {
    return lo + (hi - lo) * double(bits() >> 11) / double(1ull << 53);
  }
};

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

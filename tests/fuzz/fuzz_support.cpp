#include <cstdio>
#include <cstdlib>

#include "tests/fuzz/fuzz_input.hpp"

namespace hvac_twin::fuzz {

void invariant_failed(const char* what) {
  std::fprintf(stderr, "fuzz invariant broken: %s\n", what);
  std::abort();
}

}  // namespace hvac_twin::fuzz

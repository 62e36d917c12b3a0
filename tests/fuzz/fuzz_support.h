#pragma once
// Shared by the fuzz harnesses (tests/fuzz/README.md): the check that stops a run on a broken
// property (abort, which libFuzzer reports as a crash with the input saved) and splitting an
// input into parts.
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>
#include <vector>

namespace stickslip::fuzz {

/// Stops the run when a property does not hold (the fuzzer saves the input as a crash).
#define FUZZ_CHECK(cond, what)                                                         \
  do {                                                                                 \
    if (!(cond)) {                                                                     \
      std::fprintf(stderr, "fuzz property failed: %s (%s:%d): %s\n", #cond, __FILE__, \
                   __LINE__, std::string(what).c_str());                              \
      std::abort();                                                                    \
    }                                                                                  \
  } while (0)

/// The parts of an input separated by NUL bytes (at most max_parts; the last takes the rest).
inline std::vector<std::string_view> split_parts(std::string_view data, std::size_t max_parts) {
  std::vector<std::string_view> parts;
  while (parts.size() + 1 < max_parts) {
    const auto nul = data.find('\0');
    if (nul == std::string_view::npos) break;
    parts.push_back(data.substr(0, nul));
    data.remove_prefix(nul + 1);
  }
  parts.push_back(data);
  return parts;
}

}  // namespace stickslip::fuzz

// Fuzz target: the study spec parser (studies::parse_study), the body of POST /v1/studies and the
// file of `stickslip study run`. The input is the JSON text.
// Properties: parse_study never throws; a rejected spec names at least one error, each with a
// JSON Pointer ("" or starting with '/'); an accepted spec has between 1 and Limits::max_runs
// runs, and its canonical JSON parses again to the same canonical spec with the same runs.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "fuzz_support.h"
#include "stickslip/studies/spec.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace stickslip;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  studies::Limits limits;
  limits.max_runs = 5000;  // the harness's bound on one spec's expansion (memory, time)
  const studies::ParseResult r = studies::parse_study(text, limits);
  if (!r.ok()) {
    FUZZ_CHECK(!r.errors.empty(), "rejected without an error");
    for (const auto& e : r.errors)
      FUZZ_CHECK(e.pointer.empty() || e.pointer.front() == '/', e.pointer);
    return 0;
  }
  const studies::StudySpec& spec = *r.spec;
  FUZZ_CHECK(spec.run_count() >= 1 && spec.run_count() <= limits.max_runs,
             std::to_string(spec.run_count()));
  const std::string canonical = spec.canonical_json();
  const studies::ParseResult again = studies::parse_study(canonical, limits);
  FUZZ_CHECK(again.ok(), canonical.substr(0, 300) + ": " + common::to_string(again.errors));
  FUZZ_CHECK(again.spec->canonical_json() == canonical, canonical.substr(0, 300));
  FUZZ_CHECK(again.spec->run_count() == spec.run_count(), canonical.substr(0, 300));
  // The first and last design points and their configurations (what the runner does; an invalid
  // point throws engine::InvalidParameter, which the runner stores as an invalid run).
  for (const std::size_t i : {std::size_t{0}, spec.run_count() - 1}) {
    const studies::DesignPoint p = spec.point(i);
    FUZZ_CHECK(p.index == i, std::to_string(i));
    if (spec.is_analytic()) continue;
    try {
      (void)spec.config_for(p);
    } catch (const engine::InvalidParameter&) {
    }
  }
  return 0;
}

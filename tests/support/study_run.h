#pragma once
// Test helpers: parse a study spec that must be valid, and create + run a study to completion.
#include <gtest/gtest.h>

#include <filesystem>
#include <stdexcept>
#include <string>

#include "stickslip/store/store.h"
#include "stickslip/studies/runner.h"
#include "stickslip/studies/spec.h"

namespace stickslip::testing {

inline studies::StudySpec parse_ok(const std::string& text) {
  studies::ParseResult r = studies::parse_study(text);
  if (!r.ok()) throw std::runtime_error("spec does not parse: " + common::to_string(r.errors));
  return std::move(*r.spec);
}

struct RanStudy {
  std::string id;
  studies::RunSummary summary;
};

/// Creates the study (or finds it by spec) and runs it to completion with 2 threads.
inline RanStudy run_to_end(const std::filesystem::path& db, const studies::StudySpec& spec) {
  RanStudy r;
  {
    store::Store store = store::Store::open(db);
    r.id = studies::create_or_find_study(store, spec).id;
  }
  studies::RunnerOptions opt;
  opt.threads = 2;
  opt.writer.max_batch = 4096;  // analytic runs are cheap: few, large transactions
  r.summary = studies::run_study(db, r.id, spec, opt);
  EXPECT_EQ(r.summary.outcome, studies::RunOutcome::kCompleted) << r.summary.error;
  return r;
}

}  // namespace stickslip::testing

// The pieces of the distributed backends that need no MPI: the chunk scheduler (every job handed
// out once, in order; guided sizes that shrink towards the end and follow the measured cost;
// deadlines) and the wire format (runs and tasks round-trip bit for bit, NaN, infinities, -0
// and traces included; malformed bytes are an error, never a crash).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>

#include "stickslip/studies/chunks.h"
#include "stickslip/studies/wire.h"

namespace {

using namespace stickslip;
using namespace stickslip::studies;

std::uint64_t bits(double v) {
  std::uint64_t b;
  std::memcpy(&b, &v, sizeof b);
  return b;
}

TEST(ChunkScheduler, HandsOutEveryJobOnceInOrderAndShrinksTowardsTheEnd) {
  const std::vector<std::size_t> sizes(1000, 1);
  ChunkScheduler s(sizes, 4);
  std::vector<Chunk> chunks;
  std::size_t next = 0;
  while (auto c = s.next(2)) {
    EXPECT_EQ(c->first_job, next);
    EXPECT_EQ(c->id, chunks.size());
    next += c->jobs;
    s.returned(*c, 0.01 * static_cast<double>(c->runs), 2);  // 20 ms of a thread a run
    chunks.push_back(*c);
  }
  EXPECT_EQ(next, 1000u);
  EXPECT_EQ(s.remaining_jobs(), 0u);
  EXPECT_EQ(chunks.front().jobs, 2u);  // one job per thread before any cost is known
  // Guided: at most remaining / (2 x 4 workers); the last chunks are single jobs.
  EXPECT_LE(chunks[1].jobs, (1000 - 2 + 7) / 8);
  EXPECT_EQ(chunks.back().jobs, 1u);
  for (std::size_t k = 2; k < chunks.size(); ++k) EXPECT_LE(chunks[k].jobs, chunks[k - 1].jobs);
  ASSERT_TRUE(s.seconds_per_run().has_value());
  EXPECT_NEAR(*s.seconds_per_run(), 0.02, 1e-12);
}

TEST(ChunkScheduler, ChunksLastAboutTheTargetTimeAndStayWithinMaxRuns) {
  ChunkOptions o;
  o.target_s = 1.0;
  o.max_runs = 50;
  ChunkScheduler s(std::vector<std::size_t>(100000, 1), 2, o);
  const Chunk first = *s.next(4);
  s.returned(first, 0.1, 4);  // 4 runs in 0.1 s on 4 threads: 0.1 thread-seconds a run
  ChunkOptions wide = o;
  wide.max_runs = 1000000;
  ChunkScheduler t(std::vector<std::size_t>(100000, 1), 2, wide);
  t.returned(*t.next(4), 0.1, 4);
  EXPECT_EQ(t.next(4)->runs, 40u);  // 1 s x 4 threads / 0.1 s
  EXPECT_EQ(s.next(4)->runs, 40u);
  o.target_s = 100;
  ChunkScheduler u(std::vector<std::size_t>(100000, 1), 2, o);
  u.returned(*u.next(4), 0.1, 4);
  EXPECT_EQ(u.next(4)->runs, 50u);  // bounded by max_runs
}

TEST(ChunkScheduler, BatchedJobsStayWholeAndDeadlinesFollowTheCost) {
  ChunkOptions o;
  o.deadline_floor_s = 5;
  o.deadline_factor = 10;
  const std::vector<std::size_t> sizes = {8, 8, 8, 3, 1, 1};
  ChunkScheduler s(sizes, 1, o);
  const Chunk a = *s.next(1);
  EXPECT_EQ(a.runs, 8u);
  EXPECT_EQ(s.deadline(a, 1), 5.0);  // nothing known yet: the floor
  s.returned(a, 8.0, 1);             // 1 s a run
  const Chunk b = *s.next(1);
  // Whole jobs only: a chunk's runs are the sizes of its jobs.
  EXPECT_EQ(b.runs, std::accumulate(sizes.begin() + static_cast<long>(b.first_job),
                                    sizes.begin() + static_cast<long>(b.first_job + b.jobs),
                                    std::size_t{0}));
  EXPECT_DOUBLE_EQ(s.deadline(b, 1), std::max(5.0, 10.0 * static_cast<double>(b.runs)));
  EXPECT_DOUBLE_EQ(s.deadline(b, 4), std::max(5.0, 10.0 * static_cast<double>(b.runs) / 4));
  std::size_t runs = a.runs + b.runs;
  while (auto c = s.next(1)) runs += c->runs;
  EXPECT_EQ(runs, 29u);
}

TEST(ChunkScheduler, RejectsBadOptionsNamingThem) {
  ChunkOptions o;
  o.target_s = 0;
  o.deadline_factor = 0.5;
  std::vector<std::string> errors;
  EXPECT_FALSE(o.IsValid(&errors));
  ASSERT_EQ(errors.size(), 2u);
  EXPECT_NE(errors[0].find("target_s"), std::string::npos) << errors[0];
  EXPECT_NE(errors[1].find("deadline_factor"), std::string::npos) << errors[1];
  EXPECT_THROW(ChunkScheduler({1}, 0), std::invalid_argument);
  EXPECT_THROW(ChunkScheduler({1}, 1, o), std::invalid_argument);
}

store::RunRecord odd_run() {
  store::RunRecord r;
  r.design_index = 123456789012;
  r.param_hash = "0123456789abcdef";
  r.params_json = R"({"model":"lugre","v_a":0.001})";
  r.model = "lugre";
  r.va_over_vd = -0.0;
  r.status = "diverged";
  r.error = "step size underflow at t = 1.5 s";
  r.wall_time_s = 1e-300;
  r.t_end = 1.0 / 3.0;
  r.steps = (std::int64_t{1} << 53) + 1;
  store::StageMetricsRecord m;
  m.stage = 2;
  m.amplitude = std::numeric_limits<double>::quiet_NaN();
  m.amplitude_raw = std::numeric_limits<double>::infinity();
  m.mean_force = -std::numeric_limits<double>::infinity();
  m.mean_friction = std::numeric_limits<double>::denorm_min();
  m.mean_period = 0.1f;  // exactly a float: must not come back as another double
  m.slip_events = -7;
  m.rmse = 0.1;
  r.stages = {m, m};
  r.trace = {{0, 1, 2, 3, 4, 5}, {0.5, -1e308, 1e-308, -0.0, 7, 8}};
  return r;
}

TEST(Wire, RunsRoundTripBitForBit) {
  store::RunRecord plain;
  plain.params_json = "{}";
  const std::vector<store::RunRecord> runs = {odd_run(), plain};
  const wire::Bytes b = wire::encode_runs(runs);
  const auto back = wire::decode_runs(b.data(), b.size(), "st-x");
  ASSERT_EQ(back.size(), 2u);
  const store::RunRecord& r = back[0];
  const store::RunRecord o = odd_run();
  EXPECT_EQ(r.study_id, "st-x");
  EXPECT_EQ(r.design_index, o.design_index);
  EXPECT_EQ(r.param_hash, o.param_hash);
  EXPECT_EQ(r.params_json, o.params_json);
  EXPECT_EQ(r.model, o.model);
  EXPECT_EQ(bits(*r.va_over_vd), bits(-0.0));
  EXPECT_EQ(r.status, o.status);
  EXPECT_EQ(r.error, o.error);
  EXPECT_EQ(bits(r.wall_time_s), bits(o.wall_time_s));
  EXPECT_EQ(bits(r.t_end), bits(o.t_end));
  EXPECT_EQ(r.steps, o.steps);
  EXPECT_FALSE(r.rmse.has_value());
  ASSERT_EQ(r.stages.size(), 2u);
  const auto& m = r.stages[1];
  const auto& w = o.stages[1];
  EXPECT_EQ(m.stage, 2);
  for (auto [x, y] : {std::pair{m.amplitude, w.amplitude}, {m.amplitude_raw, w.amplitude_raw},
                      {m.mean_force, w.mean_force}, {m.mean_friction, w.mean_friction},
                      {m.mean_period, w.mean_period}, {m.t_start, w.t_start}, {*m.rmse, *w.rmse}})
    EXPECT_EQ(bits(x), bits(y));
  EXPECT_EQ(m.slip_events, -7);
  ASSERT_EQ(r.trace.size(), 2u);
  EXPECT_EQ(std::memcmp(r.trace.data(), o.trace.data(), 2 * sizeof(store::TracePoint)), 0);
  EXPECT_FALSE(back[1].model.has_value());
  EXPECT_FALSE(back[1].va_over_vd.has_value());
  EXPECT_TRUE(back[1].trace.empty());
}

TEST(Wire, TaskRoundTripsAndMalformedBytesAreAnError) {
  wire::Task t;
  t.study_id = "st-1";
  t.spec_json = R"({"name":"x"})";
  t.limits.max_runs = 7;
  t.limits.min_dt = 1e-12;
  t.spec_dir = "/data/specs";
  t.pending = {0, 1, 2, 3, 7, 9, 10, 11, 100};
  t.threads = 3;
  t.chunk_deadline_s = 2.5;
  const wire::Bytes b = wire::encode_task(t);
  const wire::Task u = wire::decode_task(b.data(), b.size());
  EXPECT_EQ(u.study_id, t.study_id);
  EXPECT_EQ(u.spec_json, t.spec_json);
  EXPECT_EQ(u.limits.max_runs, 7u);
  EXPECT_EQ(u.limits.min_dt, 1e-12);
  EXPECT_EQ(u.spec_dir, t.spec_dir);
  EXPECT_EQ(u.pending, t.pending);
  EXPECT_EQ(u.threads, 3);
  EXPECT_EQ(u.chunk_deadline_s, 2.5);
  for (std::size_t cut : {std::size_t{0}, std::size_t{1}, b.size() / 2, b.size() - 1})
    EXPECT_THROW(wire::decode_task(b.data(), cut), wire::WireError) << cut;
  const wire::Bytes runs = wire::encode_runs({odd_run()});
  EXPECT_THROW(wire::decode_runs(runs.data(), runs.size() - 3, "s"), wire::WireError);
  EXPECT_THROW(wire::decode_runs(b.data(), b.size(), "s"), wire::WireError);  // a task
  // A spec this process cannot rebuild is named.
  t.spec_json = R"({"name": 1})";
  try {
    wire::load_task(t);
    ADD_FAILURE() << "no error";
  } catch (const wire::WireError& e) {
    EXPECT_NE(std::string(e.what()).find("does not parse"), std::string::npos) << e.what();
  }
}

}  // namespace

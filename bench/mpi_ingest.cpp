// Rank 0's ingest ceiling (docs/scale.md): the runs per second the MPI master can receive,
// decode and commit when its worker ranks return every chunk at once. A table printer, not a
// test; run it alone on an idle machine:
//
//   mpirun --oversubscribe --bind-to none -np 3 build/bench/mpi_ingest [--runs 100000]
//
// Workers "compute" a run by copying a real paper-map record (2 stages, computed once at start)
// under the run's own design index, parameters and hash, so rank 0 handles exactly what a real
// study sends it. Printed, side by side in one run:
//   1. the writer alone: RunWriter::add of the same records in this process (no MPI);
//   2. the whole path through the MPI master, for chunks of at most 64, 512 and 4096 runs;
//   3. the message sizes: bytes per run of a result message and of a chunk message.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>

#include <CLI/CLI.hpp>

#include "stickslip/mpi/session.h"
#include "stickslip/studies/runner.h"

namespace {

namespace fs = std::filesystem;
using namespace stickslip;
using Clock = std::chrono::steady_clock;

// A grid of the paper map's models and stages, n runs in all (n/4 values of va_over_vd).
std::string spec_text(std::size_t n) {
  return R"({"name": "ingest", "base": {"model": "lugre", "m": 0.665, "k_d": 11700, "v_d": 0.001,
    "F_z": 29.4}, "stages": [{"duration": 10}, {"duration": 10, "v_a": 0.0, "f": 1500}],
    "design": {"type": "grid", "axes": [
      {"name": "model", "values": ["dahl", "karnopp", "reset_integrator", "lugre"]},
      {"name": "va_over_vd", "linspace": [0, 5, )" +
         std::to_string(n / 4) + "]}]}}";
}

studies::StudySpec parse(std::size_t n) {
  studies::Limits limits;
  limits.max_runs = n + 4;
  auto r = studies::parse_study(spec_text(n), limits);
  if (!r.ok()) throw std::runtime_error("spec: " + r.errors[0].message);
  return std::move(*r.spec);
}

// A real run's record (short stages: only its shape matters), reused for every run.
store::RunRecord template_record() {
  auto r = studies::parse_study(R"({"name": "t", "stages": [{"duration": 1}, {"duration": 1}],
                                    "design": {"type": "list", "points": [{}]}})");
  return studies::compute_run(*r.spec, 0, "");
}

// The same record under run i of spec: its own parameters and hash, as compute_run sets them.
store::RunRecord instant_run(const studies::StudySpec& spec, std::size_t i,
                             const store::RunRecord& t, const std::string& study_id) {
  store::RunRecord r = t;
  const studies::DesignPoint p = spec.point(i);
  r.study_id = study_id;
  r.design_index = static_cast<std::int64_t>(i);
  r.params_json = spec.canonical_point_json(p);
  r.param_hash = store::param_hash(r.params_json);
  r.model = p.model;
  r.va_over_vd = p.value("va_over_vd");
  return r;
}

int serve_instantly(mpi::Session& session) {
  const store::RunRecord t = template_record();
  return session.serve([&t](const studies::wire::LoadedTask& task,
                            const std::vector<studies::Job>& jobs, const std::string& id, int,
                            std::atomic<std::int64_t>*) {
    std::vector<store::RunRecord> out;
    for (const auto& job : jobs)
      for (std::size_t i : job) out.push_back(instant_run(task.spec, i, t, id));
    return out;
  });
}

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

void writer_alone(const studies::StudySpec& spec, const fs::path& db) {
  fs::remove(db);
  store::Store store = store::Store::open(db);
  const auto st = studies::create_or_find_study(store, spec);
  const store::RunRecord t = template_record();
  std::vector<store::RunRecord> recs;
  for (std::size_t i = 0; i < spec.run_count(); ++i) recs.push_back(instant_run(spec, i, t, st.id));
  const auto t0 = Clock::now();
  {
    store::RunWriter w = store::RunWriter::open(db);
    for (auto& r : recs) w.add(std::move(r));
    w.flush();
  }
  const double s = seconds_since(t0);
  std::printf("%-34s %10zu %9.3f %12.0f\n", "writer alone (no MPI)", spec.run_count(), s,
              static_cast<double>(spec.run_count()) / s);
}

void through_master(mpi::Session& session, const studies::StudySpec& spec, const fs::path& db,
                    std::size_t max_runs) {
  fs::remove(db);
  std::string id;
  {
    store::Store store = store::Store::open(db);
    id = studies::create_or_find_study(store, spec).id;
  }
  studies::ChunkOptions chunks;
  chunks.max_runs = max_runs;
  studies::RunnerOptions opt;
  opt.execution.executor = session.executor(chunks);
  const studies::RunSummary s = studies::run_study(db, id, spec, opt);
  if (s.outcome != studies::RunOutcome::kCompleted) throw std::runtime_error(s.error);
  const std::string label = "MPI master, chunks <= " + std::to_string(max_runs) + " runs";
  std::printf("%-34s %10lld %9.3f %12.0f   (writer %.3f s)\n", label.c_str(),
              static_cast<long long>(s.computed), s.wall_s,
              static_cast<double>(s.computed) / s.wall_s, s.store_s);
}

void message_sizes(const studies::StudySpec& spec) {
  const store::RunRecord t = template_record();
  std::vector<store::RunRecord> recs;
  for (std::size_t i = 0; i < 512; ++i) recs.push_back(instant_run(spec, i, t, "st"));
  const auto bytes = studies::wire::encode_runs(recs);
  std::printf("result message: %.0f bytes per run (2 stages, no trace; 512 runs: %zu bytes)\n",
              static_cast<double>(bytes.size()) / 512.0, bytes.size());
  std::printf("chunk message:  16 bytes per unbatched run (a job of one: its size and index, "
              "int64), 8 + 8 per run in a batch of n\n");
}

}  // namespace

int main(int argc, char** argv) {
  auto session = mpi::Session::start_if_launched(&argc, &argv);
  if (!session || session->size() < 2) {
    std::fprintf(stderr, "run under mpirun with at least 2 ranks (see the header)\n");
    return 2;
  }
  if (session->rank() > 0) return serve_instantly(*session);
  CLI::App app{"rank 0's ingest ceiling"};
  std::size_t runs = 100000;
  std::string dir = "/tmp";
  app.add_option("--runs", runs, "runs of the study")->capture_default_str();
  app.add_option("--dir", dir, "where the scratch stores go")->capture_default_str();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return session->finish(app.exit(e));
  }
  const studies::StudySpec spec = parse(runs);
  std::printf("%d ranks (%d workers returning at once); %zu runs\n", session->size(),
              session->size() - 1, spec.run_count());
  std::printf("%-34s %10s %9s %12s\n", "path", "runs", "wall [s]", "runs/s");
  const fs::path db = fs::path(dir) / ("mpi-ingest-" + std::to_string(::getpid()) + ".db");
  writer_alone(spec, db);
  for (std::size_t max_runs : {64, 512, 4096}) through_master(*session, spec, db, max_runs);
  message_sizes(spec);
  for (const char* ext : {"", "-wal", "-shm", ".lock"}) fs::remove(db.string() + ext);
  return session->finish(0);
}

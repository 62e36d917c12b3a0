// The MPI paths store exactly what the OpenMP path stores: `mpirun -np 3 stickslip study run`
// (rank 0 the master, 2 worker ranks) and `stickslip study run --launcher "mpirun -np 2"`
// (one worker rank with 2 threads) against `stickslip study run --threads 2`, row by row and
// bit for bit; for adaptive runs, batched rk4 runs, runs with traces, a Sobol design that grows
// in rounds, and the nightly report's path (`stickslip report`).
#include <nlohmann/json.hpp>

#include "mpi_support.h"

namespace {

using namespace stickslip::mpitest;
using stickslip::testing::TempDir;

class MpiResults : public ::testing::Test {
 protected:
  /// Runs spec three ways into <name>-omp.db, <name>-mpi.db, <name>-launch.db; all must pass.
  void run_three_ways(const std::string& name, const std::string& spec) {
    const fs::path file = write_file(dir_ / (name + ".json"), spec);
    const std::vector<std::string> run = {kClient, "study", "run", file.string(), "--quiet"};
    const CommandResult omp =
        run_command(cat(run, {"--db", db(name, "omp"), "--threads", "2"}), dir_.path());
    ASSERT_EQ(omp.code, 0) << omp.err;
    const CommandResult mpi = run_command(
        cat(mpirun(3), cat(run, {"--db", db(name, "mpi"), "--threads", "1"})), dir_.path());
    ASSERT_EQ(mpi.code, 0) << mpi.out << mpi.err;
    const CommandResult launched = run_command(
        cat(run, {"--db", db(name, "launch"), "--threads", "2", "--launcher", launcher(2)}),
        dir_.path());
    ASSERT_EQ(launched.code, 0) << launched.out << launched.err;
    for (const char* way : {"mpi", "launch"}) {
      SCOPED_TRACE(way);
      EXPECT_EQ(state_of(db(name, way)), "succeeded");
      expect_same_results(db(name, "omp"), db(name, way));
    }
  }
  std::string db(const std::string& name, const std::string& way) const {
    return (dir_ / (name + "-" + way + ".db")).string();
  }
  TempDir dir_{"stickslip-mpi"};
};

TEST_F(MpiResults, AdaptiveGridIsBitwiseTheSameOnThreeRanksAndThroughALauncher) {
  run_three_ways("adaptive", grid_spec("adaptive", 8));
  EXPECT_EQ(query_int(db("adaptive", "mpi"), "SELECT count(*) FROM runs"), 16);
  // The runs really differ (a comparison of identical rows would prove nothing).
  EXPECT_GT(query_int(db("adaptive", "mpi"),
                      "SELECT count(DISTINCT amplitude_raw) FROM stage_metrics"),
            16);
}

TEST_F(MpiResults, BatchedRk4RunsAndStoredTracesAreBitwiseTheSame) {
  run_three_ways("rk4", grid_spec("rk4", 10, R"("integrator": {"kind": "rk4", "dt": 2e-5})"));
  run_three_ways("traces", grid_spec("traces", 3, R"("outputs": {"traces": {"rate": 200}})"));
  EXPECT_EQ(query_int(db("traces", "mpi"), "SELECT count(*) FROM traces"), 6);
  EXPECT_GT(query_int(db("traces", "mpi"), "SELECT min(n_samples) FROM traces"), 600);
}

// A Sobol design with "until" grows in rounds: every round is one more study for the MPI
// workers (a new kTagBegin) and one more launched job.
TEST_F(MpiResults, SobolStudyThatGrowsInRoundsIsTheSame) {
  run_three_ways("sobol", R"({"name": "sobol", "base": {"model": "ishigami"},
      "design": {"type": "sobol", "n": 64, "until": {"max_st_width": 0.2, "n_max": 1024,
                 "resamples": 100}}})");
  const std::int64_t total = query_int(db("sobol", "mpi"), "SELECT progress_total FROM jobs");
  EXPECT_GT(total, 64 * 5) << "the study did not grow";
  expect_complete(db("sobol", "mpi"), total);
}

// `stickslip report` under mpirun and with --launcher computes its studies the same way: the
// indices and the map in summary.json are those of the local report.
TEST_F(MpiResults, ReportUnderMpirunAndWithALauncherGivesTheLocalSummary) {
  write_file(dir_ / "g.json", R"({"name": "g", "base": {"model": "sobol_g", "a": [0, 1, 9]},
                                  "design": {"type": "sobol", "n": 64}})");
  write_file(dir_ / "cfg.json", R"({"name": "r", "studies": [
      {"id": "g", "kind": "indices", "spec": "g.json"},
      {"id": "m", "kind": "map", "spec": {"name": "m", "stages": [{"duration": 1.5}, {"duration": 0.5}],
        "design": {"type": "grid", "axes": [{"name": "model", "values": ["karnopp", "lugre"]},
                                            {"name": "va_over_vd", "values": [0, 2]}]}}}]})");
  auto report = [&](const std::string& way, std::vector<std::string> prefix,
                    std::vector<std::string> more) {
    std::vector<std::string> argv = cat(std::move(prefix), {kClient, "report", "--config",
                                        (dir_ / "cfg.json").string(), "--out",
                                        (dir_ / ("out-" + way)).string(), "--db", db("r", way),
                                        "--date", "2026-04-01", "--quiet", "--threads", "1"});
    const CommandResult r = run_command(cat(argv, more), dir_.path());
    EXPECT_EQ(r.code, 0) << r.out << r.err;
    return nlohmann::json::parse(
        slurp(dir_ / ("out-" + way) / "2026-04-01" / "summary.json"));
  };
  const auto local = report("omp", {}, {});
  const auto mpi = report("mpi", mpirun(3), {});
  const auto launched = report("launch", {}, {"--launcher", launcher(2)});
  auto indices = [](nlohmann::json s) {  // all but the study's id, which each store makes
    s["entries"]["g"]["indices"].erase("study_id");
    return s["entries"]["g"]["indices"];
  };
  for (const auto* s : {&mpi, &launched}) {
    EXPECT_EQ(indices(*s), indices(local));
    EXPECT_EQ((*s)["entries"]["m"]["counts"], local["entries"]["m"]["counts"]);
    EXPECT_EQ((*s)["entries"]["g"]["run"]["computed"], 64 * 5);
  }
  for (const char* way : {"mpi", "launch"}) {
    // Both studies, every row: the report's store equals the local report's.
    EXPECT_EQ(rows_missing(db("r", "omp"), db("r", way)), 0) << way;
    EXPECT_EQ(result_rows(db("r", "omp")), result_rows(db("r", way))) << way;
  }
}

}  // namespace

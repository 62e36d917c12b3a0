// Study-level measurements for issue 3 (a table printer, not a test; run on an idle machine):
//   1. paper map (studies/paper-map.json) wall time with 1 and 2 threads -> parallel efficiency
//      T1 / (2 T2), and the store's share of wall time (time the single writer spends in
//      RunWriter::add/flush over the wall time of the study), traces off;
//   2. peak RSS of a 10,000-run study with traces off, sampled while it runs, against a
//      1,000-run study: memory must not grow with the number of runs;
//   3. convergence of the paper map's metrics: its own tolerance (studies/paper-map.json) against
//      rtol = atol = 1e-10 on every 5th va_over_vd column;
//   4. parsing and validating a list design of 12,500 to 100,000 points (the request the server
//      checks before it answers 202): the time per point must stay flat (a quadratic check,
//      issue 18 defect 4, grew it 8x over this range: 100,001 points took 3 s).
// Usage: study_bench [--skip-map] [--skip-memory] [--skip-convergence] [--skip-parse]
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "stickslip/studies/runner.h"

namespace {

namespace fs = std::filesystem;
using namespace stickslip;

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

studies::StudySpec parse_or_die(const std::string& text) {
  studies::ParseResult r = studies::parse_study(text);
  if (!r.ok()) {
    std::fprintf(stderr, "spec does not parse: %s: %s\n", r.errors[0].pointer.c_str(),
                 r.errors[0].message.c_str());
    std::exit(1);
  }
  return std::move(*r.spec);
}

// Current resident set size [MB] from /proc/self/statm.
double rss_mb() {
  std::ifstream in("/proc/self/statm");
  long pages = 0, resident = 0;
  in >> pages >> resident;
  return static_cast<double>(resident) * static_cast<double>(sysconf(_SC_PAGESIZE)) / 1048576.0;
}
double peak_rss_mb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;
}

studies::RunSummary run_fresh(const fs::path& db, const studies::StudySpec& spec, studies::RunnerOptions opt) {
  fs::remove(db);
  fs::remove(db.string() + "-wal");
  fs::remove(db.string() + "-shm");
  store::Store store = store::Store::open(db);
  const store::StudyRecord st = studies::create_or_find_study(store, spec);
  return studies::run_study(db, st.id, spec, opt);
}

void paper_map(const fs::path& tmp) {
  const studies::StudySpec spec = parse_or_die(slurp(fs::path(STICKSLIP_SOURCE_DIR) / "studies/paper-map.json"));
  std::printf("== paper map: %zu runs (4 models x 51 va_over_vd, 10 s + 10 s, adaptive)\n",
              spec.run_count());
  studies::RunnerOptions one, two;
  one.threads = 1;
  two.threads = 2;
  const studies::RunSummary s2 = run_fresh(tmp / "map2.db", spec, two);
  const studies::RunSummary s1 = run_fresh(tmp / "map1.db", spec, one);
  for (const auto* s : {&s1, &s2})
    std::printf("  threads %d: wall %.2f s, compute %.2f CPU-s, store %.4f s (%.3f %% of wall), "
                "failed %lld\n",
                s == &s1 ? 1 : 2, s->wall_s, s->compute_s, s->store_s, 100.0 * s->store_s / s->wall_s,
                static_cast<long long>(s->failed));
  std::printf("  parallel efficiency T1 / (2 T2) = %.1f %% (target >= 90 %%)\n",
              100.0 * s1.wall_s / (2.0 * s2.wall_s));
}

void memory(const fs::path& tmp) {
  std::printf("== memory: cheap runs (Karnopp, 0.05 s + 0.05 s), traces off\n");
  for (int n : {1000, 10000}) {
    const std::string text = R"({"name": "mem", "stages": [{"duration": 0.05}, {"duration": 0.05}],
      "base": {"model": "karnopp"},
      "design": {"type": "random", "n": )" + std::to_string(n) + R"(, "seed": 3,
                 "ranges": [{"name": "k_d", "min": 9000, "max": 14000},
                            {"name": "va_over_vd", "min": 0, "max": 5}]}})";
    const studies::StudySpec spec = parse_or_die(text);
    double max_rss = 0, rss_at_10pc = 0;
    studies::RunnerOptions opt;
    opt.threads = 2;
    opt.on_progress = [&](const studies::Progress& p) {
      const double r = rss_mb();
      max_rss = std::max(max_rss, r);
      if (rss_at_10pc == 0 && p.done >= p.total / 10) rss_at_10pc = r;
    };
    const double before = rss_mb();
    const studies::RunSummary s = run_fresh(tmp / "mem.db", spec, opt);
    std::printf("  %5d runs: wall %.2f s (compute %.2f CPU-s), RSS before %.1f MB, at 10 %% %.1f MB, max sampled %.1f "
                "MB, process peak %.1f MB, store %.3f %% of wall\n",
                n, s.wall_s, s.compute_s, before, rss_at_10pc, max_rss, peak_rss_mb(),
                100.0 * s.store_s / s.wall_s);
  }
}

void convergence(const fs::path& tmp) {
  nlohmann::json doc = nlohmann::json::parse(slurp(fs::path(STICKSLIP_SOURCE_DIR) / "studies/paper-map.json"));
  doc["design"]["axes"][1] = {{"name", "va_over_vd"}, {"linspace", {0, 5, 11}}};
  const studies::StudySpec coarse = parse_or_die(doc.dump());
  doc["integrator"] = {{"kind", "adaptive"}, {"rtol", 1e-10}, {"atol", 1e-10}};
  doc["name"] = "paper-map-tight";
  const studies::StudySpec tight = parse_or_die(doc.dump());
  std::printf("== convergence of the paper map's metrics: its tolerance vs rtol = atol = "
              "1e-10, %zu runs\n", coarse.run_count());
  studies::RunnerOptions opt;
  opt.threads = 2;
  run_fresh(tmp / "c1.db", coarse, opt);
  run_fresh(tmp / "c2.db", tight, opt);
  store::Store a = store::Store::open(tmp / "c1.db", store::Store::Mode::kReadOnly);
  store::Store b = store::Store::open(tmp / "c2.db", store::Store::Mode::kReadOnly);
  const auto ra = a.get_runs(a.list_studies(1)[0].id, -1, 10000);
  const auto rb = b.get_runs(b.list_studies(1)[0].id, -1, 10000);
  double worst_amp = 0, worst_mean = 0;
  std::string where_amp, where_mean;
  for (std::size_t i = 0; i < ra.size() && i < rb.size(); ++i)
    for (std::size_t s = 0; s < ra[i].stages.size() && s < rb[i].stages.size(); ++s) {
      const double da = std::abs(ra[i].stages[s].amplitude - rb[i].stages[s].amplitude);
      const double dm = std::abs(ra[i].stages[s].mean_force - rb[i].stages[s].mean_force);
      const std::string at = *ra[i].model + " va/vd=" + std::to_string(*ra[i].va_over_vd) +
                             " stage " + std::to_string(s + 1);
      if (da > worst_amp) worst_amp = da, where_amp = at;
      if (dm > worst_mean) worst_mean = dm, where_mean = at;
    }
  std::printf("  max |d amplitude| = %.2e N (%s); max |d mean_force| = %.2e N (%s)\n", worst_amp,
              where_amp.c_str(), worst_mean, where_mean.c_str());
}

// 4. A list design of n empty points (every point takes the spec's defaults), as the server's
// POST /v1/studies receives it; the fastest of three parses per size.
void list_design_parse() {
  std::printf("list design: parse and validate (fastest of 3)\n%10s %12s %16s %8s\n", "points", "time[s]",
              "per point[us]", "ratio");
  double first = 0;
  for (int n : {12500, 25000, 50000, 100000}) {  // 100,000: the default run limit
    std::string points;
    for (int i = 0; i < n; ++i) points += i ? ",{}" : "{}";
    const std::string text = R"({"name": "big", "stages": [{"duration": 0.1}], )"
                             R"("design": {"type": "list", "points": [)" + points + "]}}";
    double best = 1e300;
    for (int rep = 0; rep < 3; ++rep) {
      const auto t0 = std::chrono::steady_clock::now();
      const studies::StudySpec spec = parse_or_die(text);
      best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      if (spec.name() != "big") std::exit(1);
    }
    const double per = best / n * 1e6;
    if (first == 0) first = per;
    std::printf("%10d %12.4f %16.3f %8.2f\n", n, best, per, per / first);
  }
  std::printf("ratio: time per point against 12,500 points (1 = linear; a quadratic check gives 8 at 100,000)\n");
}

}  // namespace

int main(int argc, char** argv) {
  bool map = true, mem = true, conv = true;
  CLI::App app{"Study benchmarks: the paper map, memory, convergence, list-design parsing"};
  app.add_flag("!--skip-map", map, "skip the paper map");
  app.add_flag("!--skip-memory", mem, "skip the memory measurement");
  app.add_flag("!--skip-convergence", conv, "skip the convergence table");
  bool parse = true;
  app.add_flag("!--skip-parse", parse, "skip the list-design parse scaling");
  CLI11_PARSE(app, argc, argv);
  const fs::path tmp = fs::temp_directory_path() / ("stickslip-bench-" + std::to_string(getpid()));
  fs::create_directories(tmp);
  if (mem) memory(tmp);  // first, so the peak RSS is not inflated by the larger studies
  if (map) paper_map(tmp);
  if (conv) convergence(tmp);
  if (parse) list_design_parse();
  fs::remove_all(tmp);
  return 0;
}

// What a diagnosis reports beyond the cause (issue 5): whole runs held out (leave one v_a out),
// the evidence in the residuals (profiles, spectra against x and t, stage levels against v_a),
// diagnosis.json against schemas/diagnosis.schema.json, and the plots of write_report.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <random>
#include <sstream>

#include "stickslip/diagnosis/detail/diagnose_evidence.h"
#include "stickslip/diagnosis/diagnose.h"
#include "stickslip/diagnosis/diagnose_suite.h"
#include "stickslip/common/json_schema.h"
#include "stickslip/measured/synth.h"
#include "support/temp_dir.h"

using namespace stickslip;
using namespace stickslip::diagnosis;

namespace {

std::string slurp(const std::filesystem::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

double rms_of(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x * x;
  return std::sqrt(s / static_cast<double>(v.size()));
}

HiddenCase drift_case() { return hidden_case("drift"); }


// A sine of known frequency in unevenly sampled noise: the scan finds its period and amplitude,
// and a period at the samples' Nyquist limit (where the sine vanishes at every sample) has no
// amplitude instead of a division by almost zero.
TEST(DiagnoseEvidence, SineScanFindsAKnownPeriodAndIgnoresTheNyquistLimit) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 0.03);
  std::vector<double> t, y;
  for (int i = 0; i < 4000; ++i) {
    t.push_back(i * 4e-3);  // 250 Hz
    y.push_back(0.1 * std::sin(2 * M_PI * 7.0 * t.back() + 0.3) + noise(rng));
  }
  const detail::SineScan s = detail::sine_scan(y, t, 8e-3, 1000.0, 600);
  double ratio = 0;
  const std::size_t k = detail::scan_peak(s, &ratio);
  EXPECT_NEAR(1.0 / s.period[k], 7.0, 7.0 * 0.012);  // grid step 1.2 %
  EXPECT_NEAR(s.amplitude[k], 0.1, 0.01);
  EXPECT_GT(ratio, 100.0);
  EXPECT_LT(s.amplitude.front(), 1.0);  // period 8 ms = 2 samples
  for (double a : s.amplitude) EXPECT_TRUE(std::isfinite(a));
}

// Leave one v_a out: a hidden drift (friction x (1 + gamma x)) fitted on one run carries over
// to the other, so the extended model predicts each left-out whole run to the noise level
// (0.03 N) while the base misses it; the left-out run's own stage statistics are reported.
void check_whole_runs(const Diagnosis& d) {
  ASSERT_EQ(d.cause, "drift") << summary_text(d);
  ASSERT_EQ(d.run_holdouts.size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    const RunHoldout& h = d.run_holdouts[k];
    EXPECT_EQ(h.status, "ok");
    EXPECT_EQ(h.run, d.run_names[k]);
    EXPECT_DOUBLE_EQ(h.va, d.run_va[k]);
    EXPECT_LT(h.rmse_extended, 0.045) << h.run;
    EXPECT_GT(h.rmse_base, 2 * h.rmse_extended) << h.run;
    EXPECT_GT(h.gain, 0.5) << h.run;
    ASSERT_EQ(h.stages_base.size(), 2u);
    ASSERT_EQ(h.stages_extended.size(), 2u);
    // The measured side is the left-out run's own (as in the all-run calibration's table).
    for (const StageScore& st : d.evidence.stages)
      if (st.run == static_cast<int>(k)) {
        EXPECT_DOUBLE_EQ(h.stages_base[st.stage].measured_amplitude, st.measured_amplitude);
        EXPECT_NEAR(h.stages_extended[st.stage].model_mean, st.measured_mean, 0.05);
      }
  }
  EXPECT_GT(d.gain_heldout_runs, 0.5);
  EXPECT_LT(d.rmse_extended_heldout_runs, d.rmse_base_heldout_runs);

  // With one run there are no folds.
  measured::MeasuredDataset one = measured::synthesize(hidden_case_dataset(drift_case(), 1000, SuiteDatasets::kCi));
  one.runs.resize(1);
  DiagnoseOptions o = hidden_case_options(SuiteDatasets::kCi);
  o.candidates = {engine::ExtensionKind::kDrift};
  o.max_evals_base = 12;
  o.max_evals_candidate = 12;
  const Diagnosis d1 = diagnose(one, o);
  EXPECT_TRUE(d1.run_holdouts.empty());
  EXPECT_TRUE(to_json(d1)["heldout_runs"].is_null());
  DiagnoseOptions bad = o;
  bad.max_evals_fold = 2;
  std::string why;
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_NE(why.find("max_evals_fold = 2"), std::string::npos) << why;
}

// The evidence of a hidden drift: the residual profiles and spectra are filled for the base
// and the extended model, the extended model's residuals are flatter along x, and the time
// spectrum's peak is a real frequency with a residual-sized amplitude.
void check_evidence(const Diagnosis& d) {
  const Evidence& e = d.evidence;
  ASSERT_EQ(e.profiles.size(), 3u);
  for (const ResidualProfile& p : e.profiles) {
    EXPECT_EQ(p.center.size(), 20u) << p.variable;
    ASSERT_EQ(p.extended.size(), p.base.size()) << p.variable;
    for (std::size_t i = 1; i < p.center.size(); ++i) EXPECT_GE(p.center[i], p.center[i - 1]);
    EXPECT_LT(rms_of(p.extended), rms_of(p.base)) << p.variable;
  }
  EXPECT_EQ(e.profiles[2].variable, "position");
  ASSERT_EQ(e.t_spectrum.period.size(), e.t_spectrum.extended.size());
  ASSERT_EQ(e.x_spectrum.period.size(), e.x_spectrum.extended.size());
  EXPECT_GT(e.frequency, 0.0);
  EXPECT_LE(e.frequency, 0.5 * d.options.fit_rate);
  EXPECT_LT(e.frequency_amplitude, 2 * e.residual_rms);
  ASSERT_EQ(e.stage_mean_residual_extended.size(), e.stage_mean_residual.size());
  EXPECT_LT(rms_of(e.stage_mean_residual_extended), rms_of(e.stage_mean_residual));
}

// diagnosis.json follows its schema, and write_report writes the data and, with gnuplot, the
// per-run plots and the evidence plot with the cause's panel marked; a quote in a run name does
// not break the plot script.
void check_json_and_plots(const Diagnosis& d) {
  const auto schema = nlohmann::json::parse(diagnosis_schema_text());
  EXPECT_EQ(schema, nlohmann::json::parse(slurp(STICKSLIP_SCHEMA_DIR "/diagnosis.schema.json")));
  const auto j = to_json(d);
  const auto errors = common::validate_against_schema(j, schema);
  EXPECT_TRUE(errors.empty()) << to_string(errors);
  EXPECT_EQ(j["heldout_runs"]["folds"].size(), 2u);
  EXPECT_EQ(j["evidence"]["profiles"]["position"]["base"].size(), 20u);

  // The schema is not vacuous: a wrong cause and a missing field are caught.
  auto broken = j;
  broken["cause"] = "friction";
  broken.erase("gain");
  const auto errs = common::validate_against_schema(broken, schema);
  bool cause = false, gain = false;
  for (const auto& err : errs) {
    cause = cause || err.pointer == "/cause";
    gain = gain || err.message.find("gain") != std::string::npos;
  }
  EXPECT_TRUE(cause && gain) << to_string(errs);

  stickslip::testing::TempDir dir;
  const auto files = write_report(d, dir.path());
  for (const char* f : {"diagnosis.json", "run1.dat", "run2.dat", "profile_position.dat",
                        "spectrum_x.dat", "spectrum_t.dat", "stage_levels.dat", "plots.gp"})
    EXPECT_TRUE(std::filesystem::exists(dir.path() / f)) << f;
  EXPECT_EQ(nlohmann::json::parse(slurp(dir.path() / "diagnosis.json")), j);
  const std::string gp = slurp(dir.path() / "plots.gp");
  EXPECT_NE(gp.find("[cause] residual vs position"), std::string::npos);
  EXPECT_NE(gp.find("stand''s run 1"), std::string::npos);
  // The run plots' title names the base and the named cause (no stray "+", no empty name).
  EXPECT_NE(gp.find(": measured vs lugre and drift"), std::string::npos) << gp.substr(0, 600);
  if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) {
    ADD_FAILURE() << "gnuplot not installed (scripts/install-deps.sh installs it)";
    return;
  }
  for (const char* f : {"run1.png", "run2.png", "evidence.png"}) {
    const std::string png = slurp(dir.path() / f);
    ASSERT_GT(png.size(), 1000u) << f << "\n" << slurp(dir.path() / "gnuplot.log");
    EXPECT_EQ(png.substr(1, 3), "PNG") << f;
  }
  EXPECT_EQ(slurp(dir.path() / "gnuplot.log"), "");  // no gnuplot warning or error
}

}  // namespace

// The drift case of the hidden-effect suite (seed 1000, CI datasets), diagnosed with the drift
// candidate only (one diagnosis for all the checks, for CI time), a quote in a run name.
TEST(DiagnoseReport, DriftDiagnosisReportsWholeRunsEvidenceSchemaAndPlots) {
  measured::MeasuredDataset data = measured::synthesize(hidden_case_dataset(drift_case(), 1000, SuiteDatasets::kCi));
  data.runs[0].name = "stand's run 1";
  data.runs[1].conditions.defaulted = {"Fz"};  // as if its manifest left Fz out
  DiagnoseOptions o = hidden_case_options(SuiteDatasets::kCi);
  o.candidates = {engine::ExtensionKind::kDrift};
  const Diagnosis d = diagnose(data, o);
  EXPECT_EQ(d.base_note, "");  // lugre, the base, takes effects
  {
    SCOPED_TRACE("conditions taken from the seed are reported per run");
    ASSERT_EQ(d.readings.size(), 2u);
    EXPECT_TRUE(d.readings[0].defaulted.empty());
    EXPECT_EQ(d.readings[1].defaulted, std::vector<std::string>{"Fz"});
    EXPECT_EQ(to_json(d)["readings"][1]["defaulted"], nlohmann::json::array({"Fz"}));
    const std::string text = summary_text(d);
    EXPECT_NE(text.find("not in the manifest, the seed's values taken: Fz = 29.4 N"), std::string::npos)
        << text;
  }
  {
    SCOPED_TRACE("whole runs held out");
    check_whole_runs(d);
  }
  {
    SCOPED_TRACE("evidence");
    check_evidence(d);
  }
  {
    SCOPED_TRACE("diagnosis.json and plots");
    check_json_and_plots(d);
  }
}

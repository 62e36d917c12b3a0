// eFAST and RBD-FAST (sa_fast.h, sa_given.h): frequencies, designs, and the indices of the Ishigami
// and Sobol G functions against their exact values.
#include "stickslip/studies/sa_fast.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <string>
#include <vector>

#include "stickslip/studies/sa_given.h"
#include "support/sa_functions.h"
#include "support/is_valid.h"

namespace {

namespace ss = stickslip::studies::sensitivity;
using stickslip::testing::evaluate;
using stickslip::testing::ishigami_unit;
using stickslip::testing::report;
using stickslip::testing::bootstrap;

ss::EfastShape efast(std::size_t n, std::size_t d, std::size_t replicates, std::size_t M = 4) {
  ss::EfastShape s;
  s.n = n;
  s.d = d;
  s.M = M;
  s.replicates = replicates;
  return s;
}

const std::vector<double> kGA = {78, 12, 0.5, 2, 97, 33};

double g_unit(const std::vector<double>& u) { return ss::sobol_g(u, kGA); }

}  // namespace

// SALib's fast_sampler assignment: omega_max = floor((n - 1) / 2M), the others spread over
// [1, omega_max / 2M] (or cycling through it when it is shorter than d - 1).
TEST(EfastFrequencies, FollowSaltelliAndSalib) {
  EXPECT_EQ(ss::efast_frequencies(efast(1025, 8, 1)),
            (std::vector<std::size_t>{128, 1, 3, 6, 8, 11, 13, 16}));
  EXPECT_EQ(ss::efast_frequencies(efast(65, 3, 1)), (std::vector<std::size_t>{8, 1, 1}));
  EXPECT_EQ(ss::efast_frequencies(efast(257, 4, 1)), (std::vector<std::size_t>{32, 1, 2, 4}));
  std::string why;
  EXPECT_FALSE(stickslip::testing::is_valid(efast(64, 3, 1), why));
  EXPECT_NE(why.find("4 M^2 = 64"), std::string::npos) << why;
  EXPECT_THROW(ss::efast_design(efast(64, 3, 1), 1), std::invalid_argument);
}

TEST(EfastDesign, CurvesAreUniformAndReplicatesAreStable) {
  const auto s = efast(257, 3, 2);
  const auto x = ss::efast_design(s, 4);
  ASSERT_EQ(x.size(), 2u * 3u * 257u);
  for (const auto& row : x)
    for (double v : row) {
      EXPECT_GE(v, 0.0);
      EXPECT_LE(v, 1.0);
    }
  // Along its own curve a parameter's values are uniform: each tenth of [0, 1] gets ~ 1/10.
  std::vector<int> bins(10, 0);
  for (std::size_t k = 0; k < s.n; ++k) ++bins[std::min(9, static_cast<int>(x[s.run(1, 2, k)][2] * 10))];
  for (int b : bins) EXPECT_NEAR(b, 25.7, 6.0);
  // Replicate 0 does not depend on how many replicates follow.
  const auto one = ss::efast_design(efast(257, 3, 1), 4);
  for (std::size_t k = 0; k < one.size(); ++k) ASSERT_EQ(one[k], x[k]);
}

void check_efast_ishigami(std::size_t M, double tol_s1, double tol_st) {
  const auto s = efast(1025, 3, 8, M);
  const auto r = ss::efast_analysis(evaluate(ss::efast_design(s, 11), ishigami_unit), s, bootstrap(500));
  const auto ex = ss::ishigami_exact();
  ASSERT_TRUE(r.defined);
  const std::string tag = "efast ishigami n=1025 R=8 M=" + std::to_string(M);
  for (std::size_t i = 0; i < 3; ++i) {
    const std::string x = stickslip::testing::input_name(i);
    EXPECT_LE(report(tag, "S1 " + x, r.find("S1")->value[i], ex.S1[i]), tol_s1);
    EXPECT_LE(report(tag, "ST " + x, r.find("ST")->value[i], ex.ST[i]), tol_st);
    EXPECT_LE(r.find("S1")->ci[i].lo, r.find("S1")->value[i]);
    EXPECT_GE(r.find("ST")->ci[i].hi, r.find("ST")->value[i]);
  }
}

// Ishigami, n = 1025 points per curve, 8 replicates (24,600 runs). With M = 4 (SALib's default)
// x3's complementary frequency is omega_max / 8 = 16 and only its first 4 harmonics fall below
// omega_max / 2: the rest of x3^4's spectrum (a triangle wave raised to the 4th power) is counted
// as x2's, so ST_2 comes out 0.045 high and S1_3 0.023 high (the eFAST truncation, independent of
// n). Tolerances 0.03 (S1) and 0.05 (ST) there; with M = 8, 0.01 for both.
TEST(EfastAnalysis, IshigamiWithSalibsInterferenceFactor) { check_efast_ishigami(4, 0.03, 0.05); }
TEST(EfastAnalysis, IshigamiWithEightHarmonics) { check_efast_ishigami(8, 0.01, 0.01); }

// Sobol G (6 inputs), n = 1025, M = 4, 4 replicates: S1 and ST within 0.015 (observed 0.012 on
// S1_3; 10 % off is 0.077 there).
TEST(EfastAnalysis, SobolG) {
  const auto s = efast(1025, kGA.size(), 4);
  const auto r = ss::efast_analysis(evaluate(ss::efast_design(s, 5), g_unit), s, bootstrap(200));
  const auto ex = ss::sobol_g_exact(kGA);
  for (std::size_t i = 0; i < kGA.size(); ++i) {
    const std::string x = stickslip::testing::input_name(i);
    EXPECT_LE(report("efast G n=1025 R=4", "S1 " + x, r.find("S1")->value[i], ex.S1[i]), 0.015);
    EXPECT_LE(report("efast G n=1025 R=4", "ST " + x, r.find("ST")->value[i], ex.ST[i]), 0.015);
  }
}

TEST(EfastAnalysis, OneReplicateHasNoIntervalAndSaysWhy) {
  const auto s = efast(129, 3, 1);
  const auto r = ss::efast_analysis(evaluate(ss::efast_design(s, 1), ishigami_unit), s, bootstrap(50));
  EXPECT_TRUE(r.find("S1")->ci.empty());
  ASSERT_EQ(r.notes.size(), 1u);
  EXPECT_NE(r.notes[0].find("replicates >= 2"), std::string::npos);
  const auto c = ss::efast_analysis(std::vector<double>(s.runs(), 2.0), s, bootstrap(50));
  EXPECT_FALSE(c.defined);
}

TEST(RbdDesign, ColumnsArePermutationsOfOneTriangleWaveSample) {
  const auto x = ss::rbd_design(500, 3, 2);
  ASSERT_EQ(x.size(), 500u);
  std::vector<std::vector<double>> cols(3);
  for (const auto& row : x)
    for (std::size_t j = 0; j < 3; ++j) cols[j].push_back(row[j]);
  EXPECT_NE(cols[0], cols[1]);
  for (auto& c : cols) std::sort(c.begin(), c.end());
  EXPECT_EQ(cols[0], cols[1]);
  EXPECT_EQ(cols[1], cols[2]);
  EXPECT_GT(cols[0].front(), 0.0);
  EXPECT_LT(cols[0].back(), 1.0);
}

// RBD-FAST S1 of Ishigami at n = 10,000, both on the random balance design and on i.i.d. uniform
// points (given data): within 0.02.
TEST(RbdFastAnalysis, IshigamiOnItsDesignAndOnGivenData) {
  const auto ex = ss::ishigami_exact();
  const auto x = ss::rbd_design(10000, 3, 3);
  const auto r = ss::rbd_fast_analysis(x, evaluate(x, ishigami_unit), bootstrap(300));
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  ss::Matrix iid(10000, std::vector<double>(3));
  for (auto& row : iid)
    for (double& v : row) v = u(rng);
  const auto g = ss::rbd_fast_analysis(iid, evaluate(iid, ishigami_unit), bootstrap(300));
  for (std::size_t i = 0; i < 3; ++i) {
    const std::string x = "S1 x" + std::to_string(i + 1);
    EXPECT_LE(report("rbd-fast ishigami n=10000 rbd", x, r.find("S1")->value[i], ex.S1[i]), 0.02);
    EXPECT_LE(report("rbd-fast ishigami n=10000 iid", x, g.find("S1")->value[i], ex.S1[i]), 0.02);
    EXPECT_LE(g.find("S1")->ci[i].lo, ex.S1[i] + 0.02);
    EXPECT_GE(g.find("S1")->ci[i].hi, ex.S1[i] - 0.02);
  }
}

// RBD-FAST S1 of Sobol G (6 inputs), n = 10,000 random balance design points: within 0.02.
TEST(RbdFastAnalysis, SobolG) {
  const auto ex = ss::sobol_g_exact(kGA);
  const auto x = ss::rbd_design(10000, kGA.size(), 8);
  const auto r = ss::rbd_fast_analysis(x, evaluate(x, g_unit), bootstrap(200));
  for (std::size_t i = 0; i < kGA.size(); ++i)
    EXPECT_LE(report("rbd-fast G n=10000", "S1 x" + std::to_string(i + 1), r.find("S1")->value[i],
                     ex.S1[i]),
              0.02);
}

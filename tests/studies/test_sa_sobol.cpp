// Sobol indices from Saltelli designs (sa_sobol.h): the layouts and their nesting, agreement with
// the first-order estimator of sensitivity.h, S1/ST/S2 against the exact values of the Ishigami
// and Sobol G functions, undefined constant outputs, kept resamples and convergence prefixes.
#include "stickslip/studies/sa_sobol.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "stickslip/studies/sa_reference.h"
#include "support/sa_functions.h"

namespace {

namespace ss = stickslip::studies::sensitivity;
using stickslip::testing::evaluate;
using stickslip::testing::ishigami_unit;
using stickslip::testing::report;
using stickslip::testing::bootstrap;

ss::SaltelliShape shape(std::size_t n, std::size_t d, bool second, ss::SaltelliLayout layout) {
  ss::SaltelliShape s;
  s.n = n;
  s.d = d;
  s.second_order = second;
  s.layout = layout;
  return s;
}

const std::vector<double> kGA = {0.0, 0.5, 3.0, 9.0, 99.0};

}  // namespace

TEST(SaltelliRows, BlockLayoutIsSaltelliDesign) {
  EXPECT_EQ(ss::saltelli_rows(shape(64, 4, false, ss::SaltelliLayout::kBlocks), 9),
            ss::saltelli_design(64, 4, 9));
}

// The row layout is what lets a study grow: the runs of the first N base rows keep their indices
// and their points when N doubles, and the BA blocks mirror the AB blocks.
TEST(SaltelliRows, RowLayoutIsNestedWhenTheBaseSampleGrows) {
  const auto small = shape(64, 3, true, ss::SaltelliLayout::kRows);
  const auto large = shape(256, 3, true, ss::SaltelliLayout::kRows);
  const auto a = ss::saltelli_rows(small, 5), b = ss::saltelli_rows(large, 5);
  ASSERT_EQ(a.size(), 64u * 8u);
  ASSERT_EQ(b.size(), 256u * 8u);
  for (std::size_t k = 0; k < a.size(); ++k) ASSERT_EQ(a[k], b[k]) << "run " << k;
  for (std::size_t j = 0; j < 256; ++j)
    for (std::size_t i = 0; i < 3; ++i) {
      const auto& A = b[large.run(j, 0)];
      const auto& B = b[large.run(j, 1)];
      for (std::size_t k = 0; k < 3; ++k) {
        EXPECT_EQ(b[large.run(j, 2 + i)][k], k == i ? B[k] : A[k]);
        EXPECT_EQ(b[large.run(j, 5 + i)][k], k == i ? A[k] : B[k]);
      }
    }
}

TEST(SobolAnalysis, BothLayoutsGiveTheSameIndices) {
  const std::size_t n = 256, d = 3;
  const auto blocks = shape(n, d, true, ss::SaltelliLayout::kBlocks);
  const auto rows = shape(n, d, true, ss::SaltelliLayout::kRows);
  const auto a = ss::sobol_analysis(evaluate(ss::saltelli_rows(blocks, 2), ishigami_unit), blocks, bootstrap(100));
  const auto b = ss::sobol_analysis(evaluate(ss::saltelli_rows(rows, 2), ishigami_unit), rows, bootstrap(100));
  for (const char* name : {"S1", "ST"})
    for (std::size_t i = 0; i < d; ++i) {
      EXPECT_EQ(a.find(name)->value[i], b.find(name)->value[i]) << name << i;
      EXPECT_EQ(a.find(name)->ci[i].lo, b.find(name)->ci[i].lo) << name << i;
    }
  ASSERT_EQ(a.per_pair.size(), 1u);
  for (std::size_t p = 0; p < 3; ++p) EXPECT_EQ(a.per_pair[0].value[p], b.per_pair[0].value[p]);
}

// Ishigami at N = 8192 (second-order design: 65,536 runs). Tolerance 0.01 for every S1, ST and S2
// (observed: 0.0022 at most); an estimator off by 10 % misses S1_1, ST_1, S1_2, ST_2 or S13 by
// 0.024 to 0.056.
TEST(SobolAnalysis, IshigamiFirstTotalAndSecondOrder) {
  const std::size_t n = 8192, d = 3;
  const auto s = shape(n, d, true, ss::SaltelliLayout::kRows);
  const auto r = ss::sobol_analysis(evaluate(ss::saltelli_rows(s, 2024), ishigami_unit), s, bootstrap(200));
  const auto ex = ss::ishigami_exact();
  const auto s2 = ss::ishigami_second_order_exact();
  for (std::size_t i = 0; i < d; ++i) {
    const std::string x = stickslip::testing::input_name(i);
    EXPECT_LE(report("sobol ishigami N=8192", "S1 " + x, r.find("S1")->value[i], ex.S1[i]), 0.01);
    EXPECT_LE(report("sobol ishigami N=8192", "ST " + x, r.find("ST")->value[i], ex.ST[i]), 0.01);
  }
  ASSERT_EQ(r.pairs.size(), 3u);
  const char* names[] = {"S2 x1,x2", "S2 x1,x3", "S2 x2,x3"};
  for (std::size_t p = 0; p < 3; ++p)
    EXPECT_LE(report("sobol ishigami N=8192", names[p], r.per_pair[0].value[p], s2[p]), 0.01);
}

// Sobol G, a = (0, 0.5, 3, 9, 99), N = 8192: S1, ST and S2 within 0.005 (observed: 0.0004 at
// most; 10 % off is 0.059 on S1_1, 0.069 on ST_1 and 0.0087 on S2_12).
TEST(SobolAnalysis, SobolGFirstTotalAndSecondOrder) {
  const std::size_t n = 8192, d = kGA.size();
  const auto s = shape(n, d, true, ss::SaltelliLayout::kRows);
  const auto y = evaluate(ss::saltelli_rows(s, 77), [](const std::vector<double>& u) {
    return ss::sobol_g(u, kGA);
  });
  const auto r = ss::sobol_analysis(y, s, bootstrap(200));
  const auto ex = ss::sobol_g_exact(kGA);
  const auto s2 = ss::sobol_g_second_order_exact(kGA);
  for (std::size_t i = 0; i < d; ++i) {
    const std::string x = stickslip::testing::input_name(i);
    EXPECT_LE(report("sobol G N=8192", "S1 " + x, r.find("S1")->value[i], ex.S1[i]), 0.005);
    EXPECT_LE(report("sobol G N=8192", "ST " + x, r.find("ST")->value[i], ex.ST[i]), 0.005);
  }
  for (std::size_t p = 0; p < r.pairs.size(); ++p) {
    const std::string name = "S2 x" + std::to_string(r.pairs[p][0] + 1) + ",x" +
                             std::to_string(r.pairs[p][1] + 1);
    EXPECT_LE(report("sobol G N=8192", name, r.per_pair[0].value[p], s2[p]), 0.005);
  }
}

TEST(SobolAnalysis, ConstantOutputIsUndefinedNotZero) {
  const auto s = shape(32, 3, true, ss::SaltelliLayout::kRows);
  const std::vector<double> y(s.runs(), 0.1);
  const auto r = ss::sobol_analysis(y, s, bootstrap(50));
  EXPECT_FALSE(r.defined);
  EXPECT_NE(r.reason.find("constant"), std::string::npos) << r.reason;
  EXPECT_NE(r.reason.find("undefined"), std::string::npos) << r.reason;
  EXPECT_TRUE(r.per_parameter.empty());
  EXPECT_TRUE(r.per_pair.empty());
}

TEST(SobolAnalysis, KeepsTheResamplesOnRequest) {
  const auto s = shape(128, 3, false, ss::SaltelliLayout::kRows);
  const auto y = evaluate(ss::saltelli_rows(s, 3), ishigami_unit);
  ss::BootstrapOptions o = bootstrap(40, 8);
  EXPECT_TRUE(ss::sobol_analysis(y, s, o).find("S1")->resamples.empty());
  o.keep_resamples = true;
  const auto r = ss::sobol_analysis(y, s, o);
  const auto& st = *r.find("ST");
  ASSERT_EQ(st.resamples.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    ASSERT_EQ(st.resamples[i].size(), 40u);
    auto sorted = st.resamples[i];
    std::sort(sorted.begin(), sorted.end());
    EXPECT_GE(st.ci[i].lo, sorted.front());
    EXPECT_LE(st.ci[i].hi, sorted.back());
  }
}

TEST(SobolConvergence, PowerOfTwoPrefixesEqualSmallerDesignsAndNarrow) {
  EXPECT_EQ(ss::convergence_sizes(4096), (std::vector<std::size_t>{16, 32, 64, 128, 256, 512,
                                                                     1024, 2048, 4096}));
  EXPECT_EQ(ss::convergence_sizes(100, 16), (std::vector<std::size_t>{16, 32, 64, 100}));
  EXPECT_TRUE(ss::convergence_sizes(8, 16).empty());
  const auto big = shape(4096, 3, false, ss::SaltelliLayout::kRows);
  const auto y = evaluate(ss::saltelli_rows(big, 6), ishigami_unit);
  const auto steps = ss::sobol_convergence(y, big, bootstrap(200));
  ASSERT_EQ(steps.size(), 9u);
  // The N = 256 prefix is exactly the N = 256 study of the same seed.
  const auto small = shape(256, 3, false, ss::SaltelliLayout::kRows);
  const auto direct = ss::sobol_analysis(evaluate(ss::saltelli_rows(small, 6), ishigami_unit),
                                         small, bootstrap(200));
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(steps[4].indices.find("ST")->value[i], direct.find("ST")->value[i]);
    EXPECT_EQ(steps[4].indices.find("ST")->ci[i].hi, direct.find("ST")->ci[i].hi);
  }
  // Interval widths shrink like 1/sqrt(N): 16 times the points, about a quarter of the width.
  for (std::size_t i = 0; i < 3; ++i) {
    const auto& w256 = steps[4].indices.find("ST")->ci[i];
    const auto& w4096 = steps[8].indices.find("ST")->ci[i];
    std::printf("[sobol convergence] ST x%zu interval width N=256 %.4f, N=4096 %.4f\n", i + 1,
                w256.hi - w256.lo, w4096.hi - w4096.lo);
    EXPECT_LT(w4096.hi - w4096.lo, 0.5 * (w256.hi - w256.lo));
  }
}

TEST(SobolAnalysis, BadArgumentsNameTheProblem) {
  const auto s = shape(8, 2, false, ss::SaltelliLayout::kRows);
  const std::vector<double> y(s.runs(), 1.0);
  EXPECT_THROW(ss::sobol_analysis(std::vector<double>(5, 1.0), s, bootstrap(10)), std::invalid_argument);
  EXPECT_THROW(ss::sobol_analysis(y, s, bootstrap(10), 9), std::invalid_argument);
  EXPECT_THROW(ss::sobol_analysis(y, s, bootstrap(0)), std::invalid_argument);
  auto bad = y;
  bad[3] = std::nan("");
  try {
    ss::sobol_analysis(bad, s, bootstrap(10));
    FAIL() << "no throw";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("y[3]"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ss::saltelli_rows(shape(8, 2000, false, ss::SaltelliLayout::kRows), 1),
               std::invalid_argument);
}

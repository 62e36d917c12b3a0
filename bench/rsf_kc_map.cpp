// The rate-and-state critical-stiffness map (docs/img/rsf_kc_map.png): the stick-slip amplitude
// of the spring-slider (the seed's body and normal load, rate-and-state defaults) against the
// drive stiffness k_d / k_c(V) and the drive velocity V, for the aging and the slip law, with
// k_c(V) = F_N (b - a)/D_c (1 + m V^2 / (F_N a D_c)) (Rice & Ruina 1983; see
// tests/engine/test_model_rate_state.cpp). Each cell is one engine run from rest over ~150
// periods of the oscillation at k_c (the initial state is steady sliding at V, the run starts at
// rest: a large perturbation), judged over its last 30 %; the amplitude is max - min of F_d there
// (amplitude_raw), in units of the steady friction F_N mu_ss(V). The dashed line is the
// quasi-static k_c (without the inertial correction).
//
// Usage: rsf_kc_map [--out DIR] [--threads N]   (writes DIR/rsf_kc_map.{dat,gp,png}; DIR
//                                               defaults to docs/img of the source tree)
// Runs through the engine directly (the studies library does not list rate_state yet).
#include <omp.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "stickslip/common/gnuplot.h"
#include "stickslip/engine/params.h"
#include "stickslip/engine/simulate.h"

namespace {

using namespace stickslip::engine;

struct Cell {
  const char* law;
  double V, ratio;  // drive velocity [m/s], k_d / k_c(V) [-]
  double amplitude = std::nan(""), mu_ss = std::nan("");
  std::string status;
};

void run(Cell& cell) {
  SimConfig c = SimConfig::seed(model_kind<RateState>, 0.0);
  set_option(c, "law", cell.law);
  set_parameter(c, "V_init", cell.V);
  c.drive.v_d = cell.V;
  const double FN = c.drive.normal_load(), a = c.friction["a_rs"], b = c.friction["b_rs"];
  const double Dc = c.friction["D_c"], m = c.drive.m, V = cell.V;
  const double kc = FN * (b - a) / Dc * (1.0 + m * V * V / (FN * a * Dc));
  c.drive.k_d = cell.ratio * kc;
  // oscillation at k_c: omega^2 = k p / (m p + F_N a / V), p = V / D_c
  const double p = V / Dc, omega = std::sqrt(kc * p / (m * p + FN * a / V));
  const double period = 2 * M_PI / omega;
  c.stages = {Stage{150 * period, 0.0, 1500.0}};
  c.integrator.rtol = c.integrator.atol = 1e-6;
  c.integrator.dt_max = std::min(1e-3, period / 100);
  c.metrics.settle_fraction = 0.7;
  const SimResult r = simulate(c);
  cell.status = to_string(r.status);
  cell.mu_ss = c.friction["mu0"] + (a - b) * std::log(V / c.friction["V0"]);
  if (r.status == RunStatus::kOk) cell.amplitude = r.stages[0].amplitude_raw / (FN * cell.mu_ss);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"rate-and-state critical-stiffness map"};
  std::string out = std::string(STICKSLIP_SOURCE_DIR) + "/docs/img";
  int threads = 2;
  app.add_option("--out", out, "output directory");
  app.add_option("--threads", threads, "threads (at most 2 on the shared machine)");
  CLI11_PARSE(app, argc, argv);

  std::vector<Cell> cells;
  const std::vector<double> Vs = {1e-5, 2e-5, 5e-5, 1e-4, 2e-4, 5e-4, 1e-3, 2e-3, 5e-3};
  for (const char* law : {"aging", "slip"})
    for (double V : Vs)
      for (int i = 0; i <= 20; ++i)
        cells.push_back(Cell{law, V, 0.5 + 0.05 * i, std::nan(""), std::nan(""), {}});
#pragma omp parallel for schedule(dynamic) num_threads(threads)
  for (std::size_t i = 0; i < cells.size(); ++i) run(cells[i]);

  std::filesystem::create_directories(out);
  {
    std::ofstream dat(out + "/rsf_kc_map.dat");
    dat << "# law V[m/s] k_d/k_c amplitude/(F_N mu_ss) status\n";
    std::string law;
    double V = -1;
    for (const Cell& c : cells) {
      if (c.law != law) {
        if (!law.empty()) dat << "\n\n";  // a gnuplot data set per law
        law = c.law;
        V = -1;
      } else if (c.V != V) {
        dat << "\n";  // a scan line per V (pm3d)
      }
      V = c.V;
      char line[160];
      std::snprintf(line, sizeof line, "%s %g %.3f %.6g %s\n", c.law, c.V, c.ratio, c.amplitude,
                    c.status.c_str());
      dat << line;
    }
    // the quasi-static k_c on this axis: 1 / (1 + m V^2 / (F_N a D_c)) (data set 2)
    dat << "\n\n# V[m/s] k_c,quasi-static / k_c(V)\n";
    const SimConfig c0 = SimConfig::seed(model_kind<RateState>, 0.0);
    const double FN = c0.drive.normal_load(), a = c0.friction["a_rs"], Dc = c0.friction["D_c"];
    for (double V = 1e-5; V <= 5.01e-3; V *= 1.1) {
      char line[80];
      std::snprintf(line, sizeof line, "%.4g %g 0\n", 1.0 / (1.0 + c0.drive.m * V * V / (FN * a * Dc)), V);
      dat << line;
    }
  }
  {
    std::ofstream gp(out + "/rsf_kc_map.gp");
    gp << "# written by bench/rsf_kc_map (data: rsf_kc_map.dat)\n"
          "set terminal pngcairo size 1150,480 font ',10'\n"
          "set output 'rsf_kc_map.png'\n"
          "set multiplot layout 1,2 title 'Rate-and-state spring-slider: stick-slip amplitude "
          "(max - min F_d over the last 30 %) / (F_N mu_{ss}(V)), from rest'\n"
          "set logscale y\nset format y '10^{%L}'\nset xrange [0.475:1.525]\n"
          "set yrange [7e-6:7e-3]\n"
          "set xlabel 'k_d / k_c(V),   k_c = F_N (b - a)/D_c (1 + m V^2/(F_N a D_c))'\n"
          "set ylabel 'drive velocity V [m/s]'\n"
          "set cbrange [0:1.2]\nset palette defined (0 'white', 0.05 '#ffffcc', 0.4 '#fd8d3c', "
          "1.2 '#800026')\nset style fill solid noborder\n"
          "set arrow 1 from 1,7e-6 to 1,7e-3 nohead lc 'black' lw 2 front\n"
          "set key bottom left box opaque\n";
    for (int k = 0; k < 2; ++k)
      gp << "set title '" << (k ? "slip law" : "aging law") << "'\n"
         << (k ? "set cblabel 'amplitude / steady friction'\n" : "unset colorbox\n")
         << (k ? "set colorbox\n" : "")
         << "plot 'rsf_kc_map.dat' index " << k
         << " using 3:2:($3-0.025):($3+0.025):($2/1.41):($2*1.41):4 with boxxyerror fc palette "
            "notitle, 'rsf_kc_map.dat' index 2 using 1:2 with lines dt 2 lw 2 lc 'black' "
            "title 'quasi-static k_c', 1/0 with lines lw 2 lc 'black' title 'k_c(V)'\n";
    gp << "unset multiplot\n";
  }
  stickslip::common::GnuplotCall call;
  call.script = "rsf_kc_map.gp";
  call.workdir = out;
  const int status = stickslip::common::run_gnuplot(call);
  std::printf("wrote %s/rsf_kc_map.{dat,gp}; gnuplot exit status %d\n", out.c_str(), status);
  // the boundary per law and V: the smallest ratio without stick-slip (amplitude < 1e-3)
  for (const char* law : {"aging", "slip"})
    for (double V : Vs) {
      double first_steady = std::nan(""), last_sticking = std::nan("");
      for (const Cell& c : cells)
        if (c.law == std::string(law) && c.V == V) {
          if (c.amplitude >= 1e-3) last_sticking = c.ratio;
          if (c.amplitude < 1e-3 && std::isnan(first_steady)) first_steady = c.ratio;
        }
      std::printf("%s law, V = %g m/s: stick-slip up to k_d/k_c = %.2f, steady from %.2f\n", law,
                  V, last_sticking, first_steady);
    }
  return status == 0 ? 0 : 1;
}

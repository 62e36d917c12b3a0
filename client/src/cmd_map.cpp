// `stickslip map` and `stickslip rmse`: the stick-slip map and the RMSE table of a stored study.
#include <iostream>

#include "local_store.h"
#include "stickslip/client/cli.h"
#include "stickslip/studies/map.h"

namespace stickslip::client {
namespace {

struct MapArgs {
  std::string study, db, format = "table", out = "-", view = "amplitude", server;
};

int print_map(const MapArgs& a, bool rmse) {
  store::Store store = open_existing(a.db);
  const store::StudyRecord s = resolve_study(store, a.study);
  const studies::StudyMap map = studies::build_map(store, s.id);
  if (rmse) {
    bool any = false;
    for (const auto& row : map.rows)
      for (const auto& c : row.cells) any = any || c.rmse.has_value();
    if (!any)
      std::cerr << "stickslip rmse: study " << s.id
                << " has no RMSE values (does its spec name a measured dataset whose conditions "
                   "match its runs?)\n";
  }
  std::string text;
  if (a.format == "json") text = studies::map_to_json(map).dump(2) + "\n";
  else if (a.format == "csv") text = studies::map_to_csv(map);
  else {
    const studies::MapView view = rmse                  ? studies::MapView::kRmse
                                  : a.view == "mean_force" ? studies::MapView::kMeanForce
                                                           : studies::MapView::kAmplitude;
    text = studies::map_to_table(map, view);
  }
  write_output(a.out, text);
  if (a.out != "-") std::cerr << "wrote " << a.out << "\n";
  return kOk;
}

void add_map_like(CLI::App& app, int& exit_code, const char* name, const char* help, bool rmse) {
  auto a = std::make_shared<MapArgs>();
  CLI::App* cmd = app.add_subcommand(name, help);
  cmd->add_option("study", a->study, "study id or name (newest of that name)")->required();
  add_db_option(cmd, a->db);
  cmd->add_option("--format", a->format, "table (readable), csv or json")
      ->check(CLI::IsMember({"table", "csv", "json"}))
      ->capture_default_str();
  cmd->add_option("--out", a->out, "output file, - for stdout")->capture_default_str();
  if (!rmse) {
    cmd->add_option("--view", a->view, "table view: amplitude or mean_force")
        ->check(CLI::IsMember({"amplitude", "mean_force"}))
        ->capture_default_str();
    // With --server the map comes from stickslipd (GET /v1/studies/{id}/map) instead of --db.
    cmd->add_option("--server", a->server,
                    "read the study (by id) from this stickslipd URL instead of --db "
                    "(token: $STICKSLIP_TOKEN)")
        ->excludes(cmd->get_option("--db"));
  }
  cmd->callback([a, rmse, name, &exit_code] {
    if (!a->server.empty()) {
      exit_code = remote_map(a->server, a->study, a->format, a->out, a->view);
      return;
    }
    exit_code = guarded(name, [&] { return print_map(*a, rmse); });
  });
}

}  // namespace

void add_map_command(CLI::App& app, int& exit_code) {
  add_map_like(app, exit_code, "map",
               "Stick-slip amplitude per stage, mean force and the reduction ratio against "
               "va_over_vd (rows), one column per model; missing and failed cells are marked",
               false);
  add_map_like(app, exit_code, "rmse",
               "RMSE of F_d against the study's measured data (eq. 23 of the seed), whole run and "
               "per stage, one column per model (the seed's Table 2)",
               true);
}

}  // namespace stickslip::client

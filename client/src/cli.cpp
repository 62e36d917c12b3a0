#include "stickslip/client/cli.h"

#include <iostream>

#include "diagnose_remote.h"

namespace stickslip::client {

int run(int argc, char** argv, std::shared_ptr<studies::Executor> mpi) {
  CLI::App app{"stickslip: stick-slip friction under longitudinal vibration (seed: Rybkiewicz & "
               "Leus). SI units throughout."};
  app.require_subcommand(1);
  int exit_code = kOk;
  add_simulate_command(app, exit_code);
  add_synth_command(app, exit_code);
  add_diagnose_command(app, exit_code);
  add_diagnosis_command(app, exit_code);
  add_validate_command(app, exit_code);
  add_table_command(app, exit_code);
  add_study_command(app, exit_code, mpi);
  add_store_command(app, exit_code);
  add_remote_commands(app, exit_code);
  add_map_command(app, exit_code);
  add_indices_command(app, exit_code);
  add_report_command(app, exit_code, mpi);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return kBadInput;
  } catch (const std::exception& e) {
    std::cerr << "stickslip: " << e.what() << "\n";
    return kFailure;
  }
  return exit_code;
}

}  // namespace stickslip::client

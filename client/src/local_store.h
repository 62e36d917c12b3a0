#pragma once
// Shared pieces of the commands that work on a local store (`study`, `map`, `rmse`).
#include <filesystem>
#include <functional>
#include <iosfwd>
#include <string>

#include <CLI/CLI.hpp>

#include "stickslip/store/store.h"

namespace stickslip::client {

/// The default database: $STICKSLIP_DB if set, else ./stickslip.db (documented in README).
std::string default_db_path();
/// Adds --db with that default to cmd.
void add_db_option(CLI::App* cmd, std::string& db);

/// Opens an existing database read-only; throws StoreError naming the path.
store::Store open_existing(const std::string& db);

/// A study given by id, or by name (the newest study of that name). Throws std::invalid_argument
/// naming what was looked for when there is none.
store::StudyRecord resolve_study(store::Store& store, const std::string& id_or_name);

/// Writes text to path ("-" = stdout); throws std::runtime_error naming the path on failure.
void write_output(const std::string& path, const std::string& text);

/// Runs f and turns failures into exit codes with a message "stickslip <what>: ...": StoreError
/// and std::invalid_argument (bad database, unknown study) are bad input (2), the rest 1.
int guarded(const char* what, const std::function<int()>& f);

/// A progress bar on a terminal (redrawn in place) or plain lines every 10 % otherwise.
class ProgressPrinter {
 public:
  explicit ProgressPrinter(std::ostream& out);
  void update(long long done, long long failed, long long total);
  void finish();

 private:
  std::ostream& out_;
  bool tty_;
  int last_decile_ = -1;
  long long last_done_ = -1;
};

}  // namespace stickslip::client

#include "local_store.h"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <stdexcept>

#include "stickslip/client/cli.h"

namespace stickslip::client {

std::string default_db_path() {
  const char* env = std::getenv("STICKSLIP_DB");
  return env != nullptr && *env != '\0' ? std::string(env) : std::string("stickslip.db");
}

void add_db_option(CLI::App* cmd, std::string& db) {
  db = default_db_path();
  cmd->add_option("--db", db, "SQLite database (default: $STICKSLIP_DB, else ./stickslip.db)")
      ->capture_default_str();
}

store::Store open_existing(const std::string& db) {
  if (!std::filesystem::exists(db))
    throw store::StoreError("database '" + db + "' does not exist (set --db or STICKSLIP_DB)");
  return store::Store::open(db, store::Store::Mode::kReadOnly);
}

store::StudyRecord resolve_study(store::Store& store, const std::string& id_or_name) {
  if (auto s = store.get_study(id_or_name)) return *s;
  const auto newest = store.find_newest_by_name(id_or_name);
  if (!newest)
    throw std::invalid_argument("no study with id or name '" + id_or_name + "' in " +
                                store.path().string());
  return *newest;
}

void write_output(const std::string& path, const std::string& text) {
  if (path == "-") {
    std::cout << text;
    return;
  }
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw std::runtime_error("cannot write '" + path + "'");
  out << text;
  if (!out.flush()) throw std::runtime_error("error while writing '" + path + "'");
}

int guarded(const char* what, const std::function<int()>& f) {
  try {
    return f();
  } catch (const store::StoreError& e) {
    std::cerr << "stickslip " << what << ": " << e.what() << "\n";
    return kBadInput;
  } catch (const std::invalid_argument& e) {
    std::cerr << "stickslip " << what << ": " << e.what() << "\n";
    return kBadInput;
  } catch (const std::exception& e) {
    std::cerr << "stickslip " << what << ": " << e.what() << "\n";
    return kFailure;
  }
}

ProgressPrinter::ProgressPrinter(std::ostream& out)
    : out_(out), tty_(&out == &std::cerr ? isatty(2) != 0 : isatty(1) != 0) {}

void ProgressPrinter::update(long long done, long long failed, long long total) {
  if (done == last_done_) return;
  last_done_ = done;
  const double frac = total > 0 ? static_cast<double>(done) / static_cast<double>(total) : 1.0;
  if (tty_) {
    constexpr int kWidth = 40;
    const int fill = static_cast<int>(frac * kWidth + 0.5);
    out_ << "\r[" << std::string(fill, '#') << std::string(kWidth - fill, '.') << "] " << done
         << "/" << total << " runs, " << failed << " failed" << std::flush;
  } else {
    const int decile = static_cast<int>(frac * 10);
    if (decile == last_decile_) return;
    last_decile_ = decile;
    out_ << "progress: " << done << "/" << total << " runs done, " << failed << " failed\n"
         << std::flush;
  }
}

void ProgressPrinter::finish() {
  if (tty_ && last_done_ >= 0) out_ << "\n" << std::flush;
}

}  // namespace stickslip::client

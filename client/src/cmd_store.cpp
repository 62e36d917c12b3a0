// `stickslip store check DB`: the full check of a store file (docs/store.md, Damage). Read-only:
// safe on a store that a server is writing to.
#include <cstdio>
#include <iostream>

#include "local_store.h"
#include "stickslip/client/cli.h"
#include "stickslip/store/store.h"
#include "stickslip/store/writer_lock.h"

namespace stickslip::client {
namespace {

int store_check(const std::string& db) {
  if (!std::filesystem::exists(db))
    throw store::StoreError("database '" + db + "' does not exist (set --db or STICKSLIP_DB)");
  const store::StoreCheck check = store::check_store(db);
  if (const auto holder = store::WriterLock::holder(db))
    std::printf("writer: %s\n", holder->describe().c_str());
  for (const auto& p : check.problems) std::printf("integrity_check: %s\n", p.c_str());
  if (check.foreign_key_violations > 0)
    std::printf("foreign_key_check: %lld rows refer to missing rows\n",
                static_cast<long long>(check.foreign_key_violations));
  if (check.ok()) {
    std::printf("%s: ok (PRAGMA integrity_check and foreign_key_check)\n", db.c_str());
    return kOk;
  }
  std::fprintf(stderr,
               "stickslip store check: %s is damaged; restore it from a backup (or try `sqlite3 "
               "%s .recover`); a server refuses to write to it\n",
               db.c_str(), db.c_str());
  return kFailure;
}

}  // namespace

void add_store_command(CLI::App& app, int& exit_code) {
  CLI::App* st = app.add_subcommand("store", "Check a local SQLite store");
  st->require_subcommand(1);
  auto db = std::make_shared<std::string>();
  CLI::App* check = st->add_subcommand(
      "check", "Full PRAGMA integrity_check and foreign_key_check of DB, read-only (safe while a "
               "server writes to it). Exit 0: ok, 1: damaged, 2: not a stickslip store");
  check->add_option("db", *db, "the store file")->required();
  check->callback([db, &exit_code] {
    exit_code = guarded("store check", [&] { return store_check(*db); });
  });
}

}  // namespace stickslip::client

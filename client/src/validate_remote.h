#pragma once
// `stickslip validate DIAGNOSIS.json MANIFEST --server URL` (private to the client): submits the
// diagnosis document, the manifest and its CSV contents as a validation job (POST
// /v1/validations) and, with --wait, writes what `stickslip validate --out DIR` writes.
#include <string>

namespace stickslip::client {

struct RemoteValidateArgs {
  std::string server;           ///< stickslipd URL
  std::string diagnosis;        ///< diagnosis.json file
  std::string manifest;         ///< manifest file; its CSVs are read relative to it
  std::string idempotency_key;  ///< "" = none
  std::string out;              ///< with wait: DIR/validation.json and DIR/<run>.csv; "" = none
  bool wait = false;
  bool json_output = false;
  bool quiet = false;
};

/// Submits (and with wait, waits for) a validation; returns the exit code.
int remote_validate(const RemoteValidateArgs& args);

}  // namespace stickslip::client

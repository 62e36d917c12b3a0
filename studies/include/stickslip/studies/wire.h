#pragma once
// What the processes of a distributed study send each other (docs/scale.md, "Messages"): a
// study task (what to compute) and finished runs, as MessagePack through nlohmann_json (a
// binary form that keeps every double bit for bit, NaN and infinities included). The MPI ranks
// exchange these as MPI_BYTE messages; a launched job's rank 0 streams them on its standard
// output as frames (launcher.h). Neither is a network protocol of our own: MPI and the
// launcher's standard streams carry the bytes.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "stickslip/measured/measured.h"
#include "stickslip/store/store.h"
#include "stickslip/studies/spec.h"

namespace stickslip::studies::wire {

using Bytes = std::vector<std::uint8_t>;

/// Malformed bytes, or a task this process cannot rebuild; the message says which.
class WireError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A study as another process needs it to compute some of its runs.
struct Task {
  std::string study_id;
  std::string spec_json;  ///< the canonical spec (StudySpec::canonical_json())
  Limits limits;          ///< the limits the spec was accepted under
  std::string spec_dir;   ///< absolute; a relative measured path is resolved against it
  std::vector<std::size_t> pending;  ///< the runs to compute (empty for an MPI worker)
  int threads = 0;                   ///< OpenMP threads per process; 0 = OpenMP's default
  double chunk_deadline_s = 0;       ///< ComputeRequest::chunk_deadline_s
};

Bytes encode_task(const Task& task);
Task decode_task(const std::uint8_t* data, std::size_t size);

/// The spec and measured data of a task, rebuilt in this process.
struct LoadedTask {
  StudySpec spec;
  std::optional<measured::MeasuredDataset> measured;
};
/// Parses the spec under the task's limits (its canonical form must come back unchanged, so
/// every process enumerates the same design) and loads the measured data it names. Throws
/// WireError naming the problem.
LoadedTask load_task(const Task& task);

/// Finished runs (their study_id is not sent: the receiver knows its study).
Bytes encode_runs(const std::vector<store::RunRecord>& runs);
std::vector<store::RunRecord> decode_runs(const std::uint8_t* data, std::size_t size,
                                          const std::string& study_id);

/// A MessagePack document (a frame of the launcher stream); throws WireError when malformed.
nlohmann::json decode_json(const std::uint8_t* data, std::size_t size);

}  // namespace stickslip::studies::wire

#pragma once
// Point-to-point helpers of the master and the workers (protocol.h). Waiting is a probe loop
// with short sleeps, not a blocking receive: Open MPI's blocking calls spin a core at 100 %,
// and rank 0 usually shares its node's cores with a worker.
#include <mpi.h>

#include <chrono>
#include <cstdint>
#include <list>
#include <vector>

namespace stickslip::mpi::detail {

/// Sleeps 20 us, doubling to 2 ms, between unsuccessful probes; reset() after a message.
class Backoff {
 public:
  void sleep();
  void reset() { wait_ = std::chrono::microseconds(20); }

 private:
  std::chrono::microseconds wait_{20};
};

/// One probe for a message from source (MPI_ANY_SOURCE: any) with any tag.
bool probe(int source, MPI_Status* status);
/// Probes until a message from source arrives.
MPI_Status wait_probe(int source);

/// Receives the probed message.
std::vector<std::uint8_t> recv_bytes(const MPI_Status& status);
std::vector<std::int64_t> recv_int64(const MPI_Status& status);

/// Non-blocking sends that own their buffers until MPI is done with them, so that a peer that
/// hung never blocks the sender.
class Sends {
 public:
  ~Sends();  ///< a send still pending (its peer hung) is released, its buffer left allocated
  void bytes(std::vector<std::uint8_t> data, int dest, int tag);
  void int64(std::vector<std::int64_t> data, int dest, int tag);
  /// Completes the sends that are done; returns how many are still pending.
  std::size_t progress();

 private:
  struct Pending {
    std::vector<std::uint8_t> bytes;
    std::vector<std::int64_t> ints;
    MPI_Request request = MPI_REQUEST_NULL;
  };
  std::list<Pending> pending_;
};

}  // namespace stickslip::mpi::detail

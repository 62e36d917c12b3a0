// Point-to-point helpers (transport.h).
#include "transport.h"

#include <algorithm>
#include <thread>

namespace stickslip::mpi::detail {

void Backoff::sleep() {
  std::this_thread::sleep_for(wait_);
  wait_ = std::min(wait_ * 2, std::chrono::microseconds(2000));
}

bool probe(int source, MPI_Status* status) {
  int flag = 0;
  MPI_Iprobe(source, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, status);
  return flag != 0;
}

MPI_Status wait_probe(int source) {
  MPI_Status st;
  Backoff backoff;
  while (!probe(source, &st)) backoff.sleep();
  return st;
}

std::vector<std::uint8_t> recv_bytes(const MPI_Status& st) {
  int n = 0;
  MPI_Get_count(&st, MPI_BYTE, &n);
  std::vector<std::uint8_t> out(static_cast<std::size_t>(n));
  MPI_Recv(out.data(), n, MPI_BYTE, st.MPI_SOURCE, st.MPI_TAG, MPI_COMM_WORLD,
           MPI_STATUS_IGNORE);
  return out;
}

std::vector<std::int64_t> recv_int64(const MPI_Status& st) {
  int n = 0;
  MPI_Get_count(&st, MPI_INT64_T, &n);
  std::vector<std::int64_t> out(static_cast<std::size_t>(std::max(n, 0)));
  MPI_Recv(out.data(), n, MPI_INT64_T, st.MPI_SOURCE, st.MPI_TAG, MPI_COMM_WORLD,
           MPI_STATUS_IGNORE);
  return out;
}

Sends::~Sends() {
  if (progress() == 0) return;
  // A peer never took these (it hung or died, and the job is about to be aborted): MPI may
  // still read the buffers, so they are deliberately left allocated.
  for (Pending& p : pending_) MPI_Request_free(&p.request);
  new std::list<Pending>(std::move(pending_));
}

void Sends::bytes(std::vector<std::uint8_t> data, int dest, int tag) {
  Pending& p = pending_.emplace_back();
  p.bytes = std::move(data);
  MPI_Isend(p.bytes.data(), static_cast<int>(p.bytes.size()), MPI_BYTE, dest, tag,
            MPI_COMM_WORLD, &p.request);
}

void Sends::int64(std::vector<std::int64_t> data, int dest, int tag) {
  Pending& p = pending_.emplace_back();
  p.ints = std::move(data);
  MPI_Isend(p.ints.data(), static_cast<int>(p.ints.size()), MPI_INT64_T, dest, tag,
            MPI_COMM_WORLD, &p.request);
}

std::size_t Sends::progress() {
  for (auto it = pending_.begin(); it != pending_.end();) {
    int done = 0;
    MPI_Test(&it->request, &done, MPI_STATUS_IGNORE);
    it = done ? pending_.erase(it) : std::next(it);
  }
  return pending_.size();
}

}  // namespace stickslip::mpi::detail

// MPI start-up and shutdown of a stickslip process (session.h).
#include "stickslip/mpi/session.h"

#include <mpi.h>
#include <unistd.h>

#include <cstdlib>
#include <stdexcept>
#include <thread>

#include "master.h"
#include "stickslip/mpi/protocol.h"

namespace stickslip::mpi {

bool launched_by_mpi() {
  for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "PMI_SIZE"})
    if (std::getenv(v) != nullptr) return true;
  return false;
}

std::unique_ptr<Session> Session::start_if_launched(int* argc, char*** argv) {
  if (!launched_by_mpi()) return nullptr;
  int provided = 0;
  MPI_Init_thread(argc, argv, MPI_THREAD_SERIALIZED, &provided);
  if (provided < MPI_THREAD_SERIALIZED) {
    MPI_Finalize();
    throw std::runtime_error("the MPI library does not support MPI_THREAD_SERIALIZED (got " +
                             std::to_string(provided) + ")");
  }
  int rank = 0, size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  return std::unique_ptr<Session>(new Session(rank, size));
}

Session::Session(int rank, int size) : rank_(rank), size_(size) {}

Session::~Session() {
  if (!finished_) finish(0);
}

std::shared_ptr<studies::Executor> Session::executor(studies::ChunkOptions chunks) {
  if (rank_ != 0 || size_ < 2) return nullptr;
  return std::make_shared<detail::MasterExecutor>(size_ - 1, chunks, broken_);
}

int Session::finish(int exit_code) {
  if (finished_) return exit_code;
  finished_ = true;
  if (rank_ == 0 && broken_->load()) {
    // A rank hung or was lost: no clean shutdown is possible. Give the launcher a moment to
    // forward what rank 0 wrote last (its error), then end every rank.
    std::fflush(nullptr);
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    MPI_Abort(MPI_COMM_WORLD, exit_code != 0 ? exit_code : 1);
  }
  if (rank_ == 0)
    for (int w = 1; w < size_; ++w)
      MPI_Send(nullptr, 0, MPI_BYTE, w, kTagShutdown, MPI_COMM_WORLD);
  MPI_Finalize();
  return exit_code;
}

}  // namespace stickslip::mpi

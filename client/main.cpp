// stickslip: thin main. Started by an MPI launcher (mpirun, srun), every rank comes here:
// rank 0 runs the command with the MPI master as its studies' backend, the other ranks serve
// it (stickslip/mpi/session.h, docs/scale.md).
#include <cstdlib>
#include <iostream>

#include "stickslip/client/cli.h"
#ifdef STICKSLIP_HAVE_MPI
#include "stickslip/mpi/session.h"
#endif

int main(int argc, char** argv) {
#ifdef STICKSLIP_HAVE_MPI
  std::unique_ptr<stickslip::mpi::Session> session;
  try {
    session = stickslip::mpi::Session::start_if_launched(&argc, &argv);
  } catch (const std::exception& e) {
    std::cerr << "stickslip: MPI: " << e.what() << "\n";
    return 1;
  }
  if (session && session->rank() > 0) return session->serve();
  const int code = stickslip::client::run(argc, argv, session ? session->executor() : nullptr);
  return session ? session->finish(code) : code;
#else
  for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK"})
    if (std::getenv(v) != nullptr) {
      std::cerr << "stickslip: started by an MPI launcher, but this stickslip was built without "
                   "MPI (install libopenmpi-dev and rebuild; see README)\n";
      return 2;
    }
  return stickslip::client::run(argc, argv);
#endif
}

// Test-only fault injection for the MPI tests (never built into stickslip, never preloaded by
// it): a library that the tests preload into the ranks of an MPI job (mpirun -x LD_PRELOAD=...)
// and that wraps MPI_Recv through MPI's standard profiling interface (PMPI_Recv).
//
//   STICKSLIP_MPI_FAULT="rank=K,chunk=J,action=kill|hang|exit[,once=PATH]"
//
// makes rank K, as it receives its J-th chunk of runs (tag kTagChunk, counted from 1), die by
// SIGKILL (a lost rank), stop forever without answering (a hung rank), or exit with status 3.
// With once=PATH the fault fires only while PATH does not exist, and creates it: the job that
// is started again after the fault runs clean. Without the variable the wrapper only forwards.
#include <fcntl.h>
#include <mpi.h>
#include <signal.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "stickslip/mpi/protocol.h"

namespace {

struct Fault {
  int rank = -1, chunk = 0;
  std::string action, once;
};

Fault parse_fault() {
  Fault f;
  const char* text = std::getenv("STICKSLIP_MPI_FAULT");
  if (text == nullptr) return f;
  std::string s = text;
  for (std::size_t a = 0; a < s.size();) {
    const std::size_t b = std::min(s.find(',', a), s.size());
    const std::string item = s.substr(a, b - a);
    const std::size_t eq = item.find('=');
    const std::string key = item.substr(0, eq), value = eq == std::string::npos ? "" : item.substr(eq + 1);
    if (key == "rank") f.rank = std::atoi(value.c_str());
    if (key == "chunk") f.chunk = std::atoi(value.c_str());
    if (key == "action") f.action = value;
    if (key == "once") f.once = value;
    a = b + 1;
  }
  return f;
}

void fire(const Fault& f, int rank) {
  if (!f.once.empty()) {
    const int fd = ::open(f.once.c_str(), O_CREAT | O_EXCL | O_WRONLY, 0644);
    if (fd < 0) return;  // fired before
    ::close(fd);
  }
  std::fprintf(stderr, "fault_rank_preload: rank %d: %s at chunk %d\n", rank, f.action.c_str(),
               f.chunk);
  std::fflush(stderr);
  if (f.action == "kill") ::raise(SIGKILL);
  if (f.action == "exit") std::_Exit(3);
  if (f.action == "hang")
    while (true) ::pause();
}

}  // namespace

extern "C" int MPI_Recv(void* buf, int count, MPI_Datatype type, int source, int tag,
                        MPI_Comm comm, MPI_Status* status) {
  const int rc = PMPI_Recv(buf, count, type, source, tag, comm, status);
  if (tag != stickslip::mpi::kTagChunk) return rc;
  static const Fault fault = parse_fault();
  static int chunks = 0;
  if (fault.rank < 0) return rc;
  int rank = -1;
  PMPI_Comm_rank(MPI_COMM_WORLD, &rank);
  if (rank == fault.rank && ++chunks == fault.chunk) fire(fault, rank);
  return rc;
}

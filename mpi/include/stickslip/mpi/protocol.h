#pragma once
// The messages between rank 0 (the dedicated master) and the worker ranks of a stickslip MPI
// job (docs/scale.md, "Messages"): plain MPI point-to-point messages on MPI_COMM_WORLD, each
// tag one kind. Bodies are MPI_BYTE (wire.h MessagePack) or MPI_INT64_T arrays.
//
//   rank 0 -> worker                         worker -> rank 0
//   kTagBegin     a study (wire::Task)       kTagReady   its OpenMP threads (1 int64)
//   kTagChunk     jobs: n, then per job its  kTagRuns    the chunk's runs (wire runs); it
//                 run count and indices                  also asks for the next chunk
//   kTagEnd       no more chunks (empty)     kTagFailed  it cannot compute the study (text)
//   kTagShutdown  the session ends (empty)
//
// Per study: rank 0 sends kTagBegin to every worker; each answers kTagReady; rank 0 answers
// every kTagReady and kTagRuns with the next kTagChunk, or kTagEnd once nothing is left (or a
// stop was asked). At the end of the session, kTagShutdown.

namespace stickslip::mpi {

enum Tag : int {
  kTagBegin = 101,
  kTagReady = 102,
  kTagChunk = 103,
  kTagRuns = 104,
  kTagEnd = 105,
  kTagFailed = 106,
  kTagShutdown = 107,
};

}  // namespace stickslip::mpi

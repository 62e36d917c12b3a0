#pragma once
// Internal: one chunk of a batch (up to kBatchMaxLanes lanes) and the entry point of the batched
// kernels (batch_kernels.cpp, built with the vector flags).
#include <array>

#include "stickslip/engine/batch.h"

namespace stickslip::engine::detail {

/// One chunk: lanes [0, lanes) are real; the kernel pads the rest with copies of lane 0.
struct ChunkIO {
  std::array<const SimConfig*, kBatchMaxLanes> cfg{};
  std::array<SimResult*, kBatchMaxLanes> out{};
  int lanes = 0;
};

/// Lanes per chunk of every batched kernel.
inline constexpr int kBatchLanes = 16;

/// Runs one chunk with the batched kernel of model kind (whose lanes are valid and compatible).
void run_batched_chunk(ModelKind kind, const ChunkIO& io);

}  // namespace stickslip::engine::detail

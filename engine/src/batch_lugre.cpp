// Batched RK4 for LuGre. The Stribeck exp is exp_vectorizable (exp.h), so the whole lane loop
// vectorises without -ffast-math.
#include "batch_kernel.h"

namespace stickslip::engine::detail {

void run_chunk_lugre(const ChunkIO& io) {
  run_chunk<LuGre, kLanesLuGre>(io, [](const SimConfig& c) { return LuGre(c.friction); });
}

}  // namespace stickslip::engine::detail

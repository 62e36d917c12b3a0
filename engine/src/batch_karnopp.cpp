// Batched RK4 for Karnopp. Karnopp::operator() selects between the stick band and slip without
// branches (models.h), so the lane loop vectorises.
#include "batch_kernel.h"

namespace stickslip::engine::detail {

void run_chunk_karnopp(const ChunkIO& io) {
  run_chunk<Karnopp, kLanesKarnopp>(io, [](const SimConfig& c) { return Karnopp(c.friction); });
}

}  // namespace stickslip::engine::detail

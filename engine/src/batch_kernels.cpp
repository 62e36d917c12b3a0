// The batched kernels of every registered model (run_chunk_of<M>, batch_kernel.h), in one
// translation unit built with the vector flags (engine/CMakeLists.txt).
#include <stdexcept>
#include <type_traits>

#include "batch_kernel.h"

namespace stickslip::engine::detail {

void run_batched_chunk(ModelKind kind, const ChunkIO& io) {
  visit_model(kind, [&]<class M>(std::type_identity<M>) {
    if constexpr (M::kInfo.scalar_only == nullptr)
      run_chunk_of<M>(io);
    else  // batch_compatible refuses such batches
      throw std::logic_error(std::string("no batched kernel for model ") + M::kInfo.name);
  });
}

}  // namespace stickslip::engine::detail

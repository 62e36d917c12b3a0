#include "stickslip/server/api.h"
#include "stickslip/server/openapi_data.h"

namespace stickslip::server {

std::string_view openapi_text() noexcept { return generated::kOpenApiJson; }

}  // namespace stickslip::server

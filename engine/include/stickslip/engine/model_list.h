#pragma once
// THE list of friction models. Adding a model: its header (models/<name>.h, see docs/engine.md
// "Adding a friction model"), its #include here and its name in FrictionModels. Everything else
// (ids, parameters, dispatch, schema, CLI flags, diagnosis specs, typed tests) derives from it.
// The order is the order in which the CLI, the schemas and the diagnosis list the models.
#include "stickslip/engine/models/dahl.h"
#include "stickslip/engine/models/elasto_plastic.h"
#include "stickslip/engine/models/gms.h"
#include "stickslip/engine/models/karnopp.h"
#include "stickslip/engine/models/lugre.h"
#include "stickslip/engine/models/rate_state.h"
#include "stickslip/engine/models/reset_integrator.h"

namespace stickslip::engine {

template <class... Models>
struct ModelList {};

using FrictionModels = ModelList<Dahl, Karnopp, ResetIntegrator, LuGre, ElastoPlastic, RateState, Gms>;

}  // namespace stickslip::engine

// The friction models as the server knows them: the study schema it serves (GET
// /v1/study.schema.json) is filled from the engine's model registry, so its base.model enum
// lists every registered model, in the registry's order, then the analytic test functions.
// Nothing in the dashboard names a friction model itself.
import { api } from "./api.js";

const ANALYTIC = new Set(["ishigami", "sobol_g"]);

/** The friction-model ids of a study schema, in the registry's order. */
export function modelsOf(schema) {
  const model = ((((schema || {}).$defs || {}).base || {}).properties || {}).model || {};
  return (model.enum || []).filter((m) => !ANALYTIC.has(m));
}

let pending = null;

/** The friction-model ids (fetched once; [] when the schema cannot be read). */
export function frictionModels() {
  if (!pending)
    pending = api
      .get("/v1/study.schema.json")
      .then(modelsOf)
      .catch(() => {
        pending = null;
        return [];
      });
  return pending;
}

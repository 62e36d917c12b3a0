// Batched mode: compatibility checks, per-lane validation, and chunking into SIMD kernels.
#include "stickslip/engine/batch.h"
#include "stickslip/engine/extensions.h"

#include <cstdio>
#include <optional>

#include "batch_chunk.h"

namespace stickslip::engine {
namespace {

std::string lane_why(std::size_t i, std::size_t r, const std::string& ref_value,
                     const char* what) {
  return "lane " + std::to_string(i) + " differs from lane " + std::to_string(r) + " (" +
         ref_value + "): " + what;
}

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.12g", v);
  return buf;
}

/// The first incompatibility of the batch (lanes that are invalid on their own are skipped).
std::optional<InvalidParameter> incompatibility(const std::vector<SimConfig>& cfgs) {
  std::optional<std::size_t> ref_index;
  for (std::size_t i = 0; i < cfgs.size(); ++i) {
    const SimConfig& c = cfgs[i];
    if (!c.IsValid()) continue;
    if (c.integrator.kind != IntegratorKind::kRk4)
      return InvalidParameter("integrator", to_string(c.integrator.kind),
                              "lane " + std::to_string(i) +
                                  ": batch mode runs the fixed-step rk4 integrator only");
    if (c.trace.rate > 0)
      return InvalidParameter("trace.rate", c.trace.rate,
                              "lane " + std::to_string(i) +
                                  ": batch mode records no traces (use simulate())");
    if (c.extension.active())
      return InvalidParameter("effect", to_string(c.extension.kind),
                              "lane " + std::to_string(i) +
                                  ": batch mode runs the base models only, without a catalogue "
                                  "extension (use simulate())");
    if (const char* why = model_traits(c.model).info->scalar_only)
      return InvalidParameter("model", to_string(c.model),
                              "lane " + std::to_string(i) + ": no batched kernel (" + why +
                                  "); run it with simulate()");
    if (!ref_index) {
      ref_index = i;
      continue;
    }
    const std::size_t r = *ref_index;
    const SimConfig& a = cfgs[r];
    const char* grid = "a batch shares the model, time grid and base motion";
    if (c.model != a.model)
      return InvalidParameter("model", to_string(c.model),
                              lane_why(i, r, to_string(a.model), grid));
    if constexpr (!kFrictionOptions.empty()) {
      for (std::size_t k = 0; k < kFrictionOptions.size(); ++k) {
        const char* name = kFrictionOptions[k].name;
        if (c.friction.option_at(k) != a.friction.option_at(k))
          return InvalidParameter(name, get_option(c, name),
                                  lane_why(i, r, get_option(a, name),
                                           "a batch shares the model and its options"));
      }
    }
    if (c.integrator.dt != a.integrator.dt)
      return InvalidParameter("dt", c.integrator.dt, lane_why(i, r, num(a.integrator.dt), grid));
    if (c.metrics.settle_fraction != a.metrics.settle_fraction)
      return InvalidParameter("settle_fraction", c.metrics.settle_fraction,
                              lane_why(i, r, num(a.metrics.settle_fraction), grid));
    if (c.stages.size() != a.stages.size())
      return InvalidParameter("stages", static_cast<double>(c.stages.size()),
                              lane_why(i, r, std::to_string(a.stages.size()) + " stages", grid));
    for (std::size_t k = 0; k < c.stages.size(); ++k) {
      const std::string pre = "stage" + std::to_string(k + 1) + ".";
      const Stage &sc = c.stages[k], &sa = a.stages[k];
      if (sc.duration != sa.duration)
        return InvalidParameter(pre + "duration", sc.duration,
                                lane_why(i, r, num(sa.duration), grid));
      if (sc.v_a != sa.v_a)
        return InvalidParameter(pre + "v_a", sc.v_a, lane_why(i, r, num(sa.v_a), grid));
      if (sc.f != sa.f)
        return InvalidParameter(pre + "f", sc.f, lane_why(i, r, num(sa.f), grid));
    }
  }
  return std::nullopt;
}

void construct_model(const SimConfig& c) {
  visit_model(c.model, [&]<class M>(std::type_identity<M>) { (void)make_model<M>(c); });
}

}  // namespace

int batch_chunk_lanes(ModelKind model) noexcept {
  return model_traits(model).info->scalar_only ? 1 : detail::kBatchLanes;
}

bool batch_compatible(const std::vector<SimConfig>& cfgs, std::string* error) {
  const auto bad = incompatibility(cfgs);
  if (bad && error) *error = bad->what();
  return !bad;
}

std::vector<SimResult> simulate_batch(const std::vector<SimConfig>& cfgs) {
  if (auto bad = incompatibility(cfgs)) throw *bad;
  std::vector<SimResult> results(cfgs.size());
  std::vector<std::size_t> lanes;  // valid configurations, in order
  lanes.reserve(cfgs.size());
  for (std::size_t i = 0; i < cfgs.size(); ++i) {
    std::vector<std::string> errors;
    if (cfgs[i].IsValid(&errors)) {
      try {  // the model constructors validate too; the kernels must not throw mid-chunk
        construct_model(cfgs[i]);
        lanes.push_back(i);
        continue;
      } catch (const InvalidParameter& e) {
        errors.push_back(e.what());
      }
    }
    SimResult& r = results[i];
    r.status = RunStatus::kInvalid;
    for (const auto& e : errors) r.reason += (r.reason.empty() ? "" : "; ") + e;
  }
  const std::size_t chunk =
      lanes.empty() ? 1 : static_cast<std::size_t>(batch_chunk_lanes(cfgs[lanes[0]].model));
  for (std::size_t first = 0; first < lanes.size(); first += chunk) {
    detail::ChunkIO io;
    io.lanes = static_cast<int>(std::min(chunk, lanes.size() - first));
    for (int j = 0; j < io.lanes; ++j) {
      io.cfg[j] = &cfgs[lanes[first + j]];
      io.out[j] = &results[lanes[first + j]];
    }
    detail::run_batched_chunk(io.cfg[0]->model, io);
  }
  return results;
}

}  // namespace stickslip::engine

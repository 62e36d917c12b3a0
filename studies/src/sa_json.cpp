// JSON and display forms of method indices (see sa_json.h).
#include "stickslip/studies/sa_json.h"

#include <cmath>
#include <cstdio>

namespace stickslip::studies::sensitivity {
namespace {

using nlohmann::json;

json number(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

json interval(const Interval& i) { return json::array({number(i.lo), number(i.hi)}); }

void put(const IndexValues& v, std::size_t k, json& o) {
  o[v.name] = number(v.value[k]);
  if (!v.ci.empty()) o[v.name + "_ci"] = interval(v.ci[k]);
  if (!v.resamples.empty()) {
    json r = json::array();
    for (double e : v.resamples[k]) r.push_back(number(e));
    o[v.name + "_resamples"] = std::move(r);
  }
}

std::string printf_double(const char* format, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

}  // namespace

void write_method_json(const MethodIndices& m, const std::vector<std::string>& parameters,
                       json& out) {
  json idx = json::array();
  if (m.defined)
    for (std::size_t p = 0; p < parameters.size(); ++p) {
      json o{{"parameter", parameters[p]}};
      for (const IndexValues& v : m.per_parameter) put(v, p, o);
      idx.push_back(std::move(o));
    }
  out["indices"] = std::move(idx);
  if (!m.defined || m.pairs.empty()) return;
  json pairs = json::array();
  for (std::size_t k = 0; k < m.pairs.size(); ++k) {
    json o{{"parameters", {parameters[m.pairs[k][0]], parameters[m.pairs[k][1]]}}};
    for (const IndexValues& v : m.per_pair) put(v, k, o);
    pairs.push_back(std::move(o));
  }
  out["second_order"] = std::move(pairs);
}

std::string display_index(double value, const Interval* ci, const char* format) {
  if (!std::isfinite(value)) return "n/a";
  const std::string text = printf_double(format, value);
  if (value >= 0.0 || ci == nullptr || !std::isfinite(ci->lo) || !std::isfinite(ci->hi))
    return text;
  if (ci->lo <= 0.0 && 0.0 <= ci->hi) return "\u2248 0 (" + text + ")";
  return text + " (< 0!)";
}

std::string display_interval(const Interval& ci, const char* format) {
  auto end = [&](double v) { return std::isfinite(v) ? printf_double(format, v) : "\u2013"; };
  // Appended piece by piece: "[" + std::string&& makes GCC 12 report a false -Wrestrict (bug 105329).
  std::string out = "[";
  out += end(ci.lo);
  out += ", ";
  out += end(ci.hi);
  out += ']';
  return out;
}

}  // namespace stickslip::studies::sensitivity

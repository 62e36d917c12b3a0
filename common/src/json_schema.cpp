// GCC 12 at -O3 reports a false -Wrestrict inside valijson's JSON Pointer code as inlined into
// std::string::replace (GCC bug 105329); it must be silenced before <string> is first included.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wrestrict"
#endif

#include "stickslip/common/json_schema.h"
#include "stickslip/common/text.h"

#define VALIJSON_USE_EXCEPTIONS 1
#include <valijson/adapters/nlohmann_json_adapter.hpp>
#include <valijson/schema.hpp>
#include <valijson/schema_parser.hpp>
#include <valijson/validation_results.hpp>
#include <valijson/validator.hpp>

#include <algorithm>
#include <array>
#include <regex>
#include <set>
#include <stdexcept>

namespace stickslip::common {
namespace {

using json = nlohmann::json;

// ---------------------------------------------------------------- JSON Pointer helpers

std::vector<std::string> pointer_tokens(const std::string& pointer) {
  std::vector<std::string> out;
  if (pointer.empty()) return out;
  std::size_t pos = 1;
  while (pos <= pointer.size()) {
    const std::size_t next = std::min(pointer.find('/', pos), pointer.size());
    std::string token = pointer.substr(pos, next - pos);
    std::string unescaped;
    for (std::size_t i = 0; i < token.size(); ++i) {
      if (token[i] == '~' && i + 1 < token.size()) {
        unescaped += token[i + 1] == '1' ? '/' : '~';
        ++i;
      } else {
        unescaped += token[i];
      }
    }
    out.push_back(unescaped);
    pos = next + 1;
  }
  return out;
}

// A JSON Pointer token as an array index, or nullopt.
std::optional<std::size_t> parse_index(const std::string& token) {
  if (token.empty() || token.size() > 18 ||
      token.find_first_not_of("0123456789") != std::string::npos)
    return std::nullopt;
  return static_cast<std::size_t>(std::stoull(token));
}

bool is_at_or_below(const std::string& pointer, const std::string& ancestor) {
  return pointer == ancestor ||
         (pointer.size() > ancestor.size() && pointer.compare(0, ancestor.size(), ancestor) == 0 &&
          pointer[ancestor.size()] == '/');
}

// The instance value at a pointer, or nullptr. Works for const and mutable documents.
template <typename Json>
Json* value_at(Json& doc, const std::string& pointer) {
  Json* cur = &doc;
  for (const auto& token : pointer_tokens(pointer)) {
    if (cur->is_object()) {
      const auto it = cur->find(token);
      if (it == cur->end()) return nullptr;
      cur = &*it;
    } else if (cur->is_array()) {
      const auto i = parse_index(token);
      if (!i || *i >= cur->size()) return nullptr;
      cur = &(*cur)[*i];
    } else {
      return nullptr;
    }
  }
  return cur;
}

std::string json_type_name(const json& v) {
  switch (v.type()) {
    case json::value_t::null: return "null";
    case json::value_t::boolean: return "boolean";
    case json::value_t::object: return "object";
    case json::value_t::array: return "array";
    case json::value_t::string: return "string";
    case json::value_t::number_integer:
    case json::value_t::number_unsigned: return "integer";
    case json::value_t::number_float: return "number";
    default: return "value";
  }
}

// ---------------------------------------------------------------- schema walker
// Finds the subschemas that apply at a document location, to explain an error with the
// constraint's own values. Follows local $ref, allOf, properties, patternProperties,
// additionalProperties, items/prefixItems, and if/then/else when the 'if' is simple enough to
// decide here (properties with const/enum/type, required); anyOf/oneOf branches are not followed.

class SchemaWalker {
 public:
  explicit SchemaWalker(const json& root) : root_(root) {}

  std::vector<const json*> at(const json& doc, const std::string& pointer) const {
    std::vector<const json*> cur;
    expand(&root_, &doc, &cur, 0);
    const json* inst = &doc;
    for (const auto& token : pointer_tokens(pointer)) {
      const json* child_inst = child(inst, token);
      std::vector<const json*> next;
      for (const json* s : cur)
        for (const json* c : child_schemas(*s, inst, token)) expand(c, child_inst, &next, 0);
      cur = std::move(next);
      inst = child_inst;
    }
    return cur;
  }

 private:
  static const json* child(const json* inst, const std::string& token) {
    if (inst == nullptr) return nullptr;
    if (inst->is_object()) {
      const auto it = inst->find(token);
      return it == inst->end() ? nullptr : &*it;
    }
    if (inst->is_array()) {
      const auto i = parse_index(token);
      return i && *i < inst->size() ? &(*inst)[*i] : nullptr;
    }
    return nullptr;
  }

  static std::vector<const json*> child_schemas(const json& s, const json* inst,
                                                const std::string& token) {
    std::vector<const json*> out;
    const bool as_index = inst != nullptr && inst->is_array();
    if (!as_index) {
      bool matched = false;
      if (auto p = s.find("properties"); p != s.end() && p->is_object() && p->contains(token)) {
        out.push_back(&(*p)[token]);
        matched = true;
      }
      if (auto pp = s.find("patternProperties"); pp != s.end() && pp->is_object()) {
        for (const auto& [pattern, sub] : pp->items()) {
          try {
            if (std::regex_search(token, std::regex(pattern))) {
              out.push_back(&sub);
              matched = true;
            }
          } catch (const std::regex_error&) {
          }
        }
      }
      if (auto ap = s.find("additionalProperties"); !matched && ap != s.end() && ap->is_object())
        out.push_back(&*ap);
      return out;
    }
    const auto index = parse_index(token);
    if (!index) return out;
    const std::size_t i = *index;
    const auto prefix = s.find("prefixItems");
    if (prefix != s.end() && prefix->is_array() && i < prefix->size()) {
      out.push_back(&(*prefix)[i]);
      return out;
    }
    if (auto items = s.find("items"); items != s.end()) {
      if (items->is_object()) out.push_back(&*items);
      if (items->is_array() && i < items->size()) out.push_back(&(*items)[i]);
    }
    return out;
  }

  const json* resolve(const std::string& ref) const {
    if (ref.empty() || ref[0] != '#') return nullptr;
    try {
      const json::json_pointer ptr(ref.substr(1));
      return root_.contains(ptr) ? &root_.at(ptr) : nullptr;
    } catch (const json::exception&) {
      return nullptr;
    }
  }

  void expand(const json* s, const json* inst, std::vector<const json*>* out, int depth) const {
    if (s == nullptr || !s->is_object() || depth > 32) return;
    out->push_back(s);
    if (auto ref = s->find("$ref"); ref != s->end() && ref->is_string())
      expand(resolve(ref->get<std::string>()), inst, out, depth + 1);
    if (auto all = s->find("allOf"); all != s->end() && all->is_array())
      for (const auto& sub : *all) expand(&sub, inst, out, depth + 1);
    const auto cond = s->find("if");
    if (cond != s->end() && inst != nullptr) {
      const auto decided = simple_match(*cond, *inst);
      if (decided) {
        const auto branch = s->find(*decided ? "then" : "else");
        if (branch != s->end()) expand(&*branch, inst, out, depth + 1);
      }
    }
  }

  // Evaluates simple 'if' schemas; nullopt when the schema uses anything else.
  static std::optional<bool> simple_match(const json& s, const json& inst) {
    if (s.is_boolean()) return s.get<bool>();
    if (!s.is_object()) return std::nullopt;
    bool ok = true;
    for (const auto& [key, value] : s.items()) {
      if (key == "description" || key == "title" || key == "default" || key == "$comment") continue;
      if (key == "const") {
        ok = ok && inst == value;
      } else if (key == "enum" && value.is_array()) {
        ok = ok && std::find(value.begin(), value.end(), inst) != value.end();
      } else if (key == "required" && value.is_array()) {
        for (const auto& name : value)
          ok = ok && inst.is_object() && name.is_string() && inst.contains(name.get<std::string>());
      } else if (key == "properties" && value.is_object()) {
        if (!inst.is_object()) continue;
        for (const auto& [name, sub] : value.items()) {
          const auto it = inst.find(name);
          if (it == inst.end()) continue;
          const auto m = simple_match(sub, *it);
          if (!m) return std::nullopt;
          ok = ok && *m;
        }
      } else if (key == "type") {
        const std::string t = json_type_name(inst);
        auto allows = [&](const json& name) {
          return name == t || (name == "number" && t == "integer");
        };
        ok = ok && (value.is_array() ? std::any_of(value.begin(), value.end(), allows)
                                     : allows(value));
      } else {
        return std::nullopt;
      }
    }
    return ok;
  }

  const json& root_;
};

// ---------------------------------------------------------------- message rewriting

std::string quoted_list(const json& values, std::string_view sep) {
  std::string out;
  for (const auto& v : values) out += (out.empty() ? "" : std::string(sep)) + v.dump();
  return out;
}

const json* first_keyword(const std::vector<const json*>& schemas, const char* key) {
  for (const json* s : schemas)
    if (auto it = s->find(key); it != s->end()) return &*it;
  return nullptr;
}

// The types every applicable schema allows (intersection), e.g. {"array"}.
std::vector<std::string> allowed_types(const std::vector<const json*>& schemas) {
  static constexpr std::array<const char*, 7> kAll = {"null",   "boolean", "object", "array",
                                                      "number", "integer", "string"};
  std::vector<std::string> out;
  for (const char* t : kAll) {
    bool ok = true;
    for (const json* s : schemas) {
      const auto it = s->find("type");
      if (it == s->end()) continue;
      auto allows = [&](const json& name) {
        return name == t || (name == "number" && std::string_view(t) == "integer");
      };
      ok = ok && (it->is_array() ? std::any_of(it->begin(), it->end(), allows) : allows(*it));
    }
    if (ok) out.emplace_back(t);
  }
  const bool has_number = std::find(out.begin(), out.end(), "number") != out.end();
  if (has_number) out.erase(std::remove(out.begin(), out.end(), "integer"), out.end());
  return out;
}

std::string noun_for_items(const std::vector<const json*>& schemas, std::size_t count) {
  std::string noun = "item";
  if (const json* items = first_keyword(schemas, "items");
      items != nullptr && items->is_object() && items->contains("type") &&
      (*items)["type"].is_string()) {
    const auto t = (*items)["type"].get<std::string>();
    if (t == "number" || t == "integer" || t == "string" || t == "object" || t == "array")
      noun = t;
  }
  return count == 1 ? noun : noun + "s";
}

// "Expected number greater than 0.000000" etc.: the bound from the schema, not valijson's
// fixed-point rendering.
std::optional<std::string> rewrite_bound(const std::string& d, const std::vector<const json*>& s,
                                         const json* value) {
  struct Case {
    const char* prefix;
    const char* op;
    const char* keyword;
    const char* fallback_keyword;
  };
  static constexpr std::array<Case, 4> kCases = {{
      {"Expected number greater than or equal to ", ">=", "minimum", "minimum"},
      {"Expected number greater than ", ">", "exclusiveMinimum", "minimum"},
      {"Expected number less than or equal to ", "<=", "maximum", "maximum"},
      {"Expected number less than ", "<", "exclusiveMaximum", "maximum"},
  }};
  for (const auto& c : kCases) {
    if (d.rfind(c.prefix, 0) != 0) continue;
    const json* bound = first_keyword(s, c.keyword);
    if (bound == nullptr || !bound->is_number()) bound = first_keyword(s, c.fallback_keyword);
    const std::string b = bound != nullptr && bound->is_number()
                              ? bound->dump()
                              : d.substr(std::string_view(c.prefix).size());
    return std::string("must be ") + c.op + " " + b + (value ? ", got " + value->dump() : "");
  }
  return std::nullopt;
}

std::optional<std::string> rewrite_size(const std::string& d, const std::vector<const json*>& s,
                                        const json* value) {
  const bool fewer = d.find("no fewer than") != std::string::npos;
  const bool more = d.find("no more than") != std::string::npos;
  if (!fewer && !more) return std::nullopt;
  const bool is_array = d.rfind("Array should", 0) == 0;
  const bool is_object = d.rfind("Object should", 0) == 0;
  const bool is_string = d.rfind("String should", 0) == 0;
  if (!is_array && !is_object && !is_string) return std::nullopt;
  const char* lo_key = is_array ? "minItems" : is_object ? "minProperties" : "minLength";
  const char* hi_key = is_array ? "maxItems" : is_object ? "maxProperties" : "maxLength";
  const json* lo = first_keyword(s, lo_key);
  const json* hi = first_keyword(s, hi_key);
  const json* bound = fewer ? lo : hi;
  if (bound == nullptr || !bound->is_number_unsigned()) return std::nullopt;
  const auto n = bound->get<std::size_t>();
  const std::size_t got = value == nullptr                ? 0
                          : is_string && value->is_string() ? value->get<std::string>().size()
                                                            : value->size();
  const bool exact = lo != nullptr && hi != nullptr && *lo == *hi;
  const std::string noun = is_array    ? noun_for_items(s, n)
                           : is_object ? (n == 1 ? "field" : "fields")
                                       : (n == 1 ? "character" : "characters");
  const std::string how = exact ? "" : fewer ? "at least " : "at most ";
  return "expected " + how + std::to_string(n) + " " + noun + ", got " + std::to_string(got);
}

std::string rewrite_message(const std::string& d, const std::vector<const json*>& s,
                            const json* value) {
  const std::string got = value ? ", got " + value->dump() : "";
  if (d == "Value type not permitted by 'type' constraint.") {
    const auto types = allowed_types(s);
    const std::string actual = value ? json_type_name(*value) : "nothing";
    if (types.empty() || types.size() == 7) return "wrong type: got " + actual;
    return "expected " + join(types, " or ") + ", got " + actual;
  }
  if (d == "Failed to match against any enum values.") {
    if (const json* e = first_keyword(s, "enum"); e != nullptr && e->is_array())
      return "must be one of " + quoted_list(*e, ", ") + (value ? "; got " + value->dump() : "");
  }
  if (d == "Failed to match expected value set by 'const' constraint.") {
    if (const json* c = first_keyword(s, "const")) return "must be " + c->dump() + got;
  }
  if (d == "Failed to match regex specified by 'pattern' constraint.") {
    if (const json* p = first_keyword(s, "pattern"); p != nullptr && p->is_string())
      return "must match the pattern " + p->get<std::string>() + got;
  }
  if (d.rfind("Value should be a multiple of ", 0) == 0) {
    if (const json* m = first_keyword(s, "multipleOf")) return "must be a multiple of " +
                                                                m->dump() + got;
  }
  if (d.rfind("Missing required property '", 0) == 0) {
    const auto a = d.find('\'');
    const auto b = d.rfind('\'');
    if (b > a) return "missing required field \"" + d.substr(a + 1, b - a - 1) + "\"";
  }
  if (auto m = rewrite_bound(d, s, value)) return *m;
  if (auto m = rewrite_size(d, s, value)) return *m;
  return d;
}

bool is_wrapper(const std::string& d) {
  static constexpr std::array<const char*, 9> kWrappers = {
      "Failed to validate against schema associated with property name",
      "Failed to validate item #",
      "Failed to validate against a conditional schema",
      "Failed to validate against child schema #",
      "Failed to validate against additional properties schema",
      "Failed to validate against schema associated with pattern",
      "Failed to validate against any schemas allowed by anyOf",
      "Failed to validate against any child schemas allowed by oneOf",
      "Failed to validate against dependent schema",
  };
  return std::any_of(kWrappers.begin(), kWrappers.end(),
                     [&](const char* w) { return d.rfind(w, 0) == 0; });
}

constexpr std::string_view kUnknownPrefix =
    "Object contains a property that could not be validated using 'properties' or "
    "'additionalProperties' constraints: '";

std::optional<std::string> unknown_property_name(const std::string& d) {
  if (d.rfind(kUnknownPrefix, 0) != 0 || d.size() < kUnknownPrefix.size() + 2) return std::nullopt;
  return d.substr(kUnknownPrefix.size(), d.size() - kUnknownPrefix.size() - 2);  // drop "'."
}

std::string context_to_pointer(const std::vector<std::string>& context) {
  std::string pointer;
  for (const auto& part : context) {
    if (part == "<root>") continue;
    const bool bracketed = part.size() >= 2 && part.front() == '[' && part.back() == ']';
    pointer = pointer_append(pointer, bracketed ? part.substr(1, part.size() - 2) : part);
  }
  return pointer;
}

std::string allowed_fields(const std::vector<const json*>& schemas) {
  std::vector<std::string> names;
  auto add = [&names](const std::string& name) {
    if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
  };
  for (const json* s : schemas) {
    if (const auto p = s->find("properties"); p != s->end() && p->is_object())
      for (const auto& [name, sub] : p->items()) add(name);
    if (const auto p = s->find("patternProperties"); p != s->end() && p->is_object())
      for (const auto& [pattern, sub] : p->items()) add("names matching " + pattern);
  }
  return names.empty() ? "no fields" : join(names, ", ");
}

}  // namespace

// ---------------------------------------------------------------- SchemaValidator

struct SchemaValidator::Compiled {
  valijson::Schema schema;
};

SchemaValidator::SchemaValidator(nlohmann::json schema)
    : schema_(std::move(schema)), compiled_(std::make_unique<Compiled>()) {
  try {
    valijson::SchemaParser parser(valijson::SchemaParser::kDraft7);
    const valijson::adapters::NlohmannJsonAdapter adapter(schema_);
    parser.populateSchema(adapter, compiled_->schema);
  } catch (const std::exception& e) {
    throw std::invalid_argument(std::string("invalid JSON schema: ") + e.what());
  }
}

SchemaValidator::~SchemaValidator() = default;
SchemaValidator::SchemaValidator(SchemaValidator&&) noexcept = default;
SchemaValidator& SchemaValidator::operator=(SchemaValidator&&) noexcept = default;

std::vector<SpecError> SchemaValidator::validate(const nlohmann::json& doc) const {
  const SchemaWalker walker(schema_);
  auto run = [this](const json& d) {
    valijson::Validator validator(valijson::Validator::kStrongTypes);
    valijson::ValidationResults results;
    const valijson::adapters::NlohmannJsonAdapter target(d);
    validator.validate(compiled_->schema, target, &results);
    std::vector<SpecError> raw;
    for (const auto& e : results) raw.push_back({context_to_pointer(e.context), e.description});
    return raw;
  };

  // Unknown fields: valijson names only the first per object, so remove each one reported and
  // validate again until none is left. The remaining errors come from the last pass.
  std::vector<SpecError> unknown;
  json work = doc;
  std::vector<SpecError> raw = run(work);
  for (std::size_t pass = 0; pass < 100000; ++pass) {
    bool removed = false;
    for (const auto& e : raw) {
      const auto name = unknown_property_name(e.message);
      if (!name) continue;
      json* parent = value_at(work, e.pointer);
      if (parent == nullptr || !parent->is_object() || !parent->contains(*name)) continue;
      parent->erase(*name);
      unknown.push_back({pointer_append(e.pointer, *name),
                         "unknown field \"" + *name + "\" (allowed: " +
                             allowed_fields(walker.at(doc, e.pointer)) + ")"});
      removed = true;
    }
    if (!removed) break;
    raw = run(work);
  }

  std::vector<SpecError> out = unknown;
  for (const auto& e : raw) {
    if (unknown_property_name(e.message)) continue;
    if (is_wrapper(e.message)) {
      const bool explained = std::any_of(raw.begin(), raw.end(), [&](const SpecError& f) {
        return !is_wrapper(f.message) && is_at_or_below(f.pointer, e.pointer);
      });
      if (explained || !unknown.empty()) continue;
    }
    const SpecError rewritten{e.pointer, rewrite_message(e.message, walker.at(work, e.pointer),
                                                         value_at(work, e.pointer))};
    if (std::find(out.begin(), out.end(), rewritten) == out.end()) out.push_back(rewritten);
  }
  return out;
}

std::vector<SpecError> validate_against_schema(const nlohmann::json& doc,
                                               const nlohmann::json& schema) {
  return SchemaValidator(schema).validate(doc);
}

}  // namespace stickslip::common

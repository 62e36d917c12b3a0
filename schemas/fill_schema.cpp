// stickslip_fill_schema TEMPLATE OUT_JSON OUT_HEADER LIB VAR: fills the registry markers of a
// schema template (schemas/*.json) from the friction-model registry (engine/include/stickslip/
// engine/model_list.h and the models' traits tables), writes the filled schema to OUT_JSON and
// embeds it into the header OUT_HEADER as
//   namespace stickslip::LIB::generated { inline constexpr std::string_view kVARJson = ...; }
// Run by CMake at build time (stickslip_embed_json, common/CMakeLists.txt); the binaries serve
// and validate against the filled schemas only. The markers:
//   "@models@"                  an array element: the model ids, quoted, in list order
//   "@effects@"                 an array element: the catalogue extension ids, quoted, in
//                               catalogue order (engine/include/stickslip/engine/extensions.h)
//   "@default_model@"           a string: the id of the engine's default model (SimConfig)
//   @model_names@               inside a string: the model ids joined with ", "
//   @titles_using:NAME@         inside a string: the titles of the models with parameter NAME
//   "@friction_parameters@": {} a whole member line: one property per friction parameter (its
//                               description, unit, models, allowed range and default), one per
//                               alias, and one per model option
// A template without markers passes through unchanged. An unknown marker is an error.
#include <algorithm>
#include <charconv>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <limits>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "stickslip/engine/extensions.h"
#include "stickslip/engine/params.h"
#include "stickslip/engine/registry.h"

namespace {

using namespace stickslip::engine;

std::string quoted(std::string_view s) {
  std::string out = "\"";
  for (const char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      out += buf;
    } else {
      out += c;
    }
  }
  return out + '"';
}

// The shortest text that reads back as v (a JSON number).
std::string number(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

// "A", "A and B", "A, B and C".
std::string and_list(const std::vector<std::string>& items) {
  std::string out;
  for (std::size_t i = 0; i < items.size(); ++i) {
    if (i > 0) out += i + 1 == items.size() ? " and " : ", ";
    out += items[i];
  }
  return out;
}

// The titles of the models with the parameter or option name.
std::vector<std::string> titles_using(std::string_view name) {
  std::vector<std::string> out;
  for (const ModelKind m : models_using(name)) out.push_back(model_traits(m).info->title);
  return out;
}

// The parameters that must be >= param under some model's constraint.
std::vector<std::string> lower_bounds_of(std::string_view param) {
  std::vector<std::string> out;
  for (const ModelTraits& t : all_model_traits())
    for (const Constraint& c : t.constraints)
      if (param == c.param && std::find(out.begin(), out.end(), c.at_least) == out.end())
        out.push_back(c.at_least);
  return out;
}

// "type" and the bounds of an allowed interval as JSON Schema keywords.
std::string range_keywords(const Interval& in) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  std::string out = "\"type\": \"number\"";
  if (in.lo != -inf)
    out += std::string(", \"") + (in.lo_open ? "exclusiveMinimum" : "minimum") + "\": " +
           number(in.lo);
  if (in.hi != inf)
    out += std::string(", \"") + (in.hi_open ? "exclusiveMaximum" : "maximum") + "\": " +
           number(in.hi);
  // 1.0, not 1: valijson checks an integer divisor by casting the value to int64_t, which is
  // undefined for values beyond its range (fuzz_study_spec: "levels": 4.3e53); a double divisor
  // takes its remainder() path.
  if (in.integer) out += ", \"multipleOf\": 1.0";
  return out;
}

std::string capitalised(std::string s) {
  if (!s.empty() && s[0] >= 'a' && s[0] <= 'z') s[0] = static_cast<char>(s[0] - 'a' + 'A');
  return s;
}

// One "name": {...} member per friction parameter, alias and option (without separators).
std::vector<std::string> friction_members() {
  std::vector<std::string> out;
  for (const ParamDef& p : kFrictionParameters) {
    const std::string unit = " [" + unit_of(p.dim) + "]";
    std::string text = capitalised(p.description) + unit + " (" + and_list(titles_using(p.name)) +
                       ")";
    for (const std::string& b : lower_bounds_of(p.name)) text += "; must be >= " + b;
    if (p.alias != nullptr) text += std::string("; alias ") + p.alias;
    out.push_back(quoted(p.name) + ": { \"description\": " + quoted(text + ".") + ", " +
                  range_keywords(p.allowed) + ", \"default\": " + number(p.def) + " }");
    if (p.alias != nullptr) {
      const std::string alias_text = std::string("Alias of ") + p.name + unit + ". Give " +
                                     p.name + " or " + p.alias +
                                     ", not both; the canonical form uses " + p.name + ".";
      out.push_back(quoted(p.alias) + ": { \"description\": " + quoted(alias_text) + ", " +
                    range_keywords(p.allowed) + " }");
    }
  }
  for (const OptionDef& o : kFrictionOptions) {
    std::vector<std::string> choices;
    std::string list;
    for (const char* c : o.choices) {
      choices.push_back(c);
      list += (list.empty() ? "" : ", ") + quoted(c);
    }
    const std::string text = capitalised(o.description) + ": one of " + and_list(choices) + " (" +
                             and_list(titles_using(o.name)) + ").";
    out.push_back(quoted(o.name) + ": { \"description\": " + quoted(text) + ", \"enum\": [" +
                  list + "], \"default\": " + quoted(o.choices[static_cast<std::size_t>(o.def)]) +
                  " }");
  }
  return out;
}

void replace_all(std::string& text, const std::string& from, const std::string& to) {
  for (std::size_t at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size()))
    text.replace(at, from.size(), to);
}

// Replaces each line that is exactly `"@friction_parameters@": {}` (plus an optional comma)
// by the members, at the line's indentation.
std::string fill_member_lines(const std::string& text) {
  static const std::regex kLine(R"re(^([ \t]*)"@friction_parameters@": \{\}(,?)[ \t]*$)re");
  std::istringstream in(text);
  std::string out, line;
  while (std::getline(in, line)) {
    std::smatch m;
    if (!std::regex_match(line, m, kLine)) {
      out += line + "\n";
      continue;
    }
    const auto members = friction_members();
    for (std::size_t i = 0; i < members.size(); ++i)
      out += m[1].str() + members[i] + (i + 1 < members.size() ? "," : m[2].str()) + "\n";
  }
  if (!text.empty() && text.back() != '\n') out.pop_back();
  return out;
}

std::string fill(std::string text) {
  std::string ids, names;
  for (const ModelTraits& t : all_model_traits()) {
    ids += (ids.empty() ? "" : ", ") + quoted(t.info->name);
    names += (names.empty() ? "" : ", ") + std::string(t.info->name);
  }
  text = fill_member_lines(text);
  replace_all(text, "\"@models@\"", ids);
  std::string effects;
  for (const ExtensionKind k : extension_catalogue())
    effects += (effects.empty() ? "" : ", ") + quoted(to_string(k));
  replace_all(text, "\"@effects@\"", effects);
  replace_all(text, "\"@default_model@\"", quoted(to_string(SimConfig{}.model)));
  replace_all(text, "@model_names@", names);
  static const std::regex kTitles(R"(@titles_using:([A-Za-z0-9_]+)@)");
  std::string out;
  auto begin = text.cbegin();
  for (std::sregex_iterator it(text.begin(), text.end(), kTitles), end; it != end; ++it) {
    out.append(begin, (*it)[0].first);
    const auto titles = titles_using((*it)[1].str());
    if (titles.empty())
      throw std::runtime_error("@titles_using:" + (*it)[1].str() + "@: no model has that parameter");
    out += and_list(titles);
    begin = (*it)[0].second;
  }
  out.append(begin, text.cend());
  static const std::regex kMarker(R"(@[A-Za-z_]+(:[^@"]*)?@)");
  std::smatch m;
  if (std::regex_search(out, m, kMarker))
    throw std::runtime_error("unknown marker " + m[0].str());
  return out;
}

std::string read(const char* path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(std::string("cannot read ") + path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void write(const char* path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  if (!out.flush()) throw std::runtime_error(std::string("cannot write ") + path);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 6) {
    std::cerr << "usage: stickslip_fill_schema TEMPLATE OUT_JSON OUT_HEADER LIB VAR\n";
    return 2;
  }
  try {
    const std::string filled = fill(read(argv[1]));
    if (filled.find(")stickslip_json\"") != std::string::npos)
      throw std::runtime_error("the schema contains the raw-string delimiter )stickslip_json\"");
    std::string name = argv[1];
    name = name.substr(name.find_last_of('/') + 1);
    write(argv[2], filled);
    write(argv[3], "// Generated at build time from schemas/" + name +
                       " and the friction-model registry (stickslip_fill_schema); do not edit.\n"
                       "#pragma once\n#include <string_view>\nnamespace stickslip::" +
                       argv[4] + "::generated {\ninline constexpr std::string_view k" + argv[5] +
                       "Json = R\"stickslip_json(" + filled +
                       ")stickslip_json\";\n}  // namespace stickslip::" + argv[4] +
                       "::generated\n");
  } catch (const std::exception& e) {
    std::cerr << "stickslip_fill_schema " << argv[1] << ": " << e.what() << "\n";
    return 1;
  }
  return 0;
}

// Fuzz target: page tokens (page_token and page_size of GET /v1/studies, /v1/diagnoses and
// /v1/studies/{id}/runs, JSON and CSV), through server::Api::handle over the store of
// fuzz_http.cpp (7 studies, one with 23 runs, 3 diagnoses).
// Input: byte 0 picks the endpoint and format, byte 1 the page size (0: none; else 1..40; 255:
// an out-of-range 100000), the rest is the token (percent-encoded into the query, so any bytes).
// Properties: any token gets 200 or 400, a 400 naming page_token or page_size; a 200 page holds
// only items after the token (ids greater than it; design indices above it); and following
// next_page_token from the first page with the same page size lists every item exactly once, in
// order, and ends with a null token.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <set>
#include <string>
#include <string_view>

#include "fuzz_api.h"

namespace {

using nlohmann::json;
using stickslip::server::Request;
using stickslip::server::Response;

std::string percent_encode(std::string_view s) {
  std::string out;
  for (const unsigned char c : s) {
    if ((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' ||
        c == '_' || c == '.' || c == '~') {
      out += static_cast<char>(c);
    } else {
      char buf[4];
      std::snprintf(buf, sizeof buf, "%%%02X", c);
      out += buf;
    }
  }
  return out;
}

struct Endpoint {
  std::string path, list_key;  ///< list_key "": the runs (JSON "runs" keyed by design_index)
  bool csv = false;
  std::size_t items = 0;
};

/// The keys of a page's items (ids, or design indices as numbers) and its next token.
struct Page {
  std::vector<std::string> keys;
  std::optional<std::string> next;
};

Page read_page(const Endpoint& e, const Response& res) {
  Page p;
  if (e.csv) {
    // CSV runs: the first column of each row after the header is the design index.
    std::string_view body = res.body;
    bool header = true;
    while (!body.empty()) {
      const auto nl = body.find('\n');
      const std::string_view line = body.substr(0, nl);
      body = nl == std::string_view::npos ? std::string_view{} : body.substr(nl + 1);
      if (header) {
        header = false;
        continue;
      }
      if (!line.empty()) p.keys.emplace_back(line.substr(0, line.find(',')));
    }
    if (const auto t = res.header("Next-Page-Token")) p.next = *t;
    return p;
  }
  const json j = json::parse(res.body);
  if (e.list_key.empty()) {
    for (const auto& r : j.at("runs")) p.keys.push_back(std::to_string(r.at("design_index").get<long>()));
  } else {
    for (const auto& r : j.at(e.list_key)) p.keys.push_back(r.at("id").get<std::string>());
  }
  if (!j.at("next_page_token").is_null()) p.next = j["next_page_token"].get<std::string>();
  return p;
}

bool key_after(const Endpoint& e, const std::string& key, const std::string& token) {
  if (e.list_key.empty()) return std::stoll(key) > std::stoll(token);
  return key > token;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace stickslip;
  if (size < 2) return 0;
  auto& f = fuzz::api_fixture();
  const std::string study0 = f.population.studies[0];
  const Endpoint endpoints[] = {
      {"/v1/studies", "studies", false, f.population.studies.size()},
      {"/v1/diagnoses", "diagnoses", false, f.population.diagnoses.size()},
      {"/v1/studies/" + study0 + "/runs", "", false, 23},
      {"/v1/studies/" + study0 + "/runs", "", true, 23},
  };
  const Endpoint& e = endpoints[data[0] % 4];
  std::string size_param;
  std::size_t page_size = 0;
  if (data[1] == 255) {
    size_param = "&page_size=100000";
  } else if (data[1] != 0) {
    page_size = 1 + data[1] % 40;
    size_param = "&page_size=" + std::to_string(page_size);
  }
  const std::string token(reinterpret_cast<const char*>(data) + 2, size - 2);
  const std::string base = e.path + "?" + (e.csv ? "format=csv" : "format=json") + size_param;
  const Request req{"GET", base + "&page_token=" + percent_encode(token), {}, ""};
  const Response res = f.api->handle(req);
  fuzz::check_response(req, res);
  const std::string where = req.target.substr(0, 200) + " -> " + std::to_string(res.status) + " " +
                            res.body.substr(0, 300);
  FUZZ_CHECK(res.status == 200 || res.status == 400, where);
  if (res.status == 400) {
    FUZZ_CHECK(res.body.find("page_token") != std::string::npos ||
                   res.body.find("page_size") != std::string::npos,
               where);
  } else {
    // The page holds only items after the token (keyset pagination).
    for (const auto& key : read_page(e, res).keys)
      FUZZ_CHECK(key_after(e, key, token), where + " item " + key);
  }
  if (page_size == 0 || data[1] == 255) return 0;
  // Walking the pages from the first lists every item once, in order.
  std::vector<std::string> all;
  std::optional<std::string> next;
  for (std::size_t pages = 0;; ++pages) {
    FUZZ_CHECK(pages <= e.items + 1, "the pages do not end: " + base);
    const Request walk{"GET", base + (next ? "&page_token=" + percent_encode(*next) : ""), {}, ""};
    const Response r = f.api->handle(walk);
    FUZZ_CHECK(r.status == 200, walk.target + " -> " + std::to_string(r.status) + " " + r.body);
    const Page p = read_page(e, r);
    FUZZ_CHECK(p.keys.size() <= page_size, walk.target);
    all.insert(all.end(), p.keys.begin(), p.keys.end());
    if (!p.next) break;
    FUZZ_CHECK(!p.keys.empty() && *p.next == p.keys.back(), walk.target + " next " + *p.next);
    next = p.next;
  }
  FUZZ_CHECK(all.size() == e.items, base + ": " + std::to_string(all.size()) + " items");
  for (std::size_t i = 1; i < all.size(); ++i)
    FUZZ_CHECK(key_after(e, all[i], all[i - 1]), base + ": out of order at " + all[i]);
  return 0;
}

#include "stickslip/client/http_client.h"

#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <cctype>

namespace stickslip::client {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
using tcp = asio::ip::tcp;

ServerUrl ServerUrl::parse(const std::string& url) {
  const std::string scheme = "http://";
  if (url.rfind(scheme, 0) != 0) {
    throw std::invalid_argument("--server: expected http://HOST[:PORT][/PREFIX], got \"" + url +
                                "\"" + (url.rfind("https://", 0) == 0
                                            ? " (https is not supported; use a TLS proxy)"
                                            : ""));
  }
  std::string rest = url.substr(scheme.size());
  ServerUrl out;
  const auto slash = rest.find('/');
  std::string authority = rest.substr(0, slash);
  if (slash != std::string::npos) out.prefix = rest.substr(slash);
  while (!out.prefix.empty() && out.prefix.back() == '/') out.prefix.pop_back();
  if (authority.empty()) throw std::invalid_argument("--server: no host in \"" + url + "\"");
  std::string host = authority, port = "80";
  if (authority.front() == '[') {  // [IPv6]:port
    const auto close = authority.find(']');
    if (close == std::string::npos) throw std::invalid_argument("--server: bad host in " + url);
    host = authority.substr(1, close - 1);
    if (close + 1 < authority.size() && authority[close + 1] == ':')
      port = authority.substr(close + 2);
  } else if (const auto colon = authority.rfind(':'); colon != std::string::npos) {
    host = authority.substr(0, colon);
    port = authority.substr(colon + 1);
  }
  bool digits = !port.empty() && port.size() <= 5;
  for (const char c : port) digits = digits && std::isdigit(static_cast<unsigned char>(c));
  if (!digits || std::stoi(port) < 1 || std::stoi(port) > 65535)
    throw std::invalid_argument("--server: bad port \"" + port + "\" in \"" + url + "\"");
  if (host.empty()) throw std::invalid_argument("--server: no host in \"" + url + "\"");
  out.host = host;
  out.port = port;
  return out;
}

std::string ServerUrl::to_string() const {
  const bool v6 = host.find(':') != std::string::npos;
  return "http://" + (v6 ? "[" + host + "]" : host) + ":" + port + prefix;
}

std::string HttpReply::header(const std::string& name) const {
  for (const auto& [k, v] : headers) {
    if (k.size() != name.size()) continue;
    bool same = true;
    for (std::size_t i = 0; i < k.size() && same; ++i)
      same = std::tolower(static_cast<unsigned char>(k[i])) ==
             std::tolower(static_cast<unsigned char>(name[i]));
    if (same) return v;
  }
  return "";
}

HttpReply http_call(const ServerUrl& server, const HttpCall& call) {
  asio::io_context ioc;
  beast::tcp_stream stream(ioc);
  beast::error_code ec;
  tcp::resolver resolver(ioc);
  const auto endpoints = resolver.resolve(server.host, server.port, ec);
  if (ec) throw UnreachableError("cannot resolve " + server.host + ": " + ec.message());
  stream.expires_after(call.timeout);
  // Synchronous connect/write/read: tcp_stream's timeout applies to async operations only, so
  // each step runs asynchronously on this private io_context and is waited for.
  auto run = [&](auto&& op) {
    ec = {};
    op();
    ioc.restart();
    ioc.run();
  };
  run([&] { stream.async_connect(endpoints, [&](beast::error_code e, const tcp::endpoint&) { ec = e; }); });
  if (ec) {
    throw UnreachableError("cannot connect to " + server.to_string() + ": " +
                           (ec == beast::error::timeout ? std::string("timed out")
                                                        : ec.message()));
  }
  http::request<http::string_body> req{http::string_to_verb(call.method),
                                       server.prefix + call.target, 11};
  req.set(http::field::host, server.host + ":" + server.port);
  req.set(http::field::user_agent, "stickslip-client");
  for (const auto& [k, v] : call.headers) req.set(k, v);
  if (!call.body.empty() || call.method == "POST") req.body() = call.body;
  req.keep_alive(false);
  req.prepare_payload();
  stream.expires_after(call.timeout);
  run([&] { http::async_write(stream, req, [&](beast::error_code e, std::size_t) { ec = e; }); });
  if (ec) throw UnreachableError("cannot send to " + server.to_string() + ": " + ec.message());
  beast::flat_buffer buffer;
  http::response_parser<http::string_body> parser;
  parser.body_limit(std::uint64_t{1} << 32);
  stream.expires_after(call.timeout);
  run([&] { http::async_read(stream, buffer, parser, [&](beast::error_code e, std::size_t) { ec = e; }); });
  if (ec) {
    throw UnreachableError("no reply from " + server.to_string() + ": " +
                           (ec == beast::error::timeout ? std::string("timed out")
                                                        : ec.message()));
  }
  auto res = parser.release();
  HttpReply reply;
  reply.status = static_cast<int>(res.result_int());
  for (const auto& f : res) reply.headers.emplace_back(std::string(f.name_string()),
                                                       std::string(f.value()));
  reply.body = std::move(res.body());
  stream.socket().shutdown(tcp::socket::shutdown_both, ec);
  return reply;
}

}  // namespace stickslip::client

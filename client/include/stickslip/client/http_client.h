#pragma once
// A small synchronous HTTP/1.1 client (Boost.Beast) for the `stickslip` commands that talk to
// stickslipd. One connection per call: the commands make few requests, so keep-alive is not
// worth its state.

#include <chrono>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace stickslip::client {

/// The server could not be reached (DNS, connection refused, timeout): exit code 3.
class UnreachableError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// "http://host[:port][/prefix]". Only plain HTTP: stickslipd binds to localhost by default and
/// is meant to sit behind a TLS-terminating proxy when exposed.
struct ServerUrl {
  std::string host = "127.0.0.1";
  std::string port = "80";
  std::string prefix;  ///< path prefix without a trailing '/', e.g. "" or "/stickslip"
  /// Throws std::invalid_argument naming the URL when it is not of that form.
  static ServerUrl parse(const std::string& url);
  std::string to_string() const;
};

struct HttpReply {
  int status = 0;
  std::vector<std::pair<std::string, std::string>> headers;
  std::string body;
  std::string header(const std::string& name) const;  ///< "" when absent
};

struct HttpCall {
  std::string method = "GET";
  std::string target;  ///< path and query, appended to the URL's prefix
  std::string body;
  std::vector<std::pair<std::string, std::string>> headers;
  std::chrono::milliseconds timeout{30000};
};

/// Sends one request and reads the whole reply. Throws UnreachableError when the server cannot
/// be reached or the connection fails before a reply.
HttpReply http_call(const ServerUrl& server, const HttpCall& call);

}  // namespace stickslip::client

#pragma once
// The web dashboard of stickslipd: the static files of server/web/ (HTML, CSS, JavaScript modules
// and the vendored chart library and JSON Schema validator), embedded in the binary at build time
// (server/web/embed.cmake), so the dashboard works offline and without the source tree. The pages
// are thin: they call the same /v1 API as the command line and build their DOM with textContent.
//
// Routes (Api): GET / is index.html; GET /ui/<path> is the file server/web/<path>.
//
// Security headers (Api::handle adds them to every response that has none of its own):
//  - kContentSecurityPolicy: scripts only from this origin and never inline (no <script> blocks,
//    no on* attributes, no eval), styles from this origin (no <style> blocks, no style
//    attributes), data only from this origin, frames only of this origin (the nightly reports),
//    and this server's pages may not be framed by others;
//  - the nightly reports' own files get kReportContentSecurityPolicy instead: no script at all,
//    their inline <style> and data: images allowed, sandboxed, framed by this origin only.

#include <optional>
#include <string_view>
#include <vector>

namespace stickslip::server {

inline constexpr std::string_view kContentSecurityPolicy =
    "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' data:; "
    "connect-src 'self'; frame-src 'self'; base-uri 'none'; form-action 'none'; "
    "frame-ancestors 'none'";

inline constexpr std::string_view kReportContentSecurityPolicy =
    "default-src 'none'; style-src 'unsafe-inline'; img-src 'self' data:; base-uri 'none'; "
    "form-action 'none'; frame-ancestors 'self'; sandbox";

/// One embedded file.
struct WebAsset {
  std::string_view path;          ///< relative to server/web/, e.g. "js/app.js"
  std::string_view content_type;  ///< from the extension
  std::string_view body;
  std::string_view etag;          ///< strong entity tag: the quoted SHA-256 prefix of body
  bool immutable = false;         ///< under vendor/<name>-<version>/: cacheable for good
};

/// Every embedded file, sorted by path.
const std::vector<WebAsset>& web_assets();
/// The file at path (no leading '/'), if embedded.
std::optional<WebAsset> find_web_asset(std::string_view path);

}  // namespace stickslip::server

// The daemon's pages for people (issue 34): every OGC API resource in HTML as well as JSON.
//
// The pages are rendered by the browser, not the server: a request that asks for HTML (`?f=html`,
// or an Accept header that prefers text/html, as a browser's navigation does) gets one fixed
// page (the "shell") whose script fetches the same resource as JSON and renders it. So the HTML
// holds no data at all: it needs no token (a browser sends none when it follows a link), and
// owner labels, field names and file names from uploads only ever reach the page through the
// script's text nodes, never as markup. The script sends the bearer token the person typed (kept
// in the tab's sessionStorage, never in a URL) on every request it makes, the downloads included.
//
// The map page (/app) is one more fixed page, its script the bundle web/app/ makes (OpenLayers
// and the client of web/client.js, esbuild). Static assets (the shell's and the map page's
// scripts and style sheets) are served
// from `web_dir` under /static/<name>, names checked against the files there (no path).
// Every page and asset carries a Content-Security-Policy that allows scripts, styles and
// connections from this origin only (no inline script) and blob: images (previews fetched with
// the token), plus nosniff and no framing.
// Thread safety: pure functions; the files are read per request.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "daemon/server_api.hpp"

namespace rv::daemon {

inline constexpr std::string_view kContentSecurityPolicy =
    "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' blob: data:; connect-src 'self'; "
    "base-uri 'none'; form-action 'self'; frame-ancestors 'none'";

// The map page's policy: the same, plus what its raster reader needs: WebAssembly (the ZSTD
// decoder, compiled from bytes the bundle carries: 'wasm-unsafe-eval', which allows no eval of
// script), decoding workers started from blob: URLs the bundle makes, and data: fetches (how
// the decoder hands itself its WebAssembly bytes), and style attributes (the map library's
// controls, the scale bar among them, write some as markup; a style attribute runs nothing, and
// no markup from data ever reaches the page). Inline scripts and style elements stay forbidden.
inline constexpr std::string_view kAppContentSecurityPolicy =
    "default-src 'none'; script-src 'self' 'wasm-unsafe-eval'; worker-src blob:; style-src 'self'; "
    "style-src-attr 'unsafe-inline'; "
    "img-src 'self' blob: data:; connect-src 'self' data:; base-uri 'none'; form-action 'none'; "
    "frame-ancestors 'none'";

// Whether `target` is the map page (/app, /app/, any query): open, like the pages.
bool is_app(std::string_view target);

// The map page (`web_dir`/app.html) with the security headers and kAppContentSecurityPolicy.
ApiResponse app_response(const std::string& web_dir);

// Whether a GET/HEAD of `target` (origin form, query included) with this Accept header asks for
// the HTML page of a resource: `f=html` in the query, or no `f` and an Accept header that names
// text/html with a quality above that of application/json (and above that of */*). Result files
// (/jobs/{id}/results/{name}) are never pages.
bool wants_page(std::string_view method, std::string_view target, std::string_view accept);

// Whether the target is a static asset (/static/<name>): open, like the pages.
bool is_asset(std::string_view target);

// The shell page (`web_dir`/page.html, text/html; charset=utf-8) with the security headers.
ApiResponse page_response(const std::string& web_dir);

// /static/<name> from `web_dir`: the file with its media type and the security headers; 404
// problem for a name that is not a plain file name there. Every asset carries a validator (a weak
// ETag from its size and modification time, so a rebuilt bundle is fetched again), and a GET or
// HEAD is answered 304 when If-None-Match matches it (if_none_match_matches); where the build left
// a gzip copy beside it (<name>.gz, as for the map page's bundle) and Accept-Encoding allows gzip,
// that copy is sent (Content-Encoding gzip).
ApiResponse asset_response(const std::string& web_dir, const ApiRequest& request);

// Whether an If-None-Match field value matches `etag`, the current representation's ETag, as
// RFC 9110 13.1.2 says: "*" matches any; otherwise the value must be a comma-separated list of
// entity-tags ([W/]"opaque"), one of which equals `etag` by the weak comparison (W/ ignored, the
// quoted opaque-tags equal). A value that is no such list matches nothing.
bool if_none_match_matches(std::string_view header, std::string_view etag);

// The security headers every page and asset carries.
void add_page_headers(ApiResponse& response, std::string_view policy = kContentSecurityPolicy);

}  // namespace rv::daemon

// The page's static files (io/web/assets/: HTML, CSS, JavaScript, the icon), embedded into the
// binary at build time by embed_assets.cmake.
//
// Why embedded rather than installed to share/hvac-twin/web: the page and the server that
// speaks its API are one version by construction; the same binary works from the build tree
// (tests, the demo) and installed, with no search path to get wrong; and the hardened unit needs
// no read access beyond the binary. The cost is a rebuild to change a file (about 60 KB).
//
// Threads: any; the data is static. Allocation: none.
#pragma once

#include <span>
#include <string_view>

namespace hvac_twin::web {

struct Asset {
  std::string_view path;          // URL path, e.g. "/app.js"
  std::string_view content_type;  // e.g. "text/javascript; charset=utf-8"
  std::string_view body;
};

// Every embedded file (generated: assets_data.cpp in the build tree).
std::span<const Asset> assets() noexcept;

// The asset served at `path` ("/" is "/index.html"), or nullptr.
const Asset* find_asset(std::string_view path) noexcept;

}  // namespace hvac_twin::web

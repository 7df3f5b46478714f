#include "config/load.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <span>
#include <sstream>

#include "config/detail/json_tree.hpp"
#include "config/detail/limits.hpp"
#include "config/detail/reader.hpp"
#include "config/detail/sections.hpp"

namespace hvac_twin::config {
namespace {

using detail::Errors;
using detail::ObjectReader;
using detail::Ref;

constexpr std::uintmax_t kMaxFileBytes = 16u << 20;  // a configuration is a few kB

void read_state_directory(ObjectReader& r, std::string& out) {
  const Ref ref = r.get("state_directory");
  if (!ref.present()) return;
  const auto v = detail::read_string(ref, r.errors());
  if (!v) return;
  const bool control = std::any_of(v->begin(), v->end(), [](char c) {
    return static_cast<unsigned char>(c) < 0x20 || c == 0x7f;
  });
  if (v->empty() || v->size() > detail::kMaxPathLength || control) {
    r.errors().add(*ref.node, ref.pointer,
                   "expected a directory path (absolute, or relative to the working directory), "
                   "1 to 4096 characters without control characters; got " +
                       detail::describe_value(*ref.node));
    return;
  }
  out = *v;
}

void read_units(const Ref& ref, Errors& errors, const detail::UnitContext& context,
                std::vector<UnitConfig>& out) {
  if (!ref.present()) return;
  if (!ref.node->is_array() || ref.node->elements.empty()) {
    errors.add(*ref.node, ref.pointer,
               "expected a non-empty array of units; got " + detail::describe_value(*ref.node));
    return;
  }
  for (std::size_t i = 0; i < ref.node->elements.size(); ++i) {
    const Ref unit = ref.at(i);
    out.push_back(detail::read_unit(unit, errors, context));
    const std::string& id = out.back().id;
    if (id.empty()) continue;  // missing or invalid: reported
    for (std::size_t j = 0; j < i; ++j) {
      if (out[j].id != id) continue;
      const Ref at = unit.at("id");
      errors.add(*at.node, at.pointer,
                 "duplicate unit id " + detail::quote(id) + "; also the id of " +
                     detail::child_pointer(ref.pointer, j));
      break;
    }
  }
}

std::string sanitized(std::string_view s) {
  std::string out;
  for (const char c : s) {
    const auto u = static_cast<unsigned char>(c);
    if (u < 0x20 || u == 0x7f) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(u));
      out += buf;
    } else {
      out += c;
    }
  }
  return out;
}

}  // namespace

LoadResult load_config_text(std::string_view json_text, const ModelCatalog& models) {
  LoadResult result;
  detail::ParsedDocument doc = detail::parse_json(json_text);
  if (!doc.root) {
    result.errors = std::move(doc.errors);
    return result;
  }
  Errors errors;
  const Ref root{&*doc.root, ""};
  detail::report_duplicate_keys(root, errors);

  Config c;
  ObjectReader r(root, errors);
  if (r.ok()) {
    if (const Ref site = r.require("site_id"); site.present()) {
      if (auto v = detail::read_token(site, errors, detail::is_id_char, "[A-Za-z0-9_-]",
                                      detail::kMaxNameLength))
        c.site_id = *v;
    }
    read_state_directory(r, c.state_directory);
    const detail::RuntimeSection runtime = detail::read_runtime(r.get("runtime"), errors);
    c.runtime = runtime.config;
    c.dds = detail::read_dds(r.get("dds"), errors);
    const detail::UnitContext context{models, runtime.time_scale, runtime.hang_timeout_s};
    read_units(r.require("units"), errors, context, c.units);
    r.finish();
  }
  if (errors.empty()) result.config = std::move(c);
  result.more_errors = errors.dropped();
  result.errors = std::move(errors).take_sorted();
  return result;
}

LoadResult load_config_file(const std::string& path, const ModelCatalog& models) {
  const auto fail = [](std::string message) {
    LoadResult r;
    r.errors.push_back({"", std::move(message)});
    return r;
  };
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (ec) return fail("cannot read the file: " + ec.message());
  if (!std::filesystem::is_regular_file(status))
    return fail("cannot read the file: not a regular file");
  const auto size = std::filesystem::file_size(path, ec);
  if (!ec && size > kMaxFileBytes)
    return fail("the file has " + std::to_string(size) +
                " bytes; a configuration file is at most 16 MiB");
  std::ifstream in(path, std::ios::binary);
  if (!in) return fail(std::string("cannot read the file: ") + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) return fail(std::string("cannot read the file: ") + std::strerror(errno));
  return load_config_text(text.str(), models);
}

std::string format_errors(const std::vector<ConfigError>& errors, std::string_view source,
                          std::size_t limit) {
  std::string out;
  for (const auto& e : std::span(errors).first(std::min(limit, errors.size()))) {
    out += sanitized(source);
    out += ": ";
    out += e.pointer.empty() ? std::string("(root)") : sanitized(e.pointer);
    out += ": ";
    out += sanitized(e.message);
    out += '\n';
  }
  return out;
}

}  // namespace hvac_twin::config

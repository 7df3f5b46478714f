#include "config/load.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <span>
#include <sstream>

#include "config/calibration_file.hpp"
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

namespace {

// Reads a whole file of at most kMaxFileBytes into `text`; an empty string, or what was wrong.
std::string read_file(const std::string& path, std::string& text) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (ec) return "cannot read the file: " + ec.message();
  if (!std::filesystem::is_regular_file(status)) return "cannot read the file: not a regular file";
  const auto size = std::filesystem::file_size(path, ec);
  if (!ec && size > kMaxFileBytes)
    return "the file has " + std::to_string(size) + " bytes; the limit is 16 MiB";
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::string("cannot read the file: ") + std::strerror(errno);
  std::ostringstream buffer;
  buffer << in.rdbuf();
  if (in.bad()) return std::string("cannot read the file: ") + std::strerror(errno);
  text = buffer.str();
  return {};
}

std::string pointer_token(const std::string& key) {
  std::string out;
  for (const char c : key)
    out += c == '~' ? std::string("~0") : c == '/' ? std::string("~1") : std::string(1, c);
  return out;
}

// The units' calibration files applied to the (valid) document `text`: each value inserted where
// calibration_file.hpp says, the document validated again, and an error about an inserted value
// told as an error in the calibration file.
LoadResult with_calibrations(const std::string& path, const std::string& text, const Config& config,
                             const ModelCatalog& models) {
  auto doc = nlohmann::ordered_json::parse(text);
  LoadResult out;
  struct Inserted {
    std::string pointer, unit_pointer, where;  // in the document; the unit's key; file + key
  };
  std::vector<Inserted> inserted;
  for (std::size_t i = 0; i < config.units.size(); ++i) {
    const auto& unit = config.units[i];
    if (unit.calibration.empty()) continue;
    const std::string at = "/units/" + std::to_string(i) + "/calibration";
    std::filesystem::path file(unit.calibration);
    if (file.is_relative()) file = std::filesystem::path(path).parent_path() / file;
    std::string cal_text, error;
    if (const auto e = read_file(file.string(), cal_text); !e.empty()) {
      out.errors.push_back({at, file.string() + ": " + e});
      continue;
    }
    const auto cal = read_calibration(cal_text, error);
    if (!cal) {
      out.errors.push_back({at, file.string() + ": " + error});
      continue;
    }
    if (cal->model != unit.model.type || cal->unit != unit.id) {
      out.errors.push_back({at, file.string() + ": a calibration of unit " + cal->unit +
                                    " (model " + cal->model + "), not of unit " + unit.id +
                                    " (model " + unit.model.type + ")"});
      continue;
    }
    auto& ju = doc["units"][i];
    auto insert = [&](const std::map<std::string, double>& values, const char* section,
                      const char* map, const char* key) {
      for (const auto& [name, value] : values) {
        auto& target = ju[section][map];
        const std::string pointer =
            "/units/" + std::to_string(i) + "/" + section + "/" + map + "/" + pointer_token(name);
        const std::string where = file.string() + ": /" + key + "/" + pointer_token(name);
        if (target.contains(name)) {
          out.errors.push_back(
              {at, where + ": the configuration sets it too (" + pointer + "); keep one"});
          continue;
        }
        target[name] = value;
        inserted.push_back({pointer, at, where});
      }
    };
    insert(cal->parameters, "model", "parameters", "parameters");
    insert(cal->initial_std, "estimator", "initial_std", "initial_std");
    // A point's offset is a correction of the reading: added to the configured one.
    for (const auto& [name, correction] : cal->point_offsets) {
      const std::string where = file.string() + ": /point_offsets/" + pointer_token(name);
      auto& points = ju["points"];
      std::size_t j = 0;
      while (j < points.size() && points[j].value("name", std::string()) != name)
        ++j;
      if (j == points.size()) {
        out.errors.push_back({at, where + ": unit " + unit.id + " has no point \"" + name + "\""});
        continue;
      }
      points[j]["offset"] = points[j].value("offset", 0.0) + correction;
      inserted.push_back(
          {"/units/" + std::to_string(i) + "/points/" + std::to_string(j) + "/offset", at, where});
    }
  }
  if (!out.errors.empty()) return out;
  out = load_config_text(doc.dump(), models);
  for (auto& e : out.errors)
    for (const auto& ins : inserted)
      if (e.pointer == ins.pointer || e.pointer.starts_with(ins.pointer + "/")) {
        e.message = ins.where + ": " + e.message;
        e.pointer = ins.unit_pointer;
      }
  return out;
}

}  // namespace

LoadResult load_config_file(const std::string& path, const ModelCatalog& models) {
  std::string text;
  if (const auto e = read_file(path, text); !e.empty()) {
    LoadResult r;
    r.errors.push_back({"", e});
    return r;
  }
  LoadResult r = load_config_text(text, models);
  if (!r.config) return r;
  const bool calibrated = std::any_of(r.config->units.begin(), r.config->units.end(),
                                      [](const UnitConfig& u) { return !u.calibration.empty(); });
  return calibrated ? with_calibrations(path, text, *r.config, models) : r;
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

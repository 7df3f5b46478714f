#include "io/web/json.hpp"

#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "io/dds/echo/format.hpp"

namespace hvac_twin::web {
namespace {

using Json = nlohmann::ordered_json;

std::string dump(const Json& json) {
  // Names come from the network: replace invalid UTF-8 instead of throwing.
  return json.dump(-1, ' ', false, Json::error_handler_t::replace);
}

// A JSON string literal of `text`.
std::string json_string(std::string_view text) {
  return dump(Json(std::string(text)));
}

void append_number(std::string& out, double value) {
  if (!std::isfinite(value)) {
    out += "null";
    return;
  }
  char text[32];
  const int n = std::snprintf(text, sizeof text, "%.6g", value);
  out.append(text, static_cast<std::size_t>(std::max(n, 0)));
}

Json flag_names(std::uint32_t flags) {
  Json names = Json::array();
  for (std::uint32_t bit = 1; bit != 0; bit <<= 1)
    if ((flags & bit) != 0 && !dds::flag_name(bit).empty()) names.push_back(dds::flag_name(bit));
  return names;
}

Json summary(const UnitState& u, std::int64_t now) {
  Json j{{"site", u.site}, {"unit", u.unit}};
  j["stale"] = to_string(u.stale);
  j["age_ms"] = (now - u.last_arrival_ns) / 1'000'000;
  j["period_ms"] = static_cast<double>(u.period_ns) / 1e6;
  j["deadline_ms"] = static_cast<double>(u.deadline_ns()) / 1e6;
  j["records"] = u.records;
  if (u.estimate) {
    j["quality"] = dds::to_string(u.estimate->quality);
    j["flag_names"] = flag_names(u.estimate->flags);
  } else if (u.health) {
    j["quality"] = dds::to_string(u.health->quality);
    j["flag_names"] = Json::array();
  } else {
    j["quality"] = nullptr;
    j["flag_names"] = Json::array();
  }
  if (const auto& h = u.health) {
    j["health"] = {{"cycle", h->cycle},
                   {"timestamp_ns", h->timestamp_ns},
                   {"cycle_time_ms", h->cycle_time_ms},
                   {"modbus_connected", h->modbus_connected},
                   {"modbus_last_error", h->modbus_last_error},
                   {"overruns", h->overruns},
                   {"gate_rejections", h->gate_rejections},
                   {"numerical_resets", h->numerical_resets}};
  } else {
    j["health"] = nullptr;
  }
  if (const auto& l = u.leak) {
    j["leak"] = {{"state", dds::to_string(l->state)},
                 {"hold", dds::to_string(l->hold)},
                 {"quality", dds::to_string(l->quality)},
                 {"charge", l->charge},
                 {"charge_sigma", l->charge_sigma},
                 {"nameplate_charge", l->nameplate_charge},
                 {"charge_reference", l->charge_reference},
                 {"leak_rate", l->leak_rate},
                 {"leak_rate_sigma", l->leak_rate_sigma},
                 {"cusum", l->cusum},
                 {"threshold", l->threshold},
                 {"suspect_since_ns", l->suspect_since_ns},
                 {"leak_since_ns", l->leak_since_ns}};
  } else {
    j["leak"] = nullptr;
  }
  if (const auto* c = u.pooled_consistency()) {
    j["consistency"] = {{"verdict", dds::to_string(c->verdict)},
                        {"mean_nis", c->mean_nis},
                        {"band_low", c->band_low},
                        {"band_high", c->band_high},
                        {"rejected_share", c->rejected_share}};
  } else {
    j["consistency"] = nullptr;
  }
  return j;
}

// "[a,b,c]" of already encoded JSON documents.
template <class Items, class Encode>
void append_array(std::string& out, const Items& items, Encode encode) {
  out += '[';
  bool first = true;
  for (const auto& item : items) {
    if (!first) out += ',';
    first = false;
    out += encode(item);
  }
  out += ']';
}

}  // namespace

std::string sse_event(std::string_view event, std::string_view data) {
  std::string out;
  out.reserve(event.size() + data.size() + 16);
  out += "event: ";
  out += event;
  out += '\n';
  // Every line of the data gets its own "data:" field; the browser joins them with '\n'.
  for (;;) {
    const std::size_t nl = data.find_first_of("\r\n");
    out += "data: ";
    out += data.substr(0, nl);
    out += '\n';
    if (nl == std::string_view::npos) break;
    const std::size_t skip = data.compare(nl, 2, "\r\n") == 0 ? 2 : 1;
    data.remove_prefix(nl + skip);
  }
  out += '\n';
  return out;
}

std::string record_json(const dds::Record& record) {
  return dds::echo::to_json_line(record);
}

std::string summary_json(const UnitState& unit, std::int64_t now) {
  return dump(summary(unit, now));
}

std::string overview_json(const Store& store, std::int64_t now, const ServerFacts& facts) {
  std::string out = "{\"units\":[";
  for (std::size_t i = 0; i < store.size(); ++i) {
    if (i > 0) out += ',';
    out += summary_json(store.unit(i), now);
  }
  const StoreCounters& c = store.counters();
  out += "],\"server\":";
  out += dump(Json{{"clients", facts.clients},
                   {"resyncs", facts.resyncs},
                   {"records", c.records},
                   {"refused_units", c.refused_units},
                   {"refused_keys", c.refused_keys},
                   {"refused_series", c.refused_series},
                   {"max_units", store.limits().max_units},
                   {"fine_capacity", facts.fine_capacity},
                   {"minute_capacity", facts.minute_capacity}});
  out += '}';
  return out;
}

std::string unit_json(const UnitState& u, std::int64_t now) {
  std::string out = "{\"summary\":";
  out += summary_json(u, now);
  out += ",\"health\":";
  out += u.health ? record_json(*u.health) : "null";
  out += ",\"leak\":";
  out += u.leak ? record_json(*u.leak) : "null";
  out += ",\"sensors\":";
  append_array(out, u.sensors, [](const auto& r) { return record_json(r); });
  out += ",\"observations\":";
  append_array(out, u.observations, [](const auto& r) { return record_json(r); });
  out += ",\"consistency\":";
  append_array(out, u.consistency, [](const auto& r) { return record_json(r); });
  out += '}';
  return out;
}

std::vector<CollectedSeries> collect_history(const UnitState& unit, const HistoryRequest& request) {
  std::vector<CollectedSeries> out;
  out.reserve(unit.series.size());
  for (const auto& s : unit.series)
    out.push_back({s->key, s->eng_unit,
                   s->series.window(request.now_ms, request.window_ms, request.max_points)});
  return out;
}

std::string history_json(std::string_view site, std::string_view unit,
                         const HistoryRequest& request,
                         const std::vector<CollectedSeries>& series) {
  std::string out =
      "{\"site\":" + json_string(site) + ",\"unit\":" + json_string(unit) + ",\"window_s\":";
  append_number(out, static_cast<double>(request.window_ms) / 1000.0);
  out += ",\"now_ms\":" + std::to_string(request.now_ms) + ",\"series\":{";
  bool first = true;
  for (const auto& s : series) {
    if (!first) out += ',';
    first = false;
    out += json_string(s.key) + ":{\"unit\":" + json_string(s.eng_unit) + ",\"resolution\":\"" +
           (s.window.minute_resolution ? "minute" : "sample") + "\"";
    const auto field = [&](const char* name, auto get) {
      out += ",\"";
      out += name;
      out += "\":";
      append_array(out, s.window.points, [&](const SeriesPoint& p) {
        std::string n;
        get(n, p);
        return n;
      });
    };
    field("t", [](std::string& n, const SeriesPoint& p) { n = std::to_string(p.t_ms); });
    field("v", [](std::string& n, const SeriesPoint& p) { append_number(n, p.value); });
    field("s", [](std::string& n, const SeriesPoint& p) { append_number(n, p.sigma); });
    field("lo", [](std::string& n, const SeriesPoint& p) { append_number(n, p.lo); });
    field("hi", [](std::string& n, const SeriesPoint& p) { append_number(n, p.hi); });
    out += '}';
  }
  out += "}}";
  return out;
}

}  // namespace hvac_twin::web

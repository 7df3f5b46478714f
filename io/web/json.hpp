// What hvac-twin-web sends to browsers: the JSON documents of its API and the Server-Sent Events
// framing. The records themselves go out in hvac-twin-echo's JSON (io/dds/echo/format.hpp), so
// the page and `hvac-twin-echo --format json` speak the same language.
//
// Pure functions of the Store's data (no I/O, no clock: `now` is passed in, CLOCK_MONOTONIC ns).
// They allocate the returned strings. Threads: the caller holds whatever lock guards the Store
// (collect_history copies what history_json needs, so the lock can be released before it).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "io/dds/subscriber.hpp"
#include "io/web/store.hpp"

namespace hvac_twin::web {

// One Server-Sent Event: "event: <event>\ndata: <line>\n" per line of data, then a blank line.
// `event` must not contain a line break (it is one of ours).
std::string sse_event(std::string_view event, std::string_view data);

// A record in hvac-twin-echo's JSON ({"topic":..., every field}).
std::string record_json(const dds::Record& record);

// The overview tile of a unit: identity, stale state and since when, leak state and why it is
// held, estimate quality and flags, the pooled consistency verdict, Modbus, the last cycle.
std::string summary_json(const UnitState& unit, std::int64_t now);

// Facts about the server the page shows in its footer.
struct ServerFacts {
  std::size_t clients = 0;
  std::uint64_t resyncs = 0;
  std::size_t fine_capacity = 0;
  std::size_t minute_capacity = 0;
};

// {"units":[summary...], "server":{...}}: every unit the store holds, in order of appearance.
std::string overview_json(const Store& store, std::int64_t now, const ServerFacts& facts);

// Everything latest of one unit: its summary, health, leak diagnosis, virtual sensors (the
// model's order), observations and consistency, each record in echo's JSON.
std::string unit_json(const UnitState& unit, std::int64_t now);

struct HistoryRequest {
  std::int64_t now_ms = 0;     // the window ends here (CLOCK_REALTIME, as the samples' stamps)
  std::int64_t window_ms = 0;  // and reaches back this far
  std::size_t max_points = 300;
};

struct CollectedSeries {
  std::string key;
  std::string eng_unit;
  SeriesWindow window;
};

// Copies the window of every series of `unit` (to encode after the Store's lock is released).
std::vector<CollectedSeries> collect_history(const UnitState& unit, const HistoryRequest& request);

// {"site","unit","window_s","series":{key:{"unit","resolution","t":[ms...],"v","s","lo","hi"}}}
// Numbers to 6 significant digits; t in ms since the epoch.
std::string history_json(std::string_view site, std::string_view unit,
                         const HistoryRequest& request, const std::vector<CollectedSeries>& series);

}  // namespace hvac_twin::web

// What hvac-twin-web knows about the site: per unit the latest sample of every topic, a bounded
// history per series (history.hpp), and whether the unit is stale. Fed with the DDS records in
// arrival order; read by the HTTP side through the JSON encoders (json.hpp).
//
// Bounds (StoreLimits): at most max_units units, max_keys_per_unit keys (virtual sensors,
// observed points, consistency entries) and max_series_per_unit series per unit; a record over a
// bound is refused and counted, never stored. With the series' fixed rings the memory is bounded
// by max_units x max_series_per_unit x Series::bytes_for(...) (history_budget_bytes()).
//
// Stale: a unit is stale when the liveliness of its publisher was lost (Subscriber's
// InstanceLost, or no live writer at all) until its next sample, or when no sample of it arrived
// for 2.5 x its period (the topics' DDS deadline, io/dds/qos.hpp), the period learnt from its
// health samples' timestamps and cycle counters.
//
// Time is data: `now` is CLOCK_MONOTONIC [ns], passed in. Threads: not thread-safe; Dashboard
// serialises access. Allocation: ingesting a record of a new key allocates (and reserves the
// series' rings); records of known keys allocate only to copy their strings.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "io/dds/subscriber.hpp"
#include "io/web/history.hpp"

namespace hvac_twin::web {

struct StoreLimits {
  std::size_t max_units = 64;
  std::size_t max_keys_per_unit = 200;   // virtual sensors + points + consistency entries
  std::size_t max_series_per_unit = 96;  // heat pump: 24 sensors + 2 x 7 points + 5 = 43
  std::size_t fine_capacity = 720;       // samples: 1 h at the 5 s period
  std::size_t minute_capacity = 1440;    // minute buckets: 24 h
};

enum class Stale : std::uint8_t {
  kNo = 0,
  kLiveliness = 1,   // its publisher's liveliness was lost (killed, hung, or gone)
  kDeadline = 2,     // no sample for 2.5 x its period
  kNoPublisher = 3,  // no live writer on the topics at all
};
std::string_view to_string(Stale stale) noexcept;  // "NO", "LIVELINESS_LOST", ...

// An unambiguous key for (site, unit) whatever characters the names hold
// ("<len(site)>:<site><unit>"): the Store's index and the Hub's stream filter. Allocates.
std::string unit_key(std::string_view site, std::string_view unit);

struct NamedSeries {
  std::string key;       // "vs/<name>", "obs/<point>/innovation", "leak/charge", ...
  std::string eng_unit;  // e.g. "K", "" for a ratio
  Series series;
};

struct UnitState {
  std::string site, unit;
  std::optional<dds::HealthRecord> health;
  std::optional<dds::LeakDiagnosticRecord> leak;
  std::optional<dds::UnitEstimateRecord> estimate;  // the cycle's quality and flags; no entries
  std::vector<dds::VirtualSensorRecord> sensors;    // in the model's order once known
  std::vector<dds::ObservationRecord> observations;
  std::vector<dds::ConsistencyRecord> consistency;
  std::vector<std::unique_ptr<NamedSeries>> series;
  std::map<std::string, std::size_t, std::less<>> series_index;

  std::int64_t last_arrival_ns = 0;  // CLOCK_MONOTONIC of its last record
  std::int64_t period_ns = 0;        // learnt; 0 while unknown
  bool liveliness_lost = false;
  Stale stale = Stale::kNo;
  std::uint64_t records = 0;

  // The deadline (2.5 x period) [ns], 0 while the period is unknown.
  std::int64_t deadline_ns() const noexcept { return period_ns * 5 / 2; }
  const NamedSeries* find_series(std::string_view key) const;
  const dds::ConsistencyRecord* pooled_consistency() const;  // point "*"
};

struct StoreCounters {
  std::uint64_t records = 0;
  std::uint64_t refused_units = 0;   // records of units over max_units
  std::uint64_t refused_keys = 0;    // records of keys over max_keys_per_unit
  std::uint64_t refused_series = 0;  // series over max_series_per_unit
};

class Store {
 public:
  explicit Store(StoreLimits limits = {});

  // Stores one record that arrived at `now`. Returns the unit's index, or -1 when refused.
  // *summary_changed (if given) is set when the unit's overview tile changes (health, leak,
  // estimate quality, a stale unit coming back, a new unit).
  int ingest(const dds::Record& record, std::int64_t now, bool* summary_changed = nullptr);
  // The publisher of the unit lost liveliness: stale until its next sample. Returns the unit's
  // index when that changed its state, else -1 (unknown unit or already stale so).
  int mark_liveliness_lost(std::string_view site, std::string_view unit);
  // No live writer on the topics at all: every unit is stale. Appends units that changed.
  void mark_all_liveliness_lost(std::vector<int>& changed);
  // Re-evaluates every unit's deadline at `now`; appends the units whose stale state changed.
  void check_deadlines(std::int64_t now, std::vector<int>& changed);
  // The earliest `now` at which check_deadlines may turn a unit stale (INT64_MAX: none).
  std::int64_t next_deadline() const noexcept;

  std::size_t size() const noexcept { return units_.size(); }
  const UnitState& unit(std::size_t index) const { return *units_[index]; }
  int find(std::string_view site, std::string_view unit) const;
  const StoreCounters& counters() const noexcept { return counters_; }
  const StoreLimits& limits() const noexcept { return limits_; }
  // The most heap bytes the series' rings of all units may take (every bound reached).
  std::size_t history_budget_bytes() const noexcept;

 private:
  int unit_index(const std::string& site, const std::string& unit);
  Series* series(UnitState& u, std::string_view key, std::string_view eng_unit);
  void add(UnitState& u, std::string_view key, std::string_view eng_unit, std::int64_t t_ns,
           double value, double sigma);
  bool ingest_into(UnitState& u, const dds::Record& record);
  void update_stale(UnitState& u, std::int64_t now, std::vector<int>* changed, int index);

  StoreLimits limits_;
  std::vector<std::unique_ptr<UnitState>> units_;
  std::map<std::string, int, std::less<>> index_;  // by unit_key()
  StoreCounters counters_;
};

}  // namespace hvac_twin::web

#include "io/web/store.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>

namespace hvac_twin::web {
namespace {

// The entry of `items` whose `field` is `name`, appended when absent and `room` allows; nullptr
// when absent and there is no room.
template <class T, class F>
T* find_or_add(std::vector<T>& items, F field, std::string_view name, bool room) {
  for (T& item : items)
    if (item.*field == name) return &item;
  if (!room) return nullptr;
  return &items.emplace_back();
}

// The periods a unit may learn (io/dds/qos.hpp accepts up to 24 h) [ns].
constexpr std::int64_t kMinPeriodNs = 1'000'000;
constexpr std::int64_t kMaxPeriodNs = 24LL * 3600 * 1'000'000'000;

std::int64_t ms(std::int64_t ns) {
  return ns / 1'000'000;
}

}  // namespace

std::string unit_key(std::string_view site, std::string_view unit) {
  std::string key = std::to_string(site.size());
  key += ':';
  key += site;
  key += unit;
  return key;
}

std::string_view to_string(Stale stale) noexcept {
  switch (stale) {
    case Stale::kNo:
      return "NO";
    case Stale::kLiveliness:
      return "LIVELINESS_LOST";
    case Stale::kDeadline:
      return "DEADLINE_MISSED";
    case Stale::kNoPublisher:
      return "NO_PUBLISHER";
  }
  return "UNKNOWN";
}

const NamedSeries* UnitState::find_series(std::string_view key) const {
  const auto it = series_index.find(key);
  return it == series_index.end() ? nullptr : series[it->second].get();
}

const dds::ConsistencyRecord* UnitState::pooled_consistency() const {
  for (const auto& c : consistency)
    if (c.point == dds::kAllPoints) return &c;
  return nullptr;
}

Store::Store(StoreLimits limits) : limits_(limits) {}

std::size_t Store::history_budget_bytes() const noexcept {
  return limits_.max_units * limits_.max_series_per_unit *
         Series::bytes_for(limits_.fine_capacity, limits_.minute_capacity);
}

int Store::find(std::string_view site, std::string_view unit) const {
  const auto it = index_.find(unit_key(site, unit));
  return it == index_.end() ? -1 : it->second;
}

int Store::unit_index(const std::string& site, const std::string& unit) {
  std::string key = unit_key(site, unit);
  if (const auto it = index_.find(key); it != index_.end()) return it->second;
  if (units_.size() >= limits_.max_units) {
    ++counters_.refused_units;
    return -1;
  }
  auto u = std::make_unique<UnitState>();
  u->site = site;
  u->unit = unit;
  units_.push_back(std::move(u));
  const int index = static_cast<int>(units_.size() - 1);
  index_.emplace(std::move(key), index);
  return index;
}

Series* Store::series(UnitState& u, std::string_view key, std::string_view eng_unit) {
  if (const auto it = u.series_index.find(key); it != u.series_index.end())
    return &u.series[it->second]->series;
  if (u.series.size() >= limits_.max_series_per_unit) {
    ++counters_.refused_series;
    return nullptr;
  }
  u.series.push_back(std::make_unique<NamedSeries>(
      NamedSeries{std::string(key), std::string(eng_unit),
                  Series(limits_.fine_capacity, limits_.minute_capacity)}));
  u.series_index.emplace(std::string(key), u.series.size() - 1);
  return &u.series.back()->series;
}

void Store::add(UnitState& u, std::string_view key, std::string_view eng_unit, std::int64_t t_ns,
                double value, double sigma) {
  if (Series* s = series(u, key, eng_unit)) s->add(ms(t_ns), value, sigma);
}

// Stores the record in its unit; false when a bound refused it.
bool Store::ingest_into(UnitState& u, const dds::Record& record) {
  const std::size_t keys = u.sensors.size() + u.observations.size() + u.consistency.size();
  const bool room = keys < limits_.max_keys_per_unit;
  bool stored = true;
  std::visit(
      [&](const auto& r) {
        using T = std::decay_t<decltype(r)>;
        if constexpr (std::is_same_v<T, dds::VirtualSensorRecord>) {
          auto* slot = find_or_add(u.sensors, &dds::VirtualSensorRecord::name, r.name, room);
          if (!slot) return void(stored = false);
          *slot = r;
          add(u, "vs/" + r.name, r.eng_unit, r.timestamp_ns, r.value, r.sigma);
        } else if constexpr (std::is_same_v<T, dds::ObservationRecord>) {
          auto* slot = find_or_add(u.observations, &dds::ObservationRecord::point, r.point, room);
          if (!slot) return void(stored = false);
          *slot = r;
          add(u, "obs/" + r.point + "/innovation", "", r.timestamp_ns, r.innovation,
              std::sqrt(std::max(r.innovation_variance, 0.0)));
          add(u, "obs/" + r.point + "/test_ratio", "", r.timestamp_ns, r.test_ratio, 0.0);
        } else if constexpr (std::is_same_v<T, dds::HealthRecord>) {
          // The period from consecutive health samples: their stamps over the cycles between.
          if (u.health && r.cycle > u.health->cycle && r.timestamp_ns > u.health->timestamp_ns) {
            const auto period = (r.timestamp_ns - u.health->timestamp_ns) /
                                static_cast<std::int64_t>(r.cycle - u.health->cycle);
            u.period_ns = std::clamp<std::int64_t>(period, kMinPeriodNs, kMaxPeriodNs);
          }
          u.health = r;
          add(u, "health/cycle_time_ms", "ms", r.timestamp_ns, r.cycle_time_ms, 0.0);
        } else if constexpr (std::is_same_v<T, dds::LeakDiagnosticRecord>) {
          u.leak = r;
          add(u, "leak/charge", "kg", r.timestamp_ns, r.charge, r.charge_sigma);
          add(u, "leak/leak_rate", "g/h", r.timestamp_ns, r.leak_rate, r.leak_rate_sigma);
          add(u, "leak/rate_cusum", "σ", r.timestamp_ns, r.rate_cusum, 0.0);
          add(u, "leak/charge_cusum", "σ", r.timestamp_ns, r.charge_cusum, 0.0);
        } else if constexpr (std::is_same_v<T, dds::ConsistencyRecord>) {
          auto* slot = find_or_add(u.consistency, &dds::ConsistencyRecord::point, r.point, room);
          if (!slot) return void(stored = false);
          *slot = r;
        } else if constexpr (std::is_same_v<T, dds::UnitEstimateRecord>) {
          // Every virtual sensor of the cycle, in the model's order: the sensors take that order.
          std::vector<dds::VirtualSensorRecord> ordered;
          ordered.reserve(std::max(r.estimates.size(), u.sensors.size()));
          for (const auto& e : r.estimates) {
            dds::VirtualSensorRecord vs;
            vs.site = r.site;
            vs.unit = r.unit;
            vs.name = e.name;
            vs.value = e.value;
            vs.sigma = e.sigma;
            vs.eng_unit = e.eng_unit;
            vs.quality = r.quality;
            vs.flags = r.flags;
            vs.fused_points = r.fused_points;
            vs.timestamp_ns = r.timestamp_ns;
            vs.cycle = r.cycle;
            vs.source_timestamp_ns = r.source_timestamp_ns;
            const auto* old =
                find_or_add(u.sensors, &dds::VirtualSensorRecord::name, e.name, false);
            if (!old && ordered.size() >= limits_.max_keys_per_unit) continue;
            add(u, "vs/" + e.name, e.eng_unit, r.timestamp_ns, e.value, e.sigma);
            ordered.push_back(std::move(vs));
          }
          for (auto& old : u.sensors)  // sensors this sample did not carry stay, at the end
            if (std::none_of(ordered.begin(), ordered.end(),
                             [&](const auto& o) { return o.name == old.name; }))
              ordered.push_back(std::move(old));
          u.sensors = std::move(ordered);
          u.estimate = r;
          u.estimate->estimates.clear();
        }
      },
      record);
  if (!stored) ++counters_.refused_keys;
  return stored;
}

int Store::ingest(const dds::Record& record, std::int64_t now, bool* summary_changed) {
  if (summary_changed) *summary_changed = false;
  const auto [site, unit] = std::visit(
      [](const auto& r) {
        return std::pair<const std::string&, const std::string&>(r.site, r.unit);
      },
      record);
  const std::size_t before = units_.size();
  const int index = unit_index(site, unit);
  if (index < 0) return -1;
  ++counters_.records;
  UnitState& u = *units_[index];
  if (!ingest_into(u, record)) return -1;
  ++u.records;
  u.last_arrival_ns = now;
  const bool was_stale = u.stale != Stale::kNo;
  u.liveliness_lost = false;
  u.stale = Stale::kNo;
  if (summary_changed) {
    const bool tile = std::holds_alternative<dds::HealthRecord>(record) ||
                      std::holds_alternative<dds::LeakDiagnosticRecord>(record) ||
                      std::holds_alternative<dds::UnitEstimateRecord>(record) ||
                      (std::holds_alternative<dds::ConsistencyRecord>(record) &&
                       std::get<dds::ConsistencyRecord>(record).point == dds::kAllPoints);
    *summary_changed = tile || was_stale || units_.size() != before;
  }
  return index;
}

int Store::mark_liveliness_lost(std::string_view site, std::string_view unit) {
  const int index = find(site, unit);
  if (index < 0) return -1;
  UnitState& u = *units_[index];
  if (u.liveliness_lost) return -1;
  u.liveliness_lost = true;
  u.stale = Stale::kLiveliness;
  return index;
}

void Store::mark_all_liveliness_lost(std::vector<int>& changed) {
  for (std::size_t i = 0; i < units_.size(); ++i) {
    UnitState& u = *units_[i];
    if (u.liveliness_lost) continue;
    u.liveliness_lost = true;
    u.stale = Stale::kNoPublisher;
    changed.push_back(static_cast<int>(i));
  }
}

void Store::update_stale(UnitState& u, std::int64_t now, std::vector<int>* changed, int index) {
  if (u.liveliness_lost) return;  // stays so until the next sample
  const std::int64_t deadline = u.deadline_ns();
  const Stale stale =
      deadline > 0 && now - u.last_arrival_ns > deadline ? Stale::kDeadline : Stale::kNo;
  if (stale != u.stale) {
    u.stale = stale;
    if (changed) changed->push_back(index);
  }
}

void Store::check_deadlines(std::int64_t now, std::vector<int>& changed) {
  for (std::size_t i = 0; i < units_.size(); ++i)
    update_stale(*units_[i], now, &changed, static_cast<int>(i));
}

std::int64_t Store::next_deadline() const noexcept {
  std::int64_t next = std::numeric_limits<std::int64_t>::max();
  for (const auto& u : units_)
    if (u->stale == Stale::kNo && u->deadline_ns() > 0)
      next = std::min(next, u->last_arrival_ns + u->deadline_ns() + 1);
  return next;
}

}  // namespace hvac_twin::web

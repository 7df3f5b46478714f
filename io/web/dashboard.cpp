#include "io/web/dashboard.hpp"

#include <algorithm>
#include <memory>
#include <utility>

namespace hvac_twin::web {
namespace {

Event make_event(std::string_view name, std::string_view data) {
  return std::make_shared<const std::string>(sse_event(name, data));
}

}  // namespace

Dashboard::Dashboard(StoreLimits store_limits, HubLimits hub_limits)
    : store_(store_limits), hub_(hub_limits) {}

void Dashboard::ingest(const std::vector<dds::Record>& records,
                       const std::vector<dds::InstanceLost>& lost, std::int64_t now) {
  struct Pending {
    std::string unit_key;
    Event event;
  };
  std::vector<Pending> pending;  // handed to the Hub once the store's lock is released
  std::vector<int> changed;
  {
    const std::lock_guard lock(mutex_);
    for (const dds::Record& record : records) {
      bool summary_changed = false;
      const int index = store_.ingest(record, now, &summary_changed);
      if (index < 0) continue;
      if (summary_changed && std::find(changed.begin(), changed.end(), index) == changed.end())
        changed.push_back(index);
      const UnitState& u = store_.unit(static_cast<std::size_t>(index));
      std::string key = unit_key(u.site, u.unit);
      if (!hub_.follows(key)) continue;  // nobody watches this unit: no need to encode
      pending.push_back({std::move(key), make_event("record", record_json(record))});
    }
    for (const dds::InstanceLost& l : lost) {
      const int index = store_.mark_liveliness_lost(l.site, l.unit);
      if (index >= 0 && std::find(changed.begin(), changed.end(), index) == changed.end())
        changed.push_back(index);
    }
  }
  for (const Pending& p : pending)
    hub_.publish(p.unit_key, false, p.event);
  publish_summaries(changed, now);
}

void Dashboard::publishers_lost(std::int64_t now) {
  std::vector<int> changed;
  {
    const std::lock_guard lock(mutex_);
    store_.mark_all_liveliness_lost(changed);
  }
  publish_summaries(changed, now);
}

std::int64_t Dashboard::tick(std::int64_t now) {
  std::vector<int> changed;
  std::int64_t next = 0;
  {
    const std::lock_guard lock(mutex_);
    store_.check_deadlines(now, changed);
    next = store_.next_deadline();
  }
  publish_summaries(changed, now);
  return next;
}

void Dashboard::publish_summaries(const std::vector<int>& changed, std::int64_t now) {
  if (changed.empty()) return;
  std::vector<std::pair<std::string, Event>> events;
  {
    const std::lock_guard lock(mutex_);
    for (const int index : changed) {
      const UnitState& u = store_.unit(static_cast<std::size_t>(index));
      events.emplace_back(unit_key(u.site, u.unit), make_event("summary", summary_json(u, now)));
    }
  }
  for (const auto& [key, event] : events)
    hub_.publish(key, true, event);
}

std::string Dashboard::overview(std::int64_t now) const {
  const HubStats hub = hub_.stats();
  const std::lock_guard lock(mutex_);
  return overview_json(store_, now,
                       ServerFacts{hub.clients, hub.resyncs, store_.limits().fine_capacity,
                                   store_.limits().minute_capacity});
}

std::optional<std::string> Dashboard::unit(std::string_view site, std::string_view unit,
                                           std::int64_t now) const {
  const std::lock_guard lock(mutex_);
  const int index = store_.find(site, unit);
  if (index < 0) return std::nullopt;
  return unit_json(store_.unit(static_cast<std::size_t>(index)), now);
}

std::optional<std::string> Dashboard::history(std::string_view site, std::string_view unit,
                                              const HistoryRequest& request) const {
  std::vector<CollectedSeries> series;
  {
    const std::lock_guard lock(mutex_);
    const int index = store_.find(site, unit);
    if (index < 0) return std::nullopt;
    series = collect_history(store_.unit(static_cast<std::size_t>(index)), request);
  }
  return history_json(site, unit, request, series);
}

std::size_t Dashboard::units() const {
  const std::lock_guard lock(mutex_);
  return store_.size();
}

}  // namespace hvac_twin::web

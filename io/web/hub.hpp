// The fan-out from the DDS side to the browsers' Server-Sent Event streams.
//
// Each connected stream is a Client with a bounded queue of framed events (shared, never copied
// per client). The publishing side (the DDS thread) only appends to those queues under each
// client's own short lock and signals; it never touches a socket and never waits for a browser.
// A client whose queue is full (a slow or vanished browser) loses its queue and gets a single
// "resync" instead: the page then fetches the current state again. The HTTP thread serving the
// stream takes events out and writes them, with the socket's write timeout as its only wait.
//
// Threads: every member is safe to call from any thread. Allocation: subscribe() allocates the
// client; publish() allocates a queue node per receiving client (bounded by the limits).
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

namespace hvac_twin::web {

using Event = std::shared_ptr<const std::string>;  // one framed SSE event

struct HubLimits {
  std::size_t max_clients = 32;             // open event streams; more are refused (HTTP 503)
  std::size_t max_queued_events = 4096;     // per client: about 100 cycles of a heat pump
  std::size_t max_queued_bytes = 2u << 20;  // per client
};

struct HubStats {
  std::size_t clients = 0;
  std::uint64_t resyncs = 0;          // queues dropped for a slow client
  std::uint64_t refused_clients = 0;  // streams refused over max_clients
};

class Hub {
 public:
  class Client;

  explicit Hub(HubLimits limits = {});
  ~Hub();
  Hub(const Hub&) = delete;
  Hub& operator=(const Hub&) = delete;

  // A stream of the overview (unit_key empty: every unit's summary) or of one unit (its summary
  // and records). nullptr when max_clients streams are open or the hub is closed.
  std::shared_ptr<Client> subscribe(std::string unit_key);
  void unsubscribe(const std::shared_ptr<Client>& client) noexcept;

  // Queues `event` for the streams of `unit_key`, and with `overview` also for the overview
  // streams. Never blocks on a client.
  void publish(std::string_view unit_key, bool overview, const Event& event);
  // Whether any stream follows `unit_key` (so the caller may skip encoding its records).
  bool follows(std::string_view unit_key) const;

  enum class Next { kEvent, kResync, kTimeout, kClosed };
  // Waits up to `timeout` for the client's next event (into `event`). kResync: its queue
  // overflowed and was dropped. kClosed: the hub was closed.
  Next next(Client& client, std::chrono::milliseconds timeout, Event& event);

  // Wakes every waiting stream with kClosed; later subscribe() calls get nullptr.
  void close();
  HubStats stats() const;

 private:
  HubLimits limits_;
  mutable std::mutex mutex_;  // guards clients_, closed_, stats_
  std::vector<std::shared_ptr<Client>> clients_;
  bool closed_ = false;
  HubStats stats_;
};

// One open event stream (opaque outside hub.cpp except for its filter).
class Hub::Client {
 public:
  explicit Client(std::string unit_key) : unit_key_(std::move(unit_key)) {}
  const std::string& unit_key() const { return unit_key_; }

 private:
  friend class Hub;
  const std::string unit_key_;
  std::mutex mutex_;  // guards the rest
  std::condition_variable ready_;
  std::deque<Event> queue_;
  std::size_t queued_bytes_ = 0;
  bool resync_ = false;
  bool closed_ = false;
};

}  // namespace hvac_twin::web

#include "io/web/hub.hpp"

#include <algorithm>

namespace hvac_twin::web {

Hub::Hub(HubLimits limits) : limits_(limits) {}

Hub::~Hub() {
  close();
}

std::shared_ptr<Hub::Client> Hub::subscribe(std::string unit_key) {
  const std::lock_guard lock(mutex_);
  if (closed_ || clients_.size() >= limits_.max_clients) {
    ++stats_.refused_clients;
    return nullptr;
  }
  auto client = std::make_shared<Client>(std::move(unit_key));
  clients_.push_back(client);
  return client;
}

void Hub::unsubscribe(const std::shared_ptr<Client>& client) noexcept {
  const std::lock_guard lock(mutex_);
  std::erase(clients_, client);
}

void Hub::publish(std::string_view unit_key, bool overview, const Event& event) {
  const std::lock_guard lock(mutex_);
  for (const auto& client : clients_) {
    const bool wants = client->unit_key_.empty() ? overview : client->unit_key_ == unit_key;
    if (!wants) continue;
    {
      const std::lock_guard client_lock(client->mutex_);
      if (client->closed_) continue;
      if (client->resync_) continue;  // its queue is gone; the page will fetch the state anew
      if (client->queue_.size() >= limits_.max_queued_events ||
          client->queued_bytes_ + event->size() > limits_.max_queued_bytes) {
        client->queue_.clear();  // drop and resync, never wait for the browser
        client->queued_bytes_ = 0;
        client->resync_ = true;
        ++stats_.resyncs;
      } else {
        client->queue_.push_back(event);
        client->queued_bytes_ += event->size();
      }
    }
    client->ready_.notify_one();
  }
}

bool Hub::follows(std::string_view unit_key) const {
  const std::lock_guard lock(mutex_);
  return std::any_of(clients_.begin(), clients_.end(),
                     [&](const auto& c) { return c->unit_key_ == unit_key; });
}

Hub::Next Hub::next(Client& client, std::chrono::milliseconds timeout, Event& event) {
  std::unique_lock lock(client.mutex_);
  client.ready_.wait_for(
      lock, timeout, [&] { return client.closed_ || client.resync_ || !client.queue_.empty(); });
  if (client.closed_) return Next::kClosed;
  if (client.resync_) {
    client.resync_ = false;
    return Next::kResync;
  }
  if (client.queue_.empty()) return Next::kTimeout;
  event = std::move(client.queue_.front());
  client.queue_.pop_front();
  client.queued_bytes_ -= event->size();
  return Next::kEvent;
}

void Hub::close() {
  const std::lock_guard lock(mutex_);
  closed_ = true;
  for (const auto& client : clients_) {
    {
      const std::lock_guard client_lock(client->mutex_);
      client->closed_ = true;
    }
    client->ready_.notify_all();
  }
}

HubStats Hub::stats() const {
  const std::lock_guard lock(mutex_);
  HubStats s = stats_;
  s.clients = clients_.size();
  return s;
}

}  // namespace hvac_twin::web

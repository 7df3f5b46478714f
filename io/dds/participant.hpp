// A Cyclone DDS domain participant configured from config::DdsConfig, with the network
// configuration built in code: pinned to one interface, multicast as configured (default off),
// unicast discovery to the configured peers (default 127.0.0.1).
//
// Cyclone allows one domain instance per domain id per process. Participants created here for
// the same domain id share it (reference counted); they must then agree on the configuration,
// otherwise construction throws. Cyclone's CYCLONEDDS_URI environment variable is NOT read: the
// configuration comes from DdsConfig only (pass extra XML explicitly, see the constructor).
//
// Threads: construct and destroy on one thread at start-up/shut-down; the handle may be used
// from any thread (Cyclone entities are thread-safe). Allocation and exceptions: constructor only.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "config/config.hpp"

namespace hvac_twin::dds {

class Participant {
 public:
  // Creates (or joins, see above) the domain config.domain_id and a participant in it.
  // extra_xml: further Cyclone configuration fragments (e.g. <Security>...</Security> or
  // <Tracing>...</Tracing>), applied after the generated network settings; empty for none.
  // Throws std::invalid_argument for a bad domain id, interface or peer, and std::runtime_error
  // naming the domain and interface if Cyclone refuses the domain or the participant.
  explicit Participant(const config::DdsConfig& config, std::string_view extra_xml = {});
  ~Participant();
  Participant(const Participant&) = delete;
  Participant& operator=(const Participant&) = delete;
  Participant(Participant&&) = delete;
  Participant& operator=(Participant&&) = delete;

  int domain_id() const noexcept { return domain_id_; }
  const std::string& interface_name() const noexcept { return interface_; }
  // The Cyclone dds_entity_t of the participant, for io/dds internals only.
  std::int32_t native_handle() const noexcept { return participant_; }

 private:
  int domain_id_;
  std::string interface_;
  std::int32_t participant_ = 0;
};

// The Cyclone XML configuration for `config` (what the participant uses, without extra_xml).
// Throws std::invalid_argument if the interface or a peer contains characters outside
// [A-Za-z0-9_.:-] (interface) / [A-Za-z0-9_.:-[]] (peer), or if there is no peer while
// multicast is off.
std::string make_cyclone_config(const config::DdsConfig& config);

// Participant indices Cyclone may hand out per domain on one host (MaxAutoParticipantIndex):
// room for the daemon, the echo tool, dashboards and tests side by side.
inline constexpr int kMaxParticipantsPerHost = 32;

}  // namespace hvac_twin::dds

#include "io/dds/participant.hpp"

#include <dds/dds.h>

#include <cassert>
#include <map>
#include <mutex>
#include <stdexcept>

namespace hvac_twin::dds {
namespace {

constexpr int kMaxDomainId = 232;  // highest id the default port mapping supports

bool all_chars_in(std::string_view s, std::string_view extra) {
  for (const char c : s) {
    const bool alnum = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9');
    if (!alnum && extra.find(c) == std::string_view::npos) return false;
  }
  return true;
}

// One Cyclone domain per id per process, shared by the participants created here.
struct DomainEntry {
  dds_entity_t domain = 0;
  std::string config;
  int users = 0;
};

std::mutex& registry_mutex() {
  static std::mutex mutex;
  return mutex;
}

std::map<int, DomainEntry>& registry() {
  static std::map<int, DomainEntry> domains;
  return domains;
}

std::string where(int domain_id, const std::string& interface) {
  return "DDS domain " + std::to_string(domain_id) + " on interface '" + interface + "'";
}

}  // namespace

std::string make_cyclone_config(const config::DdsConfig& config) {
  if (config.interface.empty() || !all_chars_in(config.interface, "_.:-")) {
    throw std::invalid_argument("DDS interface name '" + config.interface +
                                "' is empty or has characters outside [A-Za-z0-9_.:-]");
  }
  if (config.peers.empty() && !config.allow_multicast) {
    throw std::invalid_argument(
        "DDS discovery has neither multicast nor a unicast peer: add a peer (e.g. 127.0.0.1)");
  }
  std::string peers;
  for (const std::string& peer : config.peers) {
    if (peer.empty() || !all_chars_in(peer, "_.:-[]")) {
      throw std::invalid_argument("DDS peer address '" + peer +
                                  "' is empty or has characters outside [A-Za-z0-9_.:-[]]");
    }
    peers += "<Peer address=\"" + peer + "\"/>";
  }
  return "<CycloneDDS><Domain Id=\"any\">"
         "<General><Interfaces><NetworkInterface name=\"" +
         config.interface +
         "\"/></Interfaces>"
         "<AllowMulticast>" +
         (config.allow_multicast ? "true" : "false") +
         "</AllowMulticast></General>"
         "<Discovery><ParticipantIndex>auto</ParticipantIndex>"
         "<MaxAutoParticipantIndex>" +
         std::to_string(kMaxParticipantsPerHost - 1) +
         "</MaxAutoParticipantIndex>"
         "<Peers>" +
         peers +
         "</Peers></Discovery>"
         "</Domain></CycloneDDS>";
}

Participant::Participant(const config::DdsConfig& config, std::string_view extra_xml)
    : domain_id_(config.domain_id), interface_(config.interface) {
  if (domain_id_ < 0 || domain_id_ > kMaxDomainId) {
    throw std::invalid_argument("DDS domain id " + std::to_string(domain_id_) + " is outside 0.." +
                                std::to_string(kMaxDomainId));
  }
  std::string cyclone_config = make_cyclone_config(config);
  if (!extra_xml.empty()) cyclone_config.append(",").append(extra_xml);

  const std::lock_guard lock(registry_mutex());
  auto [it, inserted] = registry().try_emplace(domain_id_);
  DomainEntry& entry = it->second;
  if (inserted) {
    const dds_entity_t domain =
        dds_create_domain(static_cast<dds_domainid_t>(domain_id_), cyclone_config.c_str());
    if (domain < 0) {
      registry().erase(it);
      throw std::runtime_error(
          "cannot create " + where(domain_id_, interface_) + ": " + dds_strretcode(domain) +
          (domain == DDS_RETCODE_PRECONDITION_NOT_MET
               ? " (the domain already exists in this process, created outside io/dds)"
               : " (is the interface present and up? is AF_NETLINK allowed?)"));
    }
    entry.domain = domain;
    entry.config = std::move(cyclone_config);
  } else if (entry.config != cyclone_config) {
    throw std::runtime_error(where(domain_id_, interface_) +
                             " already exists in this process with a different configuration");
  }

  participant_ = dds_create_participant(static_cast<dds_domainid_t>(domain_id_), nullptr, nullptr);
  if (participant_ < 0) {
    const dds_return_t rc = participant_;
    if (entry.users == 0) {
      const dds_return_t del = dds_delete(entry.domain);
      assert(del == DDS_RETCODE_OK);
      (void)del;  // nothing more to do while reporting the original failure
      registry().erase(it);
    }
    throw std::runtime_error("cannot create a participant in " + where(domain_id_, interface_) +
                             ": " + dds_strretcode(rc));
  }
  ++entry.users;
}

Participant::~Participant() {
  dds_return_t rc = dds_delete(participant_);
  assert(rc == DDS_RETCODE_OK);
  const std::lock_guard lock(registry_mutex());
  const auto it = registry().find(domain_id_);
  if (it != registry().end() && --it->second.users == 0) {
    rc = dds_delete(it->second.domain);
    assert(rc == DDS_RETCODE_OK);
    registry().erase(it);
  }
  (void)rc;  // a destructor cannot report; deleting a valid entity does not fail
}

}  // namespace hvac_twin::dds

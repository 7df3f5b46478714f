#include "io/dds/qos.hpp"

#include <new>
#include <stdexcept>
#include <string>

namespace hvac_twin::dds {

QosPtr make_state_qos(std::chrono::nanoseconds period) {
  if (period < kAnyPeriod || period > kMaxPeriod) {
    throw std::invalid_argument("DDS state QoS: period " + std::to_string(period.count()) +
                                " ns is outside 0..24 h");
  }
  QosPtr qos(dds_create_qos());
  if (!qos) throw std::bad_alloc();

  dds_qset_reliability(qos.get(), DDS_RELIABILITY_RELIABLE, kMaxBlockingTime.count());
  dds_qset_durability(qos.get(), DDS_DURABILITY_TRANSIENT_LOCAL);
  dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, 1);
  // Cyclone serves late joiners of a transient-local writer from the durability-service history:
  // the last sample of every instance.
  dds_qset_durability_service(qos.get(), 0, DDS_HISTORY_KEEP_LAST, 1, DDS_LENGTH_UNLIMITED,
                              DDS_LENGTH_UNLIMITED, DDS_LENGTH_UNLIMITED);
  if (period == kAnyPeriod) {
    dds_qset_deadline(qos.get(), DDS_INFINITY);
    dds_qset_liveliness(qos.get(), DDS_LIVELINESS_AUTOMATIC, DDS_INFINITY);
  } else {
    dds_qset_deadline(qos.get(), state_deadline(period).count());
    dds_qset_liveliness(qos.get(), DDS_LIVELINESS_MANUAL_BY_TOPIC,
                        state_liveliness_lease(period).count());
  }
  return qos;
}

}  // namespace hvac_twin::dds

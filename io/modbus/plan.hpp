// Request planning: which read requests cover a device's points. Pure; allocates (start-up only);
// no exceptions other than std::bad_alloc; any thread.
//
// Points of the same register kind are grouped into one request while their registers are
// contiguous (or, if PlanOptions::max_gap_registers > 0, separated by at most that many unused
// registers) and the request stays within max_registers_per_request. The default is exact
// contiguity: reading a gap may touch addresses the device does not implement, and many devices
// then answer the whole request with exception 0x02 (illegal data address).
// Overlapping points (a configuration error reported by the config layer) are tolerated: they
// simply land in the same request.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "config/config.hpp"

namespace hvac_twin::modbus {

inline constexpr int kMaxRegistersPerRead = 125;  // Modbus limit for function codes 0x03/0x04

struct PlanOptions {
  int max_registers_per_request = kMaxRegistersPerRead;  // clamped to [1, 125]
  int max_gap_registers = 0;  // unused registers allowed inside one request; clamped to >= 0
};

// One point's place inside a request.
struct PlannedPoint {
  std::size_t point_index = 0;  // index into the `points` span given to make_plan()
  std::uint16_t offset = 0;     // first register of the point, relative to the request address
  std::uint16_t count = 0;      // registers_for(point.type)
};

struct ReadRequest {
  config::RegisterKind kind = config::RegisterKind::kHolding;
  std::uint16_t address = 0;    // first register (0-based protocol address)
  std::uint16_t count = 0;      // registers to read, 1..max_registers_per_request
  std::size_t first_point = 0;  // its points are RequestPlan::points[first_point, +point_count)
  std::size_t point_count = 0;
};

struct RequestPlan {
  std::vector<ReadRequest> requests;  // sorted by kind (holding first), then address
  std::vector<PlannedPoint> points;   // grouped by request; every planned point exactly once
  // Points that cannot be read at all: registers beyond address 65535, or a value wider than
  // max_registers_per_request. They appear in no request; callers should refuse the config.
  std::vector<std::size_t> rejected;
};

RequestPlan make_plan(std::span<const config::PointConfig> points, PlanOptions options = {});

}  // namespace hvac_twin::modbus

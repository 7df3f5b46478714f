#include "io/modbus/plan.hpp"

#include <algorithm>

#include "io/modbus/decode.hpp"

namespace hvac_twin::modbus {

RequestPlan make_plan(std::span<const config::PointConfig> points, PlanOptions options) {
  const std::uint32_t max_regs =
      static_cast<std::uint32_t>(std::clamp(options.max_registers_per_request, 1, 125));
  const std::uint32_t max_gap = static_cast<std::uint32_t>(std::max(options.max_gap_registers, 0));

  RequestPlan plan;
  std::vector<std::size_t> order;
  order.reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto& p = points[i];
    const auto count = static_cast<std::uint32_t>(registers_for(p.type));
    if (std::uint32_t{p.address} + count > 65536u || count > max_regs) {
      plan.rejected.push_back(i);
    } else {
      order.push_back(i);
    }
  }
  // Stable order: kind, then address, then configuration order.
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    const auto& pa = points[a];
    const auto& pb = points[b];
    if (pa.kind != pb.kind) return pa.kind < pb.kind;
    if (pa.address != pb.address) return pa.address < pb.address;
    return a < b;
  });

  plan.points.reserve(order.size());
  std::uint32_t end = 0;  // one past the last register of the open request
  for (std::size_t idx : order) {
    const auto& p = points[idx];
    const std::uint32_t begin = p.address;
    const std::uint32_t p_end = begin + static_cast<std::uint32_t>(registers_for(p.type));
    bool extend = false;
    if (!plan.requests.empty()) {
      const ReadRequest& open = plan.requests.back();
      // begin >= open.address always holds (sorted), so the new span is [open.address, new_end).
      const std::uint32_t new_end = std::max(end, p_end);
      extend = open.kind == p.kind && begin <= end + max_gap && new_end - open.address <= max_regs;
    }
    if (!extend) {
      ReadRequest r;
      r.kind = p.kind;
      r.address = p.address;
      r.first_point = plan.points.size();
      plan.requests.push_back(r);
      end = begin;
    }
    ReadRequest& open = plan.requests.back();
    end = std::max(end, p_end);
    open.count = static_cast<std::uint16_t>(end - open.address);
    ++open.point_count;
    plan.points.push_back({idx, static_cast<std::uint16_t>(begin - open.address),
                           static_cast<std::uint16_t>(p_end - begin)});
  }
  return plan;
}

}  // namespace hvac_twin::modbus

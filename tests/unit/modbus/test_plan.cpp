// Request planning: grouping, the 125-register cap, gaps, overlaps and bad addresses.
#include <catch2/catch.hpp>
#include <set>
#include <string>
#include <vector>

#include "io/modbus/decode.hpp"
#include "io/modbus/plan.hpp"
#include "tests/unit/modbus/modbus_test_util.hpp"

using hvac_twin::config::PointConfig;
using hvac_twin::config::RegisterKind;
using hvac_twin::config::ValueType;
using namespace hvac_twin::modbus;
using test::holding;
using test::input;

namespace {

// Every planned point lies inside its request; every point is planned or rejected exactly once;
// no request exceeds the cap.
void check_invariants(const std::vector<PointConfig>& points, const RequestPlan& plan, int cap) {
  std::multiset<std::size_t> seen(plan.rejected.begin(), plan.rejected.end());
  std::size_t next_slot = 0;
  for (const ReadRequest& r : plan.requests) {
    CHECK(r.count >= 1);
    CHECK(r.count <= cap);
    CHECK(r.first_point == next_slot);
    CHECK(r.point_count >= 1);
    next_slot += r.point_count;
    for (std::size_t k = r.first_point; k < r.first_point + r.point_count; ++k) {
      const PlannedPoint& pp = plan.points[k];
      const PointConfig& p = points[pp.point_index];
      seen.insert(pp.point_index);
      CHECK(p.kind == r.kind);
      CHECK(pp.count == registers_for(p.type));
      CHECK(r.address + pp.offset == p.address);
      CHECK(pp.offset + pp.count <= r.count);
    }
  }
  CHECK(next_slot == plan.points.size());
  REQUIRE(seen.size() == points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    CHECK(seen.count(i) == 1);
}

// Built with append: GCC 12 warns (-Wrestrict, a false positive, GCC bug 105329) on
// "literal" + std::to_string(i) at -O2.
std::string numbered(const char* prefix, int i) {
  std::string s(prefix);
  s.append(std::to_string(i));
  return s;
}

}  // namespace

TEST_CASE("contiguous points of one kind form one request") {
  const std::vector<PointConfig> points = {
      holding("a", 100, ValueType::kFloat32), holding("b", 102, ValueType::kInt16),
      holding("c", 103, ValueType::kUint32), holding("d", 105, ValueType::kUint16)};
  const RequestPlan plan = make_plan(points);
  REQUIRE(plan.requests.size() == 1);
  CHECK(plan.requests[0].kind == RegisterKind::kHolding);
  CHECK(plan.requests[0].address == 100);
  CHECK(plan.requests[0].count == 6);
  CHECK(plan.rejected.empty());
  check_invariants(points, plan, 125);
}

TEST_CASE("register kinds are never mixed, requests sorted by kind and address") {
  const std::vector<PointConfig> points = {input("i1", 11), holding("h2", 50), input("i0", 10),
                                           holding("h1", 10), holding("h0", 9)};
  const RequestPlan plan = make_plan(points);
  REQUIRE(plan.requests.size() == 3);
  CHECK(plan.requests[0].kind == RegisterKind::kHolding);
  CHECK(plan.requests[0].address == 9);
  CHECK(plan.requests[0].count == 2);
  CHECK(plan.requests[1].kind == RegisterKind::kHolding);
  CHECK(plan.requests[1].address == 50);
  CHECK(plan.requests[2].kind == RegisterKind::kInput);
  CHECK(plan.requests[2].address == 10);
  CHECK(plan.requests[2].count == 2);
  // Slots refer back to the configuration order.
  CHECK(plan.points[0].point_index == 4);
  CHECK(plan.points[1].point_index == 3);
  check_invariants(points, plan, 125);
}

TEST_CASE("a gap splits requests unless gaps are allowed") {
  const std::vector<PointConfig> points = {holding("a", 0), holding("b", 2),
                                           holding("c", 5, ValueType::kInt32)};
  SECTION("exact contiguity by default") {
    const RequestPlan plan = make_plan(points);
    CHECK(plan.requests.size() == 3);
    check_invariants(points, plan, 125);
  }
  SECTION("max_gap_registers = 2 reads across the holes") {
    const RequestPlan plan = make_plan(points, {125, 2});
    REQUIRE(plan.requests.size() == 1);
    CHECK(plan.requests[0].count == 7);
    CHECK(plan.points[2].offset == 5);
    check_invariants(points, plan, 125);
  }
  SECTION("max_gap_registers = 1 bridges only the first hole") {
    const RequestPlan plan = make_plan(points, {125, 1});
    CHECK(plan.requests.size() == 2);
    check_invariants(points, plan, 125);
  }
}

TEST_CASE("the 125-register cap splits long runs without splitting a point") {
  std::vector<PointConfig> points;
  for (int i = 0; i < 100; ++i) {  // 200 contiguous registers
    points.push_back(
        holding(numbered("f", i), static_cast<std::uint16_t>(1000 + 2 * i), ValueType::kFloat32));
  }
  const RequestPlan plan = make_plan(points);
  REQUIRE(plan.requests.size() == 2);
  CHECK(plan.requests[0].count == 124);  // 62 floats; a 63rd would need 126 registers
  CHECK(plan.requests[0].point_count == 62);
  CHECK(plan.requests[1].address == 1124);
  CHECK(plan.requests[1].count == 76);
  check_invariants(points, plan, 125);

  std::vector<PointConfig> words;
  for (int i = 0; i < 300; ++i)
    words.push_back(holding(numbered("w", i), static_cast<std::uint16_t>(i)));
  const RequestPlan plan16 = make_plan(words);
  REQUIRE(plan16.requests.size() == 3);
  CHECK(plan16.requests[0].count == 125);
  CHECK(plan16.requests[1].count == 125);
  CHECK(plan16.requests[2].count == 50);
  check_invariants(words, plan16, 125);

  const RequestPlan small = make_plan(words, {10, 0});
  CHECK(small.requests.size() == 30);
  check_invariants(words, small, 10);

  const RequestPlan clamped = make_plan(words, {1000, 0});  // clamped to 125
  CHECK(clamped.requests.size() == 3);
}

TEST_CASE("overlapping and duplicate points do not crash the planner") {
  const std::vector<PointConfig> points = {holding("a", 10, ValueType::kInt32),
                                           holding("b", 11, ValueType::kInt32), holding("c", 10),
                                           holding("d", 10, ValueType::kFloat32), holding("e", 12)};
  const RequestPlan plan = make_plan(points);
  REQUIRE(plan.requests.size() == 1);
  CHECK(plan.requests[0].address == 10);
  CHECK(plan.requests[0].count == 3);
  check_invariants(points, plan, 125);
}

TEST_CASE("points that cannot be read are rejected, not planned") {
  const std::vector<PointConfig> points = {holding("end16", 65535),
                                           holding("past", 65535, ValueType::kUint32),
                                           input("ok", 0, ValueType::kUint32)};
  const RequestPlan plan = make_plan(points);
  REQUIRE(plan.rejected.size() == 1);
  CHECK(plan.rejected[0] == 1);
  CHECK(plan.requests.size() == 2);
  check_invariants(points, plan, 125);

  const RequestPlan one = make_plan(points, {1, 0});  // a 32-bit value needs 2 registers
  CHECK(one.rejected.size() == 2);
  check_invariants(points, one, 1);

  CHECK(make_plan({}).requests.empty());
}

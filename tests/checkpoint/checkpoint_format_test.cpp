// The checkpoint format: round trip, and every way a file can be wrong is rejected with its
// reason (truncation at every length, every bit flipped, wrong version, implausible content,
// another model).
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <string_view>

#include "daemon/runtime/checkpoint.hpp"
#include "tests/checkpoint/checkpoint_fixture.hpp"

using namespace hvac_twin;
using runtime::CheckpointError;

namespace {

constexpr std::size_t kVersionOffset = 8, kHeaderLengthOffset = 12, kStatesOffset = 52;

void patch_u32(std::vector<std::byte>& b, std::size_t offset, std::uint32_t v) {
  for (int i = 0; i < 4; ++i)
    b[offset + static_cast<std::size_t>(i)] = static_cast<std::byte>((v >> (8 * i)) & 0xFFU);
}

// Recomputes the trailer, so that a test reaches the check behind the checksum.
void fix_crc(std::vector<std::byte>& b) {
  patch_u32(b, b.size() - 4, runtime::crc32c(std::span(b).first(b.size() - 4)));
}

CheckpointError decode_error(const std::vector<std::byte>& b) {
  return runtime::decode_checkpoint(b).status.error;
}

}  // namespace

TEST_CASE("CRC-32C has the standard check value", "[checkpoint]") {
  const std::string_view check = "123456789";
  CHECK(runtime::crc32c(std::as_bytes(std::span(check.data(), check.size()))) == 0xE3069283U);
}

TEST_CASE("a checkpoint decodes to what was encoded and re-encodes to the same bytes",
          "[checkpoint]") {
  const auto s = test::make_snapshot(42, 5);
  const auto bytes = test::encode(s);
  REQUIRE(bytes.size() == runtime::checkpoint_size(5, s.model_fingerprint.size(), 3, 3));
  const auto d = runtime::decode_checkpoint(bytes);
  INFO(d.status.message);
  REQUIRE(d.ok());
  CHECK(d.snapshot.cycle == 42);
  CHECK(test::is_snapshot_of_its_cycle(d.snapshot));
  CHECK(test::encode(d.snapshot) == bytes);
  CHECK(runtime::validate_checkpoint(d.snapshot, test::checkpoint_expectation(5), 0).ok());
}

TEST_CASE("encoding refuses a small buffer, a P of the wrong size and n over the cap",
          "[checkpoint]") {
  auto s = test::make_snapshot(1, 4);
  std::vector<std::byte> small(runtime::checkpoint_size(s) - 1);
  CHECK(runtime::encode_checkpoint(s, small) == 0);
  s.P.pop_back();
  std::vector<std::byte> buffer(runtime::checkpoint_size(s));
  CHECK(runtime::encode_checkpoint(s, buffer) == 0);
  CHECK(runtime::checkpoint_size(runtime::kCheckpointMaxStates + 1, 0, 0, 0) == 0);
}

TEST_CASE("a checkpoint truncated at any length is rejected as truncated", "[checkpoint]") {
  const auto bytes = test::encode(test::make_snapshot(7, 4));
  for (std::size_t len = 0; len < bytes.size(); ++len) {
    const std::vector<std::byte> cut(bytes.begin(), bytes.begin() + static_cast<long>(len));
    const auto e = decode_error(cut);
    INFO("length " << len << " of " << bytes.size());
    CHECK((e == CheckpointError::kTruncated || e == CheckpointError::kBadChecksum));
  }
  auto longer = bytes;
  longer.push_back(std::byte{0});
  CHECK(decode_error(longer) == CheckpointError::kImplausible);
}

TEST_CASE("a checkpoint with any single bit flipped is rejected", "[checkpoint]") {
  const auto bytes = test::encode(test::make_snapshot(7, 4));
  std::size_t by_checksum = 0;
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    for (int bit = 0; bit < 8; ++bit) {
      auto flipped = bytes;
      flipped[i] ^= static_cast<std::byte>(1U << bit);
      const auto e = decode_error(flipped);
      INFO("byte " << i << " bit " << bit);
      CHECK(e != CheckpointError::kNone);
      by_checksum += e == CheckpointError::kBadChecksum ? 1 : 0;
    }
  }
  // Past the fixed header fields every flip is the checksum's to find.
  CHECK(by_checksum >= 8 * (bytes.size() - 24));
}

TEST_CASE("the magic and the format version are checked first", "[checkpoint]") {
  auto bytes = test::encode(test::make_snapshot(3, 2));
  auto other = bytes;
  other[0] = std::byte{'X'};
  CHECK(decode_error(other) == CheckpointError::kBadMagic);
  for (const std::uint32_t version : {0U, 2U, 0xFFFFFFFFU}) {
    other = bytes;
    patch_u32(other, kVersionOffset, version);
    fix_crc(other);
    const auto d = runtime::decode_checkpoint(other);
    CHECK(d.status.error == CheckpointError::kWrongVersion);
    CHECK(d.status.message.find(std::to_string(version)) != std::string::npos);
  }
  other = bytes;
  patch_u32(other, kHeaderLengthOffset, 80);
  fix_crc(other);
  CHECK(decode_error(other) == CheckpointError::kImplausible);
}

TEST_CASE("inconsistent lengths behind a valid checksum are implausible", "[checkpoint]") {
  const auto bytes = test::encode(test::make_snapshot(3, 4));
  for (const std::uint32_t n : {0U, 3U, 5U, 1025U, 0xFFFFFFFFU}) {
    auto other = bytes;
    patch_u32(other, kStatesOffset, n);
    fix_crc(other);
    INFO("n = " << n);
    CHECK(decode_error(other) == CheckpointError::kImplausible);
  }
}

TEST_CASE("implausible content is rejected naming what is wrong", "[checkpoint]") {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  struct Case {
    const char* name;
    void (*spoil)(runtime::FilterSnapshot&);
    const char* says;
  };
  static double bad;
  const Case cases[] = {
      {"NaN in P", [](auto& s) { s.P[1 * 3 + 2] = s.P[2 * 3 + 1] = bad; }, "P(2,1)"},
      {"NaN on P's diagonal", [](auto& s) { s.P[4] = bad; }, "P(1,1)"},
      {"infinite x", [](auto& s) { s.x[2] = -bad; }, "x[2]"},
      {"asymmetric P", [](auto& s) { s.P[0 * 3 + 1] *= 1.001; }, "not symmetric"},
      {"negative variance", [](auto& s) { s.P[8] = -1e-3; }, "negative variance"},
      {"correlation above 1", [](auto& s) { s.P[1] = s.P[3] = 10.0; }, "correlation"},
      {"no state",
       [](auto& s) {
         s.x.clear();
         s.P.clear();
       },
       "n = 0"},
      {"model time not finite", [](auto& s) { s.model_time_s = bad; }, "model time"},
      {"wall time before 1970", [](auto& s) { s.wall_time_ns = -5; }, "wall time"},
  };
  for (const Case& c : cases) {
    for (const double value : {nan, inf}) {
      bad = value;
      auto s = test::make_snapshot(9, 3);
      c.spoil(s);
      const auto d = runtime::decode_checkpoint(test::encode(s));
      INFO(c.name << ": " << d.status.message);
      CHECK(d.status.error == CheckpointError::kImplausible);
      CHECK(d.status.message.find(c.says) != std::string::npos);
    }
  }
}

TEST_CASE("a checkpoint of another model, unit or age fails validation", "[checkpoint]") {
  const auto s = test::make_snapshot(5, 4);
  const auto ok = test::checkpoint_expectation(4);
  const std::int64_t now = s.wall_time_ns + 1'000'000'000;
  CHECK(runtime::validate_checkpoint(s, ok, now).ok());

  auto e = ok;
  e.model_fingerprint = "test_model:s0,s1,s3,s2";  // same size, states reordered
  CHECK(runtime::validate_checkpoint(s, e, now).error == CheckpointError::kWrongModel);
  e = ok;
  e.unit_id = "hp2";
  CHECK(runtime::validate_checkpoint(s, e, now).error == CheckpointError::kWrongModel);
  e = test::checkpoint_expectation(5);
  e.model_fingerprint = ok.model_fingerprint;
  CHECK(runtime::validate_checkpoint(s, e, now).error == CheckpointError::kWrongModel);
  e = ok;
  e.leak_block_size = 4;
  CHECK(runtime::validate_checkpoint(s, e, now).error == CheckpointError::kWrongModel);

  e = ok;
  e.max_age_ns = 2'000'000'000;
  CHECK(runtime::validate_checkpoint(s, e, now).ok());
  e.max_age_ns = 500'000'000;
  CHECK(runtime::validate_checkpoint(s, e, now).error == CheckpointError::kStale);
  CHECK(runtime::validate_checkpoint(s, e, s.wall_time_ns - 1'000'000'000).error ==
        CheckpointError::kStale);  // written "in the future": the clock was set back
}

TEST_CASE("a state far outside its physical bounds is implausible", "[checkpoint]") {
  plant::ModelLayout layout;
  for (int i = 0; i < 3; ++i)
    layout.states.push_back(plant::StateInfo{.name = "s" + std::to_string(i)});
  layout.states[0].min = 0.0;  // x0 = cycle: [0, 40], a quarter of it is 10
  layout.states[0].max = 40.0;
  layout.states[1].min = 0.0;  // x1 = cycle + 0.5: [0, inf), 0.25 of margin below
  layout.states[2].max = 1.0;  // x2 = cycle + 1: (-inf, 1], 0.25 above
  const auto e = runtime::make_checkpoint_expectation("test_model", layout, "hp1", 3, 0);
  CHECK(e.model_fingerprint == test::checkpoint_expectation(3).model_fingerprint);
  CHECK(e.num_states == 3);
  CHECK(runtime::validate_checkpoint(test::make_snapshot(0, 3), e, 0).ok());
  auto s = test::make_snapshot(0, 3);
  s.x[0] = 49.9;  // inside the margin: an unconstrained filter's excursion
  CHECK(runtime::validate_checkpoint(s, e, 0).ok());
  for (const auto& [i, v] :
       {std::pair{0, 50.1}, std::pair{0, -10.1}, std::pair{1, -0.26}, std::pair{2, 1.26}}) {
    s = test::make_snapshot(0, 3);
    s.x[static_cast<std::size_t>(i)] = v;
    const auto status = runtime::validate_checkpoint(s, e, 0);
    INFO("x[" << i << "] = " << v << ": " << status.message);
    CHECK(status.error == CheckpointError::kImplausible);
    CHECK(status.message.find("bounds") != std::string::npos);
  }
}

TEST_CASE("the model fingerprint names the model type and its states in order", "[checkpoint]") {
  plant::ModelLayout layout;
  layout.states.push_back(plant::StateInfo{.name = "T_air"});
  layout.states.push_back(plant::StateInfo{.name = "T_mass"});
  CHECK(runtime::model_fingerprint("zone_rc", layout) == "zone_rc:T_air,T_mass");
}

TEST_CASE("the committed fuzz seeds are what their names say", "[checkpoint]") {
  const std::string dir = std::string(HVAC_TWIN_SOURCE_DIR) + "/tests/fuzz/corpus/checkpoint/";
  const std::pair<const char*, CheckpointError> seeds[] = {
      {"valid-v1-n3", CheckpointError::kNone},
      {"valid-v1-n1", CheckpointError::kNone},
      {"truncated", CheckpointError::kTruncated},
      {"header-only", CheckpointError::kTruncated},
      {"bad-checksum", CheckpointError::kBadChecksum},
      {"wrong-version-2", CheckpointError::kWrongVersion},
      {"nan-in-p", CheckpointError::kImplausible},
      {"negative-variance", CheckpointError::kImplausible},
      {"lengths-inconsistent", CheckpointError::kImplausible},
  };
  for (const auto& [name, error] : seeds) {
    const auto bytes = test::read_bytes(dir + name);
    const auto d = runtime::decode_checkpoint(bytes);
    INFO(name << ": " << d.status.message);
    CHECK(!bytes.empty());
    CHECK(d.status.error == error);
    if (d.ok()) CHECK(test::is_snapshot_of_its_cycle(d.snapshot));
  }
}

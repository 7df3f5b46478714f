// What hvac-twin-web sends (io/web/json.hpp): Server-Sent Events framing and the JSON documents
// of its API, parsed back as a browser would.
#include <catch2/catch.hpp>
#include <limits>
#include <nlohmann/json.hpp>

#include "io/web/json.hpp"
#include "web_test_support.hpp"

using namespace hvac_twin;
using namespace hvac_twin::web;
using namespace hvac_twin::web::test;
using nlohmann::json;

TEST_CASE("sse: one event per call, every data line prefixed, a blank line at the end",
          "[web][json]") {
  CHECK(sse_event("summary", R"({"a":1})") == "event: summary\ndata: {\"a\":1}\n\n");
  // A line break inside the data would end the field: each line gets its own "data:".
  CHECK(sse_event("x", "one\ntwo\r\nthree") == "event: x\ndata: one\ndata: two\ndata: three\n\n");
  CHECK(sse_event("x", "") == "event: x\ndata: \n\n");
}

TEST_CASE("json: a record goes out in hvac-twin-echo's JSON", "[web][json]") {
  const json j = json::parse(record_json(leak("hp1", dds::LeakState::kLeak, kStamp0)));
  CHECK(j["topic"] == "leak_diagnostic");
  CHECK(j["state"] == "LEAK");
  CHECK(j["hold"] == "NONE");
  CHECK(j["threshold"] == 6.9);
  CHECK(j["timestamp_ns"] == kStamp0);
}

TEST_CASE("json: the summary says what the tile shows", "[web][json]") {
  Store store;
  auto h = health("hp1", 42, kStamp0);
  h.modbus_connected = false;
  h.modbus_last_error = std::string("Connection refused");
  store.ingest(h, 1'000'000'000);
  auto l = leak("hp1", dds::LeakState::kSuspect, kStamp0);
  l.hold = dds::LeakHold::kCompressorOff;
  store.ingest(l, 1'000'000'000);
  dds::ConsistencyRecord c;
  c.site = std::string("site");
  c.unit = std::string("hp1");
  c.point = std::string("*");
  c.verdict = dds::ConsistencyVerdict::kHigh;
  c.mean_nis = 2.5;
  store.ingest(c, 1'000'000'000);
  store.mark_liveliness_lost("site", "hp1");

  const json s = json::parse(summary_json(store.unit(0), 3'500'000'000));
  CHECK(s["site"] == "site");
  CHECK(s["unit"] == "hp1");
  CHECK(s["stale"] == "LIVELINESS_LOST");
  CHECK(s["age_ms"] == 2500);
  CHECK(s["quality"] == "GOOD");
  CHECK(s["health"]["cycle"] == 42);
  CHECK(s["health"]["modbus_connected"] == false);
  CHECK(s["health"]["modbus_last_error"] == "Connection refused");
  CHECK(s["leak"]["state"] == "SUSPECT");
  CHECK(s["leak"]["hold"] == "COMPRESSOR_OFF");
  CHECK(s["leak"]["nameplate_charge"] == 0.5);
  CHECK(s["consistency"]["verdict"] == "HIGH");

  // A unit with nothing but a sensor: nulls, not missing fields.
  Store other;
  other.ingest(sensor("zone", "zone_air_temperature", 21.0, 0.1, kStamp0), 0);
  const json z = json::parse(summary_json(other.unit(0), 0));
  CHECK(z["leak"].is_null());
  CHECK(z["health"].is_null());
  CHECK(z["quality"].is_null());
  CHECK(z["stale"] == "NO");
}

TEST_CASE("json: overview, unit and history documents", "[web][json]") {
  Store store;
  for (int i = 0; i < 3; ++i) {
    const std::int64_t t = kStamp0 + i * 5 * kSecond;
    store.ingest(health("hp1", static_cast<std::uint64_t>(i), t), 0);
    store.ingest(sensor("hp1", "superheat", 6.0 + i, 0.5, t), 0);
    store.ingest(observation("hp1", "suction_pressure", t), 0);
  }
  store.ingest(health("hp2", 1, kStamp0), 0);
  const json o = json::parse(overview_json(store, 0, ServerFacts{3, 1, 720, 1440}));
  REQUIRE(o["units"].size() == 2);
  CHECK(o["units"][1]["unit"] == "hp2");
  CHECK(o["server"]["clients"] == 3);
  CHECK(o["server"]["fine_capacity"] == 720);
  CHECK(o["server"]["records"] == 10);

  const json u = json::parse(unit_json(store.unit(0), 0));
  CHECK(u["summary"]["unit"] == "hp1");
  CHECK(u["health"]["topic"] == "estimator_health");
  REQUIRE(u["sensors"].size() == 1);
  CHECK(u["sensors"][0]["value"] == 8.0);
  CHECK(u["observations"][0]["point"] == "suction_pressure");
  CHECK(u["leak"].is_null());

  HistoryRequest request{kStamp0 / 1'000'000 + 60'000, 3'600'000, 300};
  const json h =
      json::parse(history_json("site", "hp1", request, collect_history(store.unit(0), request)));
  CHECK(h["window_s"] == 3600);
  const json& s = h["series"]["vs/superheat"];
  CHECK(s["unit"] == "K");
  CHECK(s["resolution"] == "sample");
  REQUIRE(s["t"].size() == 3);
  CHECK(s["t"][2] == kStamp0 / 1'000'000 + 10'000);
  CHECK(s["v"][2] == 8.0);
  CHECK(s["s"][2] == 0.5);
  CHECK(s["lo"][2] == 7.0);
  CHECK(s["hi"][2] == 9.0);
  CHECK(h["series"].contains("obs/suction_pressure/test_ratio"));
}

TEST_CASE("json: names from the network are escaped, non-finite numbers are null", "[web][json]") {
  CollectedSeries c;
  c.key = "vs/\"quoted\"\n\xff";
  c.eng_unit = std::string("°C");
  c.window.points.push_back({1000, std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0, 0.0});
  const json h = json::parse(history_json("s\"ite", "u", HistoryRequest{1000, 60'000, 10}, {c}));
  CHECK(h["site"] == "s\"ite");
  REQUIRE(h["series"].size() == 1);
  const auto series = h["series"].begin();
  CHECK(series.key().rfind("vs/\"quoted\"\n", 0) == 0);  // the invalid byte replaced, the rest kept
  CHECK((*series)["unit"] == "°C");
  CHECK((*series)["v"][0].is_null());
}

// Reference EOS of R32: published check values, thermodynamic consistency, solver round trips.
#include <catch2/catch.hpp>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "plant_models/refrigerant/r32_coefficients.hpp"
#include "plant_models/refrigerant/r32_eos.hpp"

namespace r32 = hvac_twin::plant::r32;

namespace {

const std::string kDataDir = std::string(HVAC_TWIN_SOURCE_DIR) + "/plant_models/refrigerant/data/";

// One CSV field as printed: its value and half a unit of its last printed digit.
struct Printed {
  bool present = false;
  double value = 0.0;
  double half_ulp = 0.0;
  std::string text;
};

Printed parse_printed(const std::string& s) {
  Printed p;
  if (s.empty()) return p;
  p.present = true;
  p.text = s;
  p.value = std::stod(s);
  const auto dot = s.find('.');
  const int decimals = dot == std::string::npos ? 0 : static_cast<int>(s.size() - dot - 1);
  p.half_ulp = 0.5 * std::pow(10.0, -decimals);
  return p;
}

std::vector<std::string> split_csv(const std::string& line) {
  std::vector<std::string> out;
  std::string field;
  bool quoted = false;
  for (char c : line) {
    if (c == '"') {
      quoted = !quoted;
    } else if (c == ',' && !quoted) {
      out.push_back(field);
      field.clear();
    } else {
      field.push_back(c);
    }
  }
  out.push_back(field);
  return out;
}

// Compare a computed value (already in the CSV's unit) with its printed value.
void check_printed(const std::string& row, const std::string& column, const Printed& printed,
                   double computed) {
  if (!printed.present) return;
  INFO(row << " " << column << ": published " << printed.text << ", computed " << computed);
  CHECK(std::abs(computed - printed.value) <= printed.half_ulp * (1.0 + 1e-9));
}

}  // namespace

TEST_CASE("every row of the published R32 check values is reproduced to its printed digits",
          "[refrigerant][eos]") {
  std::ifstream in(kDataDir + "r32_published.csv");
  REQUIRE(in.good());
  std::string line;
  std::getline(in, line);
  const std::vector<std::string> header = split_csv(line);
  auto col = [&](const std::string& name) {
    for (std::size_t i = 0; i < header.size(); ++i)
      if (header[i] == name) return i;
    FAIL("missing column " << name);
    return std::size_t{0};
  };
  int rows = 0;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    const std::vector<std::string> f = split_csv(line);
    REQUIRE(f.size() == header.size());
    auto get = [&](const char* name) { return parse_printed(f[col(name)]); };
    const Printed T_C = get("T_C");
    const Printed p_kPa = get("p_kPa");
    const std::string id = f[col("kind")] + " " + T_C.text + " C " + p_kPa.text + " kPa";
    ++rows;
    if (f[col("kind")] == "sat") {
      // Temperature-entry rows (Table 12) at T; pressure-entry rows (Table 13) at p, where the
      // printed T is then a check value too.
      const bool pressure_entry = f[col("source")].find("Table 13") != std::string::npos;
      const r32::Saturation s = pressure_entry ? r32::saturation_p(p_kPa.value * 1e3)
                                               : r32::saturation_t(T_C.value + 273.15);
      REQUIRE(s.status == r32::Status::kOk);
      check_printed(id, "T_C", T_C, s.T - 273.15);
      check_printed(id, "p_kPa", p_kPa, s.p / 1e3);
      check_printed(id, "rho_liq", get("rho_liq_kg_m3"), s.liquid.rho);
      check_printed(id, "rho_vap", get("rho_vap_kg_m3"), s.vapour.rho);
      check_printed(id, "h_liq", get("h_liq_kJ_kg"), s.liquid.h / 1e3);
      check_printed(id, "h_vap", get("h_vap_kJ_kg"), s.vapour.h / 1e3);
      check_printed(id, "s_liq", get("s_liq_kJ_kgK"), s.liquid.s / 1e3);
      check_printed(id, "s_vap", get("s_vap_kJ_kgK"), s.vapour.s / 1e3);
      check_printed(id, "cp_liq", get("cp_liq_kJ_kgK"), s.liquid.cp / 1e3);
      check_printed(id, "cp_vap", get("cp_vap_kJ_kgK"), s.vapour.cp / 1e3);
    } else {
      const double T = T_C.value + 273.15;
      const r32::DensityResult d = r32::density_pt(p_kPa.value * 1e3, T);
      REQUIRE(d.status == r32::Status::kOk);
      const r32::Properties s = r32::properties_trho(T, d.rho);
      check_printed(id, "rho", get("rho_kg_m3"), s.rho);
      check_printed(id, "h", get("h_kJ_kg"), s.h / 1e3);
      check_printed(id, "s", get("s_kJ_kgK"), s.s / 1e3);
      check_printed(id, "cp", get("cp_kJ_kgK"), s.cp / 1e3);
      check_printed(id, "cv", get("cv_kJ_kgK"), s.cv / 1e3);
      check_printed(id, "w", get("w_m_s"), s.w);
    }
  }
  CHECK(rows == 26);
}

TEST_CASE("compiled EOS coefficients equal the copied reference JSON", "[refrigerant][eos]") {
  std::ifstream in(kDataDir + "r32_eos.json");
  REQUIRE(in.good());
  const nlohmann::json j = nlohmann::json::parse(in);
  const auto& a0 = j["helmholtz"]["alpha0"];
  CHECK(a0["a1"].get<double>() == r32::coeff::kA1);
  CHECK(a0["a2"].get<double>() == r32::coeff::kA2);
  CHECK(a0["a3"].get<double>() == r32::coeff::kA3);
  auto same = [](const nlohmann::json& arr, const auto& values) {
    REQUIRE(arr.size() == values.size());
    for (std::size_t i = 0; i < values.size(); ++i)
      CHECK(arr[i].get<double>() == values[i]);
  };
  same(a0["m"], r32::coeff::kM);
  same(a0["theta"], r32::coeff::kTheta);
  const auto& ar = j["helmholtz"]["alphar"];
  same(ar["n"], r32::coeff::kN);
  same(ar["t"], r32::coeff::kT);
  for (std::size_t i = 0; i < r32::coeff::kD.size(); ++i) {
    CHECK(ar["d"][i].get<int>() == r32::coeff::kD[i]);
    CHECK(ar["l"][i].get<int>() == r32::coeff::kL[i]);
  }
  const auto& c = j["constants"];
  CHECK(c["molar_mass_kg_per_mol"].get<double>() == r32::kMolarMass);
  CHECK(c["gas_constant_J_per_molK"].get<double>() == r32::kGasConstantMolar);
  CHECK(c["T_critical_K"].get<double>() == r32::kTc);
  CHECK(c["p_critical_Pa"].get<double>() == r32::kPc);
  CHECK(c["reducing_rho_mol_per_m3"].get<double>() * r32::kMolarMass == r32::kRhoc);
  const auto& anc = j["ancillaries_CoolProp"];
  same(anc["pS"]["n"], r32::coeff::kPsN);
  same(anc["pS"]["t"], r32::coeff::kPsT);
  same(anc["rhoL"]["n"], r32::coeff::kRhoLN);
  same(anc["rhoL"]["t"], r32::coeff::kRhoLT);
  same(anc["rhoV"]["n"], r32::coeff::kRhoVN);
  same(anc["rhoV"]["t"], r32::coeff::kRhoVT);
}

TEST_CASE("IIR reference state: saturated liquid at 0 degC", "[refrigerant][eos]") {
  const r32::Saturation s = r32::saturation_t(273.15);
  REQUIRE(s.status == r32::Status::kOk);
  CHECK(s.liquid.h == Approx(200.0e3).margin(1e-2));
  CHECK(s.liquid.s == Approx(1.0e3).margin(1e-4));
}

TEST_CASE("cp and cv agree with finite differences of h and u", "[refrigerant][eos]") {
  const double states[][2] = {{1e5, 220.0}, {1e6, 280.0}, {3e6, 320.0},   {5e6, 340.0},
                              {2e5, 300.0}, {3e6, 380.0}, {5.5e6, 420.0}, {10e6, 360.0}};
  for (const auto& st : states) {
    const double p = st[0];
    const double T = st[1];
    const double dT = 1e-3;
    auto h_at = [&](double t) {
      const r32::DensityResult d = r32::density_pt(p, t);
      REQUIRE(d.status == r32::Status::kOk);
      return r32::properties_trho(t, d.rho).h;
    };
    const r32::DensityResult d = r32::density_pt(p, T);
    const r32::Properties s = r32::properties_trho(T, d.rho);
    INFO("p = " << p << " Pa, T = " << T << " K");
    CHECK((h_at(T + dT) - h_at(T - dT)) / (2 * dT) == Approx(s.cp).epsilon(1e-6));
    const double cv_fd =
        (r32::properties_trho(T + dT, d.rho).u - r32::properties_trho(T - dT, d.rho).u) / (2 * dT);
    CHECK(cv_fd == Approx(s.cv).epsilon(1e-6));
    // (dp/drho)_T and (dh/drho)_T against differences.
    const double dr = 1e-6 * d.rho;
    const r32::Properties a = r32::properties_trho(T, d.rho + dr);
    const r32::Properties b = r32::properties_trho(T, d.rho - dr);
    CHECK((a.p - b.p) / (2 * dr) == Approx(s.dp_drho_T).epsilon(1e-6));
    CHECK((a.h - b.h) / (2 * dr) == Approx(s.dh_drho_T).epsilon(1e-6));
  }
}

TEST_CASE("saturation: equal pressure and Gibbs energy, Clapeyron slope", "[refrigerant][eos]") {
  for (double T = 140.0; T < r32::kTc - 0.05; T += 7.3) {
    const r32::Saturation s = r32::saturation_t(T);
    REQUIRE(s.status == r32::Status::kOk);
    INFO("T = " << T);
    // The liquid pressure is rho R T (1 + delta alphar_delta) with 1 + delta alphar_delta ~ 1e-6
    // at 140 K: rounding in alphar_delta limits it to ~1e-7 Pa absolute there.
    CHECK(std::abs(s.liquid.p - s.vapour.p) <= 1e-9 * s.p + 1e-6);
    CHECK(std::abs(s.liquid.g - s.vapour.g) <= 1e-9 * std::abs(s.vapour.h - s.liquid.h));
    CHECK(s.liquid.rho > s.vapour.rho);
    // Clapeyron dp/dT = (s_v - s_l)/(v_v - v_l), against a difference of saturation_t.
    const double dT = 1e-4;
    const double dpdT = (r32::saturation_t(T + dT).p - r32::saturation_t(T - dT).p) / (2 * dT);
    CHECK(1.0 / s.dT_dp == Approx(dpdT).epsilon(1e-6));
    CHECK(1.0 / s.dT_dp ==
          Approx((s.vapour.s - s.liquid.s) / (1 / s.vapour.rho - 1 / s.liquid.rho)).epsilon(1e-8));
    // saturation_p inverts saturation_t.
    const r32::Saturation b = r32::saturation_p(s.p);
    REQUIRE(b.status == r32::Status::kOk);
    CHECK(b.T == Approx(T).epsilon(1e-11));
  }
  // Near the critical point.
  for (double dT : {1.0, 0.1, 0.01}) {
    const r32::Saturation s = r32::saturation_t(r32::kTc - dT);
    REQUIRE(s.status == r32::Status::kOk);
    CHECK(s.liquid.p == Approx(s.vapour.p).epsilon(1e-9));
    CHECK(s.liquid.rho > s.vapour.rho);
  }
}

TEST_CASE("along-saturation derivatives agree with differences", "[refrigerant][eos]") {
  for (double p : {0.1e6, 1e6, 3e6, 5e6, 5.6e6}) {
    const double dp = 1e-5 * p;
    const r32::Saturation s = r32::saturation_p(p);
    const r32::Saturation a = r32::saturation_p(p + dp);
    const r32::Saturation b = r32::saturation_p(p - dp);
    REQUIRE((s.status == r32::Status::kOk && a.status == r32::Status::kOk &&
             b.status == r32::Status::kOk));
    INFO("p = " << p);
    CHECK((a.T - b.T) / (2 * dp) == Approx(s.dT_dp).epsilon(1e-5));
    CHECK((a.liquid.h - b.liquid.h) / (2 * dp) == Approx(s.dh_l_dp).epsilon(1e-5));
    CHECK((a.vapour.h - b.vapour.h) / (2 * dp) == Approx(s.dh_v_dp).epsilon(1e-5));
    CHECK((a.liquid.rho - b.liquid.rho) / (2 * dp) == Approx(s.drho_l_dp).epsilon(1e-5));
    CHECK((a.vapour.rho - b.vapour.rho) / (2 * dp) == Approx(s.drho_v_dp).epsilon(1e-5));
  }
}

TEST_CASE("(p, h) flash round trips through (p, T) states and two-phase mixtures",
          "[refrigerant][eos]") {
  for (double p : {0.06e6, 0.1e6, 0.5e6, 1e6, 2e6, 3e6, 4.5e6, 5.5e6, 7e6, 20e6}) {
    for (double T = 190.0; T <= 430.0; T += 12.5) {
      const r32::DensityResult d = r32::density_pt(p, T);
      REQUIRE(d.status == r32::Status::kOk);
      const r32::Properties s = r32::properties_trho(T, d.rho);
      const r32::FlashResult f = r32::flash_ph(p, s.h);
      INFO("p = " << p << ", T = " << T);
      REQUIRE(f.status == r32::Status::kOk);
      CHECK(f.T == Approx(T).epsilon(1e-10));
      CHECK(f.rho == Approx(d.rho).epsilon(1e-9));
      CHECK(f.phase == d.phase);
    }
    if (p < r32::kPc) {
      const r32::Saturation sat = r32::saturation_p(p);
      for (double x : {0.0, 0.1, 0.5, 0.9, 1.0}) {
        const double h = sat.liquid.h + x * (sat.vapour.h - sat.liquid.h);
        const r32::FlashResult f = r32::flash_ph(p, h);
        REQUIRE(f.status == r32::Status::kOk);
        CHECK(f.phase == r32::Phase::kTwoPhase);
        CHECK(f.quality == Approx(x).margin(1e-12));
        CHECK(f.T == Approx(sat.T).epsilon(1e-14));
        CHECK(1 / f.rho == Approx(x / sat.vapour.rho + (1 - x) / sat.liquid.rho).epsilon(1e-12));
      }
    }
  }
}

TEST_CASE("EOS calls out of range return a recoverable status", "[refrigerant][eos]") {
  CHECK(r32::saturation_t(400.0).status == r32::Status::kOutOfRange);
  CHECK(r32::saturation_t(100.0).status == r32::Status::kOutOfRange);
  CHECK(r32::saturation_p(6e6).status == r32::Status::kOutOfRange);
  CHECK(r32::saturation_p(std::nan("")).status == r32::Status::kOutOfRange);
  CHECK(r32::density_pt(-1.0, 300.0).status == r32::Status::kOutOfRange);
  CHECK(r32::density_pt(1e5, 50.0).status == r32::Status::kOutOfRange);
  CHECK(r32::flash_ph(0.0, 3e5).status == r32::Status::kOutOfRange);
  CHECK(r32::flash_ph(1e6, std::nan("")).status == r32::Status::kOutOfRange);
  // Far below the liquid range of the EOS: h of liquid at the triple point is about -19 kJ/kg.
  CHECK(r32::flash_ph(1e6, -200e3).status == r32::Status::kOutOfRange);
  CHECK(r32::callback_code(r32::Status::kOutOfRange) > 0);
}

// ph(), ph_in() and sat_p(): Dual<K> inputs take the fused path (the table in Jets, then K
// tangents per output by the chain rule, see r32_table_jet.hpp); every other scalar type the
// operation-by-operation one (r32_table_eval.hpp). Included by r32_table.hpp; not for direct use.
#pragma once

#include <array>

#include "plant_models/refrigerant/r32_table.hpp"

namespace hvac_twin::plant::r32 {
namespace table_detail {

// The tangents of the inputs that propagate: none of a clamped p; those of the boundary curve
// h was replaced by (slope dh_dp), not h's own.
template <int K>
struct Seeds {
  std::array<double, K> p{}, h{};
  Seeds(const Dual<K>& p_in, const Dual<K>& h_in, bool p_fixed, bool h_fixed = false,
        double dh_dp = 0.0) {
    if (!p_fixed) p = p_in.d;
    for (int k = 0; k < K; ++k) {
      const auto i = static_cast<std::size_t>(k);
      h[i] = h_fixed ? dh_dp * p[i] : h_in.d[i];
    }
  }
  // A value with gradient (dp, dh) in (p, h).
  Dual<K> operator()(double v, double dp, double dh) const {
    Dual<K> r(v);
    for (int k = 0; k < K; ++k)
      r.d[static_cast<std::size_t>(k)] =
          dp * p[static_cast<std::size_t>(k)] + dh * h[static_cast<std::size_t>(k)];
    return r;
  }
  Dual<K> value(const Jet& j) const { return (*this)(j.v, j.p, j.h); }
  Dual<K> d_dp(const Jet& j) const { return (*this)(j.p, j.pp, j.ph); }  // dj/dp at constant h
  Dual<K> d_dh(const Jet& j) const { return (*this)(j.h, j.ph, j.hh); }  // dj/dh at constant p
};

}  // namespace table_detail

template <class S>
PhState<S> PhTable::ph(const S& p, const S& h) const {
  if constexpr (kIsDual<S>) {
    const JetPh j = ph_jet(p.v, h.v);
    PhState<S> out;
    out.status = j.status;
    out.region = j.region;
    if (j.empty) return out;
    const table_detail::Seeds<S::kDirections> s(p, h, j.p_fixed, j.h_fixed, j.dh_dp);
    out.T = s.value(j.T);
    out.rho = s.value(j.rho);
    out.quality = s.value(j.quality);
    out.drho_dp_h = s.d_dp(j.rho);
    out.drho_dh_p = s.d_dh(j.rho);
    out.dT_dp_h = s.d_dp(j.T);
    out.dT_dh_p = s.d_dh(j.T);
    out.h_l = s.value(j.h_l);
    out.h_v = s.value(j.h_v);
    return out;
  } else {
    return ph_by_operations(p, h);
  }
}

template <class S>
PhState<S> PhTable::ph_in(const S& p, const S& h, Region region) const {
  if constexpr (kIsDual<S>) {
    const JetPh j = ph_in_jet(p.v, h.v, region);
    PhState<S> out;
    out.status = j.status;
    if (j.empty) return out;
    out.region = j.region;
    const table_detail::Seeds<S::kDirections> s(p, h, j.p_fixed);
    out.T = s.value(j.T);
    out.rho = s.value(j.rho);
    out.quality = s.value(j.quality);
    out.drho_dp_h = s.d_dp(j.rho);
    out.drho_dh_p = s.d_dh(j.rho);
    out.dT_dp_h = s.d_dp(j.T);
    out.dT_dh_p = s.d_dh(j.T);
    out.h_l = s.value(j.h_l);
    out.h_v = s.value(j.h_v);
    return out;
  } else {
    return ph_in_by_operations(p, h, region);
  }
}

template <class S>
SatState<S> PhTable::sat_p(const S& p) const {
  if constexpr (kIsDual<S>) {
    const JetSat j = sat_p_jet(p.v);
    SatState<S> out;
    out.status = j.status;
    if (j.empty) return out;
    const table_detail::Seeds<S::kDirections> s(p, S(0.0), j.p_fixed);
    out.T = s.value(j.T);
    out.h_l = s.value(j.h_l);
    out.h_v = s.value(j.h_v);
    out.rho_l = s.value(j.rho_l);
    out.rho_v = s.value(j.rho_v);
    out.dT_dp = s.d_dp(j.T);
    out.dh_l_dp = s.d_dp(j.h_l);
    out.dh_v_dp = s.d_dp(j.h_v);
    out.drho_l_dp = s.d_dp(j.rho_l);
    out.drho_v_dp = s.d_dp(j.rho_v);
    return out;
  } else {
    return sat_p_by_operations(p);
  }
}

}  // namespace hvac_twin::plant::r32

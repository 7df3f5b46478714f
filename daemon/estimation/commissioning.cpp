#include "daemon/estimation/commissioning.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace hvac_twin::est {

StatePhases::StatePhases(const plant::ModelLayout& layout, std::vector<KnownState> known,
                         double settle_s, double commissioning_s, double release_s)
    : known_(std::move(known)),
      settle_s_(settle_s),
      commissioning_s_(commissioning_s),
      release_s_(release_s) {
  const std::size_t n = layout.states.size();
  base_.assign(n, 0);
  augmented_.assign(n, 0);
  calibrate_.assign(n, 0);
  is_known_.assign(n, 0);
  excited_by_.assign(n, -1);
  excitation_min_.assign(n, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    const plant::StateInfo& s = layout.states[i];
    excited_by_[i] = s.excited_by;
    excitation_min_[i] = s.excitation_min;
    base_[i] = s.consider || s.calibrate ? 1 : 0;
    augmented_[i] = s.augmented ? 1 : 0;
    calibrate_[i] = s.calibrate ? 1 : 0;
  }
  for (const KnownState& k : known_) {
    const auto i = layout.state(k.name);
    known_index_.push_back(i ? *i : n);
    if (i) is_known_[*i] = 1;
  }
}

void StatePhases::set_base(std::size_t state, bool consider) {
  if (state < base_.size()) base_[state] = consider ? 1 : 0;
}

std::string StatePhases::begin(Estimator& filter, double t) {
  const std::size_t n = filter.num_states();
  for (std::size_t k = 0; k < known_.size(); ++k) {
    if (known_index_[k] >= n || known_index_[k] >= base_.size())
      return "commissioning: the model has no state \"" + known_[k].name + "\"";
    if (!(known_[k].sigma > 0.0) || !std::isfinite(known_[k].value))
      return "commissioning: state \"" + known_[k].name + "\" needs a finite value and a sigma > 0";
  }
  if (commissioning(t)) {
    std::vector<double> x(filter.state().data(), filter.state().data() + n);
    std::vector<double> P(n * n);
    for (std::size_t r = 0; r < n; ++r)
      for (std::size_t c = 0; c < n; ++c)
        P[r * n + c] =
            filter.covariance()(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(c));
    for (std::size_t k = 0; k < known_.size(); ++k) {
      const std::size_t i = known_index_[k];
      x[i] = known_[k].value;
      for (std::size_t j = 0; j < n; ++j)
        P[i * n + j] = P[j * n + i] = 0.0;
      P[i * n + i] = known_[k].sigma * known_[k].sigma;
    }
    if (!filter.restore(x, P, filter.counters()))
      return "commissioning: the filter refused the covariance with the known states";
  }
  apply(filter, t);
  return {};
}

StatePhases StatePhases::resumed_ramp(const plant::ModelLayout& layout, double release_s) {
  StatePhases phases(layout, {}, 0.0, 0.0, release_s);
  phases.ramp_from_start_ = true;
  return phases;
}

double StatePhases::release_weight(double t) const {
  if (!(release_s_ > 0.0) || (!(settle_s_ > 0.0) && !ramp_from_start_) ||
      t >= settle_s_ + release_s_)
    return 1.0;
  return std::max(0.0, (t - settle_s_) / release_s_);
}

void StatePhases::apply(Estimator& filter, double t, std::span<const double> u) const {
  const bool settle = settling(t), commission = commissioning(t);
  const double release = release_weight(t);
  for (std::size_t i = 0; i < base_.size(); ++i) {
    bool consider = base_[i] != 0;
    if (commission && calibrate_[i] != 0) consider = false;
    if (commission && is_known_[i] != 0) consider = true;
    if (settle && augmented_[i] != 0) consider = true;
    const auto input = static_cast<std::size_t>(excited_by_[i]);
    if (excited_by_[i] >= 0 && input < u.size() && !(u[input] >= excitation_min_[i]))
      consider = true;
    filter.set_consider(i, consider);
    filter.set_gain_weight(i, augmented_[i] != 0 ? release : 1.0);
  }
  filter.set_starting(!settle && release < 1.0);
}

}  // namespace hvac_twin::est

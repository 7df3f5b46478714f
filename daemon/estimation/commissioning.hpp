// Which states a filter estimates and which it only considers, over its life (the consider flags
// of estimator.hpp), in three phases from its start:
//
//  - settling (settle_s): the augmented states (slow parameters, disturbances) are held at their
//    priors while the physical states converge onto the measurements. From a cold start the
//    model's guess differs from the plant by several sigma at several sensors; estimating the
//    parameters from those first innovations throws them across their range (seen on the heat
//    pump: the coil UA factors moved by 3-5 prior sigma in the first minute) and the next
//    prediction into a stiff corner.
//  - commissioning (commissioning_s, optional): the installer knows some states (the refrigerant
//    charge, weighed in). They are set to their known values with the given sigma and held; the
//    closures no sensor can separate from them (StateInfo::calibrate: the heat pump's two-phase
//    void fraction, which sets how much refrigerant a given subcooling means) are estimated.
//  - excitation (every phase): a parameter the model marks as revealed only by a running
//    process (StateInfo::excited_by) is held while its input says the process stands still.
//  - release (release_s, after settling): the augmented states are estimated with a gain weight
//    (Estimator::set_gain_weight) rising from 0 to 1. Released at once, with the whole prior
//    sigma the hold kept, one update linearised at the prior moved them across their range and
//    collapsed the predicted sigma of the outputs they drive; a sensor the move left 3 sigma
//    off was gated out for good (the heat pump's condenser-outlet wall, fused in 0 of 72 cycles
//    after the release; lost_track_test). During the ramp the filter is starting
//    (Estimator::set_starting): a point still gated out from the hold, while the others pass, is
//    re-tested against the initial covariance (ekf.hpp, "Re-admission").
//  - operation: the known states are estimated again (a change of the charge must show as a
//    charge change); the calibrated closures are frozen at their estimates, their posterior sigma
//    carried as consider states. Without commissioning they stay considered at their prior: their
//    uncertainty is in every sigma they affect, honestly larger.
//
// Pure library: time since the filter's start is passed in. Construction and begin() allocate
// (start-up only); apply() does not. No exceptions.
#pragma once

#include <span>
#include <string>
#include <vector>

#include "daemon/estimation/estimator.hpp"

namespace hvac_twin::est {

struct KnownState {
  std::string name;  // state name in the model's layout
  double value = 0.0;
  double sigma = 0.0;  // > 0
};

class StatePhases {
 public:
  // layout: the filter's model's; known: empty for no commissioning; release_s: the ramp of
  // the augmented states' gain weight after settle_s (0: released at once).
  StatePhases(const plant::ModelLayout& layout, std::vector<KnownState> known, double settle_s,
              double commissioning_s, double release_s = 0.0);

  // The phases of a filter resumed from a checkpoint saved before its augmented states were
  // fully released (in the hold or the ramp): no hold, and the ramp of release_s from t = 0.
  // (Without a hold the constructor's phases release at once: a resumed filter whose parameters
  // were released when it was saved.)
  static StatePhases resumed_ramp(const plant::ModelLayout& layout, double release_s);

  // The operation-phase flag of a state (initially the layout's consider || calibrate): the
  // configuration may override it.
  void set_base(std::size_t state, bool consider);

  // At the filter's start (after its reset or restore): sets the known states, unless
  // commissioning is already over at `t` (a restart). Returns an empty string, or what was wrong
  // (an unknown state, a sigma not positive, the filter refused the covariance); on an error the
  // filter is unchanged.
  std::string begin(Estimator& filter, double t);

  // The gain weight of an augmented state at time t since the start (1 outside the release).
  [[nodiscard]] double release_weight(double t) const;

  // The flags and gain weights for time t since the start, with the inputs over the coming period
  // (empty: no excitation holds). No allocation.
  void apply(Estimator& filter, double t, std::span<const double> u = {}) const;

  [[nodiscard]] bool settling(double t) const { return t < settle_s_; }
  // Whether the augmented states are held or not yet at full gain at time t.
  [[nodiscard]] bool releasing(double t) const { return settling(t) || release_weight(t) < 1.0; }
  [[nodiscard]] bool commissioning(double t) const {
    return !known_.empty() && t < commissioning_s_;
  }

 private:
  std::vector<KnownState> known_;
  std::vector<std::size_t> known_index_;
  std::vector<char> base_, augmented_, calibrate_, is_known_;
  std::vector<int> excited_by_;
  std::vector<double> excitation_min_;
  double settle_s_, commissioning_s_, release_s_;
  bool ramp_from_start_ = false;  // resumed_ramp()
};

}  // namespace hvac_twin::est

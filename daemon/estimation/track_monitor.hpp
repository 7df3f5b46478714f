// Whether a filter has lost track of its plant, judged from its own update reports: in
// `lost_after` updates in a row most of the available measurements failed the gate (at least two
// available), so the estimate's covariance claims a certainty the data contradicts. (One such
// update alone is a transient the filter rides out: seen on the heat pump at 4 cells in normal
// operation, a few times an hour.) Typical cause: a burst of
// in-range but absurd readings was fused, drove a state to its bound with a tiny variance, and
// the good data that follows is rejected as improbable.
//
// The monitor only judges and counts; the caller says so on its outputs (quality not GOOD, a
// flag), logs once per episode, and recovers: the EKF resets its covariance by itself after
// EkfOptions::max_consecutive_rejections such updates (reported here as `covariance_reset`);
// after `restart_after` lost updates in a row (either filter) the caller starts the filter
// again from the measured conditions. A unit with a single measured point is never judged: a
// lone rejected point is as likely a faulty sensor as a lost filter (its report says `faulty`).
//
// Pure: no I/O, no clock, no allocation.
#pragma once

#include <cstdint>
#include <span>

#include "daemon/estimation/estimator.hpp"

namespace hvac_twin::est {

// The daemon's settings (UnitPipeline), which the benchmarks mirror: lost from the second update
// in a row with most points gated out; a restart from the measured conditions after 15 lost
// updates in a row (through the EKF's covariance resets, every max_consecutive_rejections).
inline constexpr int kLostAfterUpdates = 2;
inline constexpr int kRestartAfterLostUpdates = 15;

// What one update meant for the episode.
struct TrackStep {
  bool lost = false;             // lost_after updates in a row with most measurements gated out
  bool episode_started = false;  // the first lost update after a good one
  bool episode_ended = false;    // the first good update after a lost episode
  bool first_reset = false;      // the episode's first covariance reset, or one outside any
  bool restart_due = false;      // restart_after lost updates in a row: restart the filter
  bool first_restart = false;    // the episode's first restart
  std::size_t available = 0, rejected = 0;
};

class TrackMonitor {
 public:
  TrackMonitor(int lost_after, int restart_after)
      : lost_after_(lost_after), restart_after_(restart_after) {}

  // After every update: its reports, and whether the filter reset its covariance in it. The
  // restart count runs from the first lost update.
  TrackStep observe(std::span<const MeasurementReport> reports, bool covariance_reset) {
    TrackStep s;
    for (const MeasurementReport& r : reports) {
      s.available += r.available ? 1 : 0;
      s.rejected += r.rejected ? 1 : 0;
    }
    // The EKF re-tests after its reset: the update that resets may end the episode.
    if (covariance_reset) s.first_reset = ++episode_resets_ == 1;
    const bool contradicted = s.available >= 2 && 2 * s.rejected > s.available;
    contradicted_ = contradicted ? contradicted_ + 1 : 0;
    s.lost = contradicted_ >= lost_after_;
    if (!s.lost) {
      s.episode_ended = episode_updates_ > 0;
      if (s.episode_ended) last_episode_ = Episode{episode_updates_, episode_resets_, restarts_};
      streak_ = 0;
      episode_updates_ = 0;
      episode_resets_ = 0;
      restarts_ = 0;
      return s;
    }
    s.episode_started = episode_updates_ == 0;
    if (s.episode_started) ++episodes_;
    ++episode_updates_;
    ++streak_;
    if (restart_after_ > 0 && streak_ >= restart_after_) {
      s.restart_due = true;
      streak_ = 0;  // the restarted filter gets restart_after updates of its own
      s.first_restart = ++restarts_ == 1;
    }
    return s;
  }

  // The episode that ended last: its lost updates, covariance resets and restarts.
  struct Episode {
    std::uint64_t updates = 0, covariance_resets = 0, restarts = 0;
  };
  [[nodiscard]] const Episode& last_episode() const { return last_episode_; }
  [[nodiscard]] std::uint64_t episodes() const { return episodes_; }
  [[nodiscard]] bool lost() const { return episode_updates_ > 0; }

 private:
  int lost_after_, restart_after_;
  int contradicted_ = 0;  // updates in a row with most available measurements gated out
  int streak_ = 0;        // lost updates since the episode began or the filter last restarted
  std::uint64_t episode_updates_ = 0, episode_resets_ = 0, restarts_ = 0, episodes_ = 0;
  Episode last_episode_;
};

}  // namespace hvac_twin::est

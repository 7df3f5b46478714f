#include "daemon/replay/smoothing.hpp"

#include <cinttypes>
#include <cmath>
#include <stdexcept>

#include "daemon/estimation/ekf.hpp"
#include "daemon/estimation/rts_smoother.hpp"
#include "io/dds/types.hpp"

namespace hvac_twin::replay {
namespace {

// A record: [cycle, timestamp, linked, valid] then x⁻, P⁻, F, x, P, u (doubles; the cycle and
// the stamp are exact in a double up to 2^53).
constexpr std::size_t kHead = 4;

// The smoother conditions on the directions of the prior that hold at least this share of a
// state's variance (est::RtsSmoother). On the heat pump's golden recording the textbook smoother
// (0) diverges backwards by a factor 10-100 a cycle (its gain is about F⁻¹ on the model's stiff,
// nearly noise-free states), 1e-3 and 1e-2 still by up to 100 sigma; 0.1 and 0.3 are stable and
// give the same errors within 10 % (README, "Recording and replay").
constexpr double kMinEigenvalue = 0.1;

}  // namespace

Smoothing::Smoothing(std::size_t n, std::size_t m, std::size_t k)
    : n_(n), m_(m), k_(k), record_doubles_(kHead + 3 * n * n + 2 * n + n * n + k) {
  rec_.assign(record_doubles_, 0.0);
  file_ = std::tmpfile();
  if (file_ == nullptr) throw std::runtime_error("--smooth: no temporary file (TMPDIR)");
}

Smoothing::~Smoothing() {
  if (file_ != nullptr) std::fclose(file_);
}

void Smoothing::attach(const runtime::UnitPipeline* pipeline) {
  // The pipeline makes its filter once, in its constructor: the cast holds for its life.
  ekf_ = dynamic_cast<const est::Ekf*>(&pipeline->filter());
  if (ekf_ == nullptr)
    throw std::invalid_argument("--smooth needs an EKF (estimator.type ekf or constrained_ekf)");
  pipeline_ = pipeline;
  const auto& c = pipeline->filter().counters();
  predicts_ = c.predicts;
  failures_ = c.predict_failures;
  last_valid_ = false;
}

void Smoothing::after_predict(std::string_view /*unit*/, std::uint64_t /*cycle*/,
                              const std::atomic<bool>& /*stopping*/) {
  const est::Ekf& ekf = *ekf_;
  const auto& c = ekf.counters();
  predicted_ = c.predicts == predicts_ + 1 && c.predict_failures == failures_;
  if (!predicted_) return;
  double* at = rec_.data() + kHead;
  at = std::copy_n(ekf.state().data(), n_, at);
  at = std::copy_n(ekf.covariance().data(), n_ * n_, at);
  std::copy_n(ekf.transition().data(), n_ * n_, at);
}

void Smoothing::end_cycle(std::uint64_t cycle, std::int64_t timestamp_ns,
                          const runtime::CycleOutcome& outcome) {
  const est::Estimator& f = pipeline_->filter();
  const bool valid = outcome.ran_estimator && outcome.quality != dds::EstimateQuality::kNotReady;
  const bool linked =
      valid && last_valid_ && predicted_ && (outcome.flags & dds::kFlagNumericalReset) == 0;
  rec_[0] = static_cast<double>(cycle);
  rec_[1] = static_cast<double>(timestamp_ns);
  rec_[2] = linked ? 1.0 : 0.0;
  rec_[3] = valid ? 1.0 : 0.0;
  double* at = rec_.data() + kHead + n_ + 2 * n_ * n_;
  at = std::copy_n(f.state().data(), n_, at);
  at = std::copy_n(f.covariance().data(), n_ * n_, at);
  const auto u = pipeline_->inputs();
  std::copy_n(u.data(), std::min(k_, u.size()), at);
  spill(rec_.data(), rec_.size());
  ++records_;
  predicts_ = f.counters().predicts;
  failures_ = f.counters().predict_failures;
  predicted_ = false;
  last_valid_ = valid;
}

void Smoothing::spill(const double* data, std::size_t count) {
  if (std::fwrite(data, sizeof(double), count, file_) != count)
    throw std::runtime_error("--smooth: the temporary file cannot be written (disk full?)");
}

void Smoothing::load(std::uint64_t index) {
  const auto offset = static_cast<long>(index * record_doubles_ * sizeof(double));
  if (std::fseek(file_, offset, SEEK_SET) != 0 ||
      std::fread(rec_.data(), sizeof(double), record_doubles_, file_) != record_doubles_)
    throw std::runtime_error("--smooth: the temporary file cannot be read back");
}

std::uint64_t Smoothing::write(std::FILE* out, const plant::ContinuousModel& model) {
  using Eigen::Map;
  using Eigen::MatrixXd;
  using Eigen::VectorXd;
  const auto n = static_cast<Eigen::Index>(n_);
  std::fflush(file_);
  est::RtsSmoother rts(n, kMinEigenvalue);
  VectorXd xs1(n), xs(n), x_prior1(n);
  MatrixXd Ps1(n, n), Ps(n, n), P_prior1(n, n), F1(n, n), H(static_cast<Eigen::Index>(m_), n);
  std::vector<double> y(m_), smoothed(records_ * 2 * m_, std::nan(""));
  std::vector<std::uint64_t> cycle(records_);
  std::vector<std::int64_t> stamp(records_);
  bool have_next = false, next_linked = false;
  std::uint64_t breaks = 0;
  const auto& outputs = model.layout().outputs;
  for (std::uint64_t i = records_; i-- > 0;) {
    load(i);
    cycle[i] = static_cast<std::uint64_t>(rec_[0]);
    stamp[i] = static_cast<std::int64_t>(rec_[1]);
    const bool linked = rec_[2] != 0.0, valid = rec_[3] != 0.0;
    const double* at = rec_.data() + kHead;
    const Map<const VectorXd> x_prior(at, n);
    const Map<const MatrixXd> P_prior(at + n_, n, n);
    const Map<const MatrixXd> F(at + n_ + n_ * n_, n, n);
    const Map<const VectorXd> x(at + n_ + 2 * n_ * n_, n);
    const Map<const MatrixXd> P(at + 2 * n_ + 2 * n_ * n_, n, n);
    const std::span<const double> u(at + 2 * n_ + 3 * n_ * n_, k_);
    bool have = false;
    if (valid && have_next && next_linked &&
        rts.step(x, P, x_prior1, P_prior1, F1, xs1, Ps1, xs, Ps)) {
      have = true;
    } else if (valid) {
      xs = x;  // the end of a piece: the filter's own estimate
      Ps = P;
      have = true;
      if (i + 1 < records_) ++breaks;
    }
    if (have && model.output_jacobian({xs.data(), n_}, u, y, {H.data(), m_ * n_}) == 0) {
      for (std::size_t o = 0; o < m_; ++o) {
        const auto r = static_cast<Eigen::Index>(o);
        const double filter_sigma =
            std::sqrt(std::max(0.0, (H.row(r) * Ps * H.row(r).transpose())(0)));
        smoothed[i * 2 * m_ + 2 * o] = y[o];
        smoothed[i * 2 * m_ + 2 * o + 1] = std::hypot(filter_sigma, outputs[o].model_error,
                                                      outputs[o].model_error_rel * std::abs(y[o]));
      }
    }
    // What the step before needs from this one.
    have_next = have;
    next_linked = linked;
    if (have) {
      xs1 = xs;
      Ps1 = Ps;
      x_prior1 = x_prior;
      P_prior1 = P_prior;
      F1 = F;
    }
  }
  std::fputs("cycle,timestamp_ns", out);
  for (const auto& o : outputs)
    std::fprintf(out, ",%s,%s_sigma", o.name.c_str(), o.name.c_str());
  std::fputc('\n', out);
  for (std::uint64_t i = 0; i < records_; ++i) {
    std::fprintf(out, "%" PRIu64 ",%" PRId64, cycle[i], stamp[i]);
    for (std::size_t j = 0; j < 2 * m_; ++j) {
      const double v = smoothed[i * 2 * m_ + j];
      if (std::isnan(v))
        std::fputc(',', out);
      else
        std::fprintf(out, ",%.17g", v);
    }
    std::fputc('\n', out);
  }
  return breaks;
}

}  // namespace hvac_twin::replay

#include "daemon/replay/cycle_reader.hpp"

#include <filesystem>
#include <utility>

namespace hvac_twin::replay {

using recording::RecordingError;
using recording::RecordingReader;

bool is_csv(const std::string& path) {
  return path.size() > 4 && path.compare(path.size() - 4, 4, ".csv") == 0;
}

void check_points(const RecordingReader& r, const config::UnitConfig& unit) {
  const auto& points = r.header().points;
  if (points.size() != unit.points.size())
    throw RecordingError(r.path() + ": " + std::to_string(points.size()) +
                         " points recorded, the configuration's unit " + unit.id + " has " +
                         std::to_string(unit.points.size()));
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto& c = unit.points[i];
    if (points[i].name != c.name || points[i].unit != c.unit)
      throw RecordingError(r.path() + ": point " + std::to_string(i + 1) + " recorded as " +
                           points[i].name + " [" + points[i].unit + "], the configuration has " +
                           c.name + " [" + c.unit + "]");
  }
}

std::vector<std::string> expand_inputs(const std::vector<std::string>& inputs,
                                       const std::string& unit) {
  std::vector<std::string> files;
  for (const auto& in : inputs) {
    std::error_code ec;
    if (!std::filesystem::is_directory(in, ec)) {
      files.push_back(in);
      continue;
    }
    const auto found = recording::unit_recordings(in, unit);
    if (found.empty()) throw RecordingError(in + ": no recording of unit " + unit);
    files.insert(files.end(), found.begin(), found.end());
  }
  return files;
}

std::string pick_unit(const std::string& unit, const std::vector<std::string>& inputs,
                      const config::Config& config) {
  if (!unit.empty()) return unit;
  std::error_code ec;
  const std::string& first = inputs.front();
  const bool csv = is_csv(first);
  if (!csv && !std::filesystem::is_directory(first, ec))
    return RecordingReader(first).header().unit;
  if (config.units.size() == 1) return config.units.front().id;
  throw RecordingError(first + (csv ? ": a CSV" : ": a directory") +
                       " and several units: name one with --unit");
}

CycleReader::CycleReader(std::vector<std::string> files, const config::UnitConfig& unit,
                         double input_hold_s, Warn warn)
    : files_(std::move(files)), unit_(unit), warn_(std::move(warn)) {
  if (files_.empty()) throw RecordingError("no input file");
  if (is_csv(files_.front())) {
    if (files_.size() != 1) throw RecordingError(files_[1] + ": one CSV per run");
    csv_ = std::make_unique<CsvPoints>(files_.front(), unit, input_hold_s);
    for (const auto& m : csv_->missing_points())
      warn_(files_.front() + ": no column for point " + m + ": it is never read");
    next_file_ = 1;
  }
}

CycleReader::~CycleReader() = default;

bool CycleReader::open_next_recording() {
  if (recording_ && recording_->torn_tail()) {
    ++torn_;
    warn_(recording_->path() + ": the last record (at byte " +
          std::to_string(recording_->torn_offset()) +
          ") is torn (a write a crash interrupted): skipped");
  }
  recording_.reset();
  if (next_file_ >= files_.size()) return false;
  const std::string& path = files_[next_file_++];
  if (is_csv(path)) throw RecordingError(path + ": a CSV among recordings");
  recording_ = std::make_unique<RecordingReader>(path);
  check_points(*recording_, unit_);
  if (recording_->header().unit != unit_.id)
    throw RecordingError(path + ": a recording of unit " + recording_->header().unit + ", not " +
                         unit_.id);
  if (!started_ || recording_->header().run_ns != run_) {
    // A recording from another run of the daemon: its estimator started again too.
    if (started_)
      warn_(path +
            ": recorded by another run of the daemon; the estimator starts again from the "
            "measured conditions (a daemon that resumed from a checkpoint did not)");
    run_changed_ = true;
    run_ = recording_->header().run_ns;
  }
  started_ = true;
  return true;
}

bool CycleReader::next(recording::RecordedCycle& out, bool& new_run) {
  new_run = false;
  if (csv_) {
    if (!csv_->next(out)) return false;
    new_run = !started_;
    started_ = true;
    return true;
  }
  while (!recording_ || !recording_->next(out))
    if (!open_next_recording()) return false;
  new_run = run_changed_;
  run_changed_ = false;
  return true;
}

}  // namespace hvac_twin::replay

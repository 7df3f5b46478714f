#include "daemon/replay/csv_points.hpp"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <sstream>

namespace hvac_twin::replay {

std::vector<std::string> split_csv_line(const std::string& line) {
  std::vector<std::string> out;
  std::string field;
  std::stringstream s(line);
  while (std::getline(s, field, ',')) {
    while (!field.empty() && std::isspace(static_cast<unsigned char>(field.back())))
      field.pop_back();
    std::size_t lead = 0;
    while (lead < field.size() && std::isspace(static_cast<unsigned char>(field[lead])))
      ++lead;
    out.push_back(field.substr(lead));
  }
  if (!line.empty() && line.back() == ',') out.emplace_back();
  return out;
}

namespace {

using recording::RecordingError;

std::optional<double> number(const std::string& field) {
  if (field.empty()) return std::nullopt;
  char* end = nullptr;
  const double v = std::strtod(field.c_str(), &end);
  if (end != field.c_str() + field.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

}  // namespace

std::optional<std::int64_t> parse_time(const std::string& field) {
  // Seconds since the epoch, exactly to the nanosecond (a double has 0.2 us at 2026's epoch
  // seconds: too coarse to place a reading before or after a cycle).
  if (!field.empty() && field.find_first_not_of("0123456789.") == std::string::npos &&
      field.find('.') == field.rfind('.') && field.front() != '.') {
    const std::size_t dot = field.find('.');
    const std::string whole = field.substr(0, dot);
    std::string fraction = dot == std::string::npos ? "" : field.substr(dot + 1);
    if (whole.size() > 10 || fraction.size() > 9) return std::nullopt;
    fraction.resize(9, '0');
    return std::stoll(whole) * 1'000'000'000 + std::stoll(fraction);
  }
  int y = 0, mo = 0, d = 0, h = 0, mi = 0, sec = 0, used = 0;
  char sep = 0;
  if (std::sscanf(field.c_str(), "%4d-%2d-%2d%c%2d:%2d:%2d%n", &y, &mo, &d, &sep, &h, &mi, &sec,
                  &used) != 7 ||
      (sep != 'T' && sep != ' ') || mo < 1 || mo > 12 || d < 1 || d > 31 || h > 23 || mi > 59 ||
      sec > 60)
    return std::nullopt;
  std::size_t at = static_cast<std::size_t>(used);
  double fraction = 0.0;
  if (at < field.size() && field[at] == '.') {
    std::size_t end = at + 1;
    while (end < field.size() && std::isdigit(static_cast<unsigned char>(field[end])))
      ++end;
    if (end == at + 1) return std::nullopt;
    fraction = std::strtod(field.substr(at, end - at).c_str(), nullptr);
    at = end;
  }
  long offset_s = 0;
  const std::string zone = field.substr(at);
  if (!zone.empty() && zone != "Z") {
    int oh = 0, om = 0;
    if (zone.size() != 6 || (zone[0] != '+' && zone[0] != '-') ||
        std::sscanf(zone.c_str() + 1, "%2d:%2d", &oh, &om) != 2 || oh > 23 || om > 59)
      return std::nullopt;
    offset_s = (zone[0] == '+' ? 1 : -1) * (oh * 3600L + om * 60L);
  }
  std::tm tm{};
  tm.tm_year = y - 1900;
  tm.tm_mon = mo - 1;
  tm.tm_mday = d;
  tm.tm_hour = h;
  tm.tm_min = mi;
  tm.tm_sec = sec;
  const std::time_t t = timegm(&tm);
  return (static_cast<std::int64_t>(t) - offset_s) * 1'000'000'000 +
         static_cast<std::int64_t>(std::llround(fraction * 1e9));
}

CsvPoints::CsvPoints(std::string path, const config::UnitConfig& unit, double input_hold_s)
    : path_(std::move(path)),
      in_(path_),
      period_ns_(static_cast<std::int64_t>(std::llround(unit.estimator.period_s * 1e9))) {
  if (!in_) throw RecordingError(path_ + ": cannot be opened for reading");
  for (std::size_t i = 0; i < unit.points.size(); ++i) {
    const auto& c = unit.points[i];
    Point p;
    p.index = i;
    p.measured = c.role == config::PointRole::kMeasured;
    p.hold_ns = (input_hold_s > 0.0 ? input_hold_s : c.stale_after_s) * 1e9;
    p.min = c.range_min;
    p.max = c.range_max;
    points_.push_back(p);
  }
  std::string line;
  if (next_line(line)) {
    const auto columns = split_csv_line(line);
    if (columns.empty() || columns[0] != "time")
      fail("the header row's first column must be \"time\"");
    std::vector<bool> seen(unit.points.size(), false);
    for (std::size_t c = 1; c < columns.size(); ++c) {
      long found = -1;
      for (std::size_t i = 0; i < unit.points.size(); ++i)
        if (unit.points[i].name == columns[c]) found = static_cast<long>(i);
      if (found < 0)
        fail("column " + std::to_string(c + 1) + " \"" + columns[c] + "\" is not a point of unit " +
             unit.id);
      if (seen[static_cast<std::size_t>(found)])
        fail("column " + std::to_string(c + 1) + " \"" + columns[c] + "\" repeats a point");
      seen[static_cast<std::size_t>(found)] = true;
      column_point_.push_back(found);
    }
    for (std::size_t i = 0; i < seen.size(); ++i)
      if (!seen[i]) missing_.push_back(unit.points[i].name);
    row_.resize(column_point_.size());
    return;
  }
  fail("no header row");
}

void CsvPoints::fail(const std::string& what) const {
  throw RecordingError(path_ + ": line " + std::to_string(line_) + ": " + what);
}

bool CsvPoints::next_line(std::string& line) {
  while (std::getline(in_, line)) {
    ++line_;
    if (!line.empty() && line.back() == '\r') line.pop_back();  // a file from Windows
    if (!line.empty() && line[0] != '#') return true;
  }
  return false;
}

bool CsvPoints::read_row() {
  std::string line;
  if (next_line(line)) {
    const auto fields = split_csv_line(line);
    if (fields.size() != column_point_.size() + 1)
      fail(std::to_string(fields.size()) + " fields, the header has " +
           std::to_string(column_point_.size() + 1));
    const auto t = parse_time(fields[0]);
    if (!t)
      fail("column 1: time \"" + fields[0] +
           "\" is neither seconds since the Unix epoch nor ISO 8601 (2026-07-01T12:00:00Z)");
    if (have_row_ && *t < row_time_) fail("column 1: time goes backwards");
    for (std::size_t c = 0; c < column_point_.size(); ++c) {
      row_[c] = number(fields[c + 1]);
      if (!fields[c + 1].empty() && !row_[c])
        fail("column " + std::to_string(c + 2) + ": \"" + fields[c + 1] + "\" is not a number");
    }
    row_time_ = *t;
    return true;
  }
  return false;
}

bool CsvPoints::next(recording::RecordedCycle& out) {
  if (!started_) {
    have_row_ = read_row();
    if (!have_row_) fail("no data rows");
    first_ns_ = last_row_ns_ = row_time_;
    started_ = true;
  }
  const std::int64_t t = first_ns_ + static_cast<std::int64_t>(cycle_) * period_ns_;
  if (!have_row_ && t > last_row_ns_) return false;
  while (have_row_ && row_time_ <= t) {
    for (std::size_t c = 0; c < column_point_.size(); ++c) {
      if (!row_[c]) continue;
      Point& p = points_[static_cast<std::size_t>(column_point_[c])];
      p.have = true;
      p.fused = false;
      p.value = *row_[c];
      p.time_ns = row_time_;
    }
    last_row_ns_ = row_time_;
    have_row_ = read_row();
  }
  out.cycle = cycle_++;
  out.ticks_since_last = 1;
  out.timestamp_ns = t;
  out.connected = true;
  out.samples.resize(points_.size());
  for (Point& p : points_) {
    modbus::PointSample& s = out.samples[p.index];
    s = modbus::PointSample{.value = p.value, .read_time_ns = p.have ? p.time_ns : 0};
    if (!p.have) {
      s.quality = modbus::PointQuality::kNotYetRead;
    } else if (p.value < p.min || p.value > p.max) {
      s.quality = modbus::PointQuality::kOutOfRange;
    } else if (p.measured) {
      s.quality = p.fused ? modbus::PointQuality::kStale : modbus::PointQuality::kGood;
      p.fused = true;
    } else {
      s.quality = static_cast<double>(t - p.time_ns) <= p.hold_ns ? modbus::PointQuality::kGood
                                                                  : modbus::PointQuality::kStale;
    }
  }
  return true;
}

}  // namespace hvac_twin::replay

// The simulator's truth CSV, looked up by wall-clock time.
#pragma once

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace hvac_twin::test {

class Truth {
 public:
  explicit Truth(const std::string& csv_path) {
    std::ifstream f(csv_path);
    std::string line, cell;
    if (!std::getline(f, line)) throw std::runtime_error("empty truth " + csv_path);
    std::stringstream header(line);
    for (int i = 0; std::getline(header, cell, ','); ++i)
      column_[cell] = i;
    while (std::getline(f, line)) {
      std::stringstream row(line);
      std::vector<double> values;
      while (std::getline(row, cell, ','))
        values.push_back(std::stod(cell));
      rows_.push_back(std::move(values));
    }
  }

  std::size_t size() const { return rows_.size(); }

  // Column `name` linearly interpolated at wall time `t_ns` (clamped to the recorded span).
  double at(std::int64_t t_ns, const std::string& name) const {
    const int c = column_.at(name);
    const auto t = static_cast<double>(t_ns);
    const auto it = std::lower_bound(rows_.begin(), rows_.end(), t,
                                     [](const auto& r, double v) { return r[0] < v; });
    if (it == rows_.begin()) return rows_.front()[static_cast<std::size_t>(c)];
    if (it == rows_.end()) return rows_.back()[static_cast<std::size_t>(c)];
    const auto& b = *it;
    const auto& a = *(it - 1);
    const double w = (t - a[0]) / (b[0] - a[0]);
    return a[static_cast<std::size_t>(c)] +
           w * (b[static_cast<std::size_t>(c)] - a[static_cast<std::size_t>(c)]);
  }
  // Model time [s] at wall time t_ns.
  double model_time(std::int64_t t_ns) const { return at(t_ns, "t_s"); }

 private:
  std::map<std::string, int> column_;
  std::vector<std::vector<double>> rows_;
};

}  // namespace hvac_twin::test

// hvac-twin-replay's CSV for tests: a header row, then one row per cycle.
#pragma once

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace hvac_twin::test {

struct ReplayCsv {
  std::vector<std::string> columns;
  std::vector<std::vector<std::string>> rows;
  std::map<std::string, std::size_t> index;
  std::string duplicate;  // a column name the header repeats ("": none)

  explicit ReplayCsv(const std::string& path) {
    std::ifstream in(path);
    std::string line;
    bool header = true;
    while (std::getline(in, line)) {
      std::vector<std::string> fields;
      std::stringstream s(line);
      std::string f;
      while (std::getline(s, f, ','))
        fields.push_back(f);
      if (!line.empty() && line.back() == ',') fields.emplace_back();
      if (header) {
        columns = fields;
        for (std::size_t i = 0; i < columns.size(); ++i)
          if (!index.emplace(columns[i], i).second) duplicate = columns[i];
        header = false;
      } else {
        rows.push_back(fields);
      }
    }
  }
  bool has(const std::string& column) const { return index.count(column) != 0; }
  const std::string& field(std::size_t row, const std::string& column) const {
    return rows.at(row).at(index.at(column));
  }
  // NaN for an empty field.
  double number(std::size_t row, const std::string& column) const {
    const std::string& f = field(row, column);
    return f.empty() ? std::nan("") : std::strtod(f.c_str(), nullptr);
  }
};

// |a - b| within `rel` of the larger magnitude (or of 1 near zero).
inline bool close(double a, double b, double rel) {
  return std::abs(a - b) <= rel * std::max({1.0, std::abs(a), std::abs(b)});
}

}  // namespace hvac_twin::test

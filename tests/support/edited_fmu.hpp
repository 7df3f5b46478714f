// FMUs made for tests from the exported zone FMU (<build>/fmu/zone_rc): its description edited,
// repacked with its binary (libzip). Header-only: the including test links PkgConfig::LIBZIP and
// is built with HVAC_TWIN_BINARY_DIR (tests/CMakeLists.txt). Throws std::runtime_error.
#pragma once

#include <zip.h>

#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace hvac_twin::test {

inline std::string read_binary_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot read");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

inline const std::string& zone_fmu_stage() {
  static const std::string stage = std::string(HVAC_TWIN_BINARY_DIR) + "/fmu/zone_rc/";
  return stage;
}
inline std::string zone_fmu_description() {
  return read_binary_file(zone_fmu_stage() + "modelDescription.xml");
}
inline std::string zone_fmu_binary() {
  return read_binary_file(zone_fmu_stage() + "binaries/linux64/zone_rc.so");
}

// Writes a zip archive of (name, content) entries.
inline void write_zip(const std::string& path,
                      const std::vector<std::pair<std::string, std::string>>& entries) {
  int error = 0;
  zip_t* z = zip_open(path.c_str(), ZIP_CREATE | ZIP_TRUNCATE, &error);
  if (z == nullptr) throw std::runtime_error(path + ": cannot create");
  for (const auto& [name, content] : entries) {
    zip_source_t* src = zip_source_buffer(z, content.data(), content.size(), 0);
    if (src == nullptr || zip_file_add(z, name.c_str(), src, ZIP_FL_ENC_UTF_8) < 0) {
      zip_source_free(src);
      zip_discard(z);
      throw std::runtime_error(path + ": cannot add " + name);
    }
  }
  if (zip_close(z) != 0) throw std::runtime_error(path + ": cannot write");
}

// The zone FMU with the first `from` in its description replaced by `to`, written to `path`.
inline void write_edited_zone_fmu(const std::string& path, const std::string& from,
                                  const std::string& to) {
  std::string xml = zone_fmu_description();
  const auto at = xml.find(from);
  if (at == std::string::npos) throw std::runtime_error("not in the description: " + from);
  xml.replace(at, from.size(), to);
  write_zip(path,
            {{"modelDescription.xml", xml}, {"binaries/linux64/zone_rc.so", zone_fmu_binary()}});
}

// The value reference attribute of the zone FMU's first output, as the description spells it:
// an edit to an unknown reference makes the binary answer fmi2GetReal with fmi2Error.
inline std::string zone_fmu_first_output_ref() {
  const std::string xml = zone_fmu_description();
  const auto output = xml.find("causality=\"output\"");
  const auto ref_at = xml.rfind("valueReference=\"", output);
  const auto ref_end = xml.find('"', ref_at + 16);
  return xml.substr(ref_at, ref_end + 1 - ref_at);
}

}  // namespace hvac_twin::test

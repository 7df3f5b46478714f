// A test's scratch directory: <temp>/hvac-twin-<name>-<pid>, emptied when made and removed with
// its owner, so a test run leaves nothing in /tmp (a full ctest run used to leave about 30
// directories there). HVAC_TWIN_KEEP_TEST_DIRS=1 keeps them for a look after a failure; the
// integration tests also print the daemon's log when they fail.
#pragma once

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>

namespace hvac_twin::test {

class ScratchDir {
 public:
  explicit ScratchDir(const std::string& name)
      : path_(std::filesystem::temp_directory_path() /
              ("hvac-twin-" + name + "-" + std::to_string(::getpid()))) {
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~ScratchDir() {
    const char* keep = std::getenv("HVAC_TWIN_KEEP_TEST_DIRS");
    if (keep != nullptr && std::string(keep) == "1") return;
    std::error_code ec;  // best effort: a file a sandboxed daemon left may not be ours to remove
    std::filesystem::remove_all(path_, ec);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;

  [[nodiscard]] const std::filesystem::path& path() const { return path_; }
  [[nodiscard]] std::string operator/(const std::string& file) const {
    return (path_ / file).string();
  }

 private:
  std::filesystem::path path_;
};

}  // namespace hvac_twin::test

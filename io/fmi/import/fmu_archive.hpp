// Unpacking an FMU (a zip archive) into a directory the caller owns: the daemon's private state
// or runtime directory, never a shared /tmp (an FMU's binary is native code the daemon loads).
// Entries that would land outside the directory (absolute paths, "..", backslashes) are refused,
// and so are archives that unpack to more than kMaxUnpackedBytes or kMaxEntries (a zip bomb).
// Start-up only; throws FmuError naming the archive and the entry.
#pragma once

#include <cstddef>
#include <string>

#include "io/fmi/import/model_description.hpp"

namespace hvac_twin::fmi {

inline constexpr std::size_t kMaxUnpackedBytes = std::size_t{1} << 30;  // 1 GiB
inline constexpr std::size_t kMaxEntries = 100000;
inline constexpr std::size_t kMaxDescriptionBytes = std::size_t{64} << 20;  // 64 MiB

// The FMU's description, read from the archive without unpacking it, and checked as the import
// checks it (parse_model_description), and that the archive holds its linux64 binary.
ModelDescription read_fmu_description(const std::string& fmu_path);

// Written into each unpack directory: an earlier unpack there is replaced whole.
inline constexpr const char* kUnpackMarker = ".hvac-twin-fmu";

// Unpacks `fmu_path` into `directory` (created, mode 0700). The directory must be missing, empty,
// or an earlier unpack (it holds kUnpackMarker), which is removed first. A shared library that
// is still loaded stays mapped: removing its file does not disturb it.
void unpack_fmu(const std::string& fmu_path, const std::string& directory);

}  // namespace hvac_twin::fmi

#include "io/fmi/import/fmu_archive.hpp"

#include <zip.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <vector>

#include "io/fmi/import/model_description.hpp"

namespace hvac_twin::fmi {
namespace {

namespace fs = std::filesystem;

struct ZipCloser {
  void operator()(zip_t* z) const { zip_discard(z); }
};
struct FileCloser {
  void operator()(zip_file_t* f) const { zip_fclose(f); }
};

// A relative path of plain components, or empty when the entry name could escape.
fs::path safe_relative(const std::string& name) {
  if (name.empty() || name.front() == '/' || name.find('\\') != std::string::npos ||
      name.find('\0') != std::string::npos)
    return {};
  const fs::path p(name);
  for (const auto& part : p)
    if (part == ".." || part == "." || part.has_root_name()) return {};
  return p;
}

using Archive = std::unique_ptr<zip_t, ZipCloser>;

Archive open_archive(const std::string& fmu_path) {
  std::error_code ec;
  if (!fs::is_regular_file(fmu_path, ec)) throw FmuError(fmu_path + ": no such file");
  int error = 0;
  Archive archive(zip_open(fmu_path.c_str(), ZIP_RDONLY, &error));
  if (!archive) {
    zip_error_t ze;
    zip_error_init_with_code(&ze, error);
    const std::string why = zip_error_strerror(&ze);
    zip_error_fini(&ze);
    throw FmuError(fmu_path + ": cannot open as an FMU (zip archive): " + why);
  }
  return archive;
}

}  // namespace

ModelDescription read_fmu_description(const std::string& fmu_path) {
  const Archive archive = open_archive(fmu_path);
  const zip_int64_t at = zip_name_locate(archive.get(), "modelDescription.xml", 0);
  if (at < 0) throw FmuError(fmu_path + ": modelDescription.xml: missing from the FMU");
  zip_stat_t st;
  if (zip_stat_index(archive.get(), static_cast<zip_uint64_t>(at), 0, &st) != 0 ||
      (st.valid & ZIP_STAT_SIZE) == 0 || st.size > kMaxDescriptionBytes)
    throw FmuError(fmu_path + ": modelDescription.xml unreadable or larger than " +
                   std::to_string(kMaxDescriptionBytes >> 20) + " MiB");
  std::string text(static_cast<std::size_t>(st.size), '\0');
  std::unique_ptr<zip_file_t, FileCloser> in(
      zip_fopen_index(archive.get(), static_cast<zip_uint64_t>(at), 0));
  if (!in || zip_fread(in.get(), text.data(), text.size()) != static_cast<zip_int64_t>(st.size))
    throw FmuError(fmu_path + ": modelDescription.xml corrupt");
  ModelDescription d = parse_model_description(text, fmu_path);
  const std::string binary = "binaries/linux64/" + d.model_identifier + ".so";
  if (zip_name_locate(archive.get(), binary.c_str(), 0) < 0)
    throw FmuError(fmu_path + ": no linux64 binary (" + binary + ")");
  return d;
}

void unpack_fmu(const std::string& fmu_path, const std::string& directory) {
  const Archive archive = open_archive(fmu_path);
  const zip_int64_t entries = zip_get_num_entries(archive.get(), 0);
  if (entries < 0 || static_cast<std::size_t>(entries) > kMaxEntries)
    throw FmuError(fmu_path + ": " + std::to_string(entries) + " entries (at most " +
                   std::to_string(kMaxEntries) + ")");
  const fs::path root(directory);
  std::error_code ec;
  // An earlier unpack is replaced whole (a file the new FMU lacks must not survive); any other
  // content is not ours to delete.
  if (fs::exists(root / kUnpackMarker, ec)) {
    fs::remove_all(root, ec);
    if (ec) throw FmuError(directory + ": cannot remove the earlier unpack: " + ec.message());
  } else if (fs::exists(root, ec) && !fs::is_empty(root, ec)) {
    throw FmuError(directory + ": not empty, and not an earlier FMU unpack (no " +
                   std::string(kUnpackMarker) + "); refusing to unpack into it");
  }
  fs::create_directories(root, ec);
  if (ec) throw FmuError(directory + ": cannot create the unpack directory: " + ec.message());
  fs::permissions(root, fs::perms::owner_all, fs::perm_options::replace, ec);
  std::ofstream(root / kUnpackMarker) << fmu_path << '\n';
  std::size_t total = 0;
  std::vector<char> buffer(1 << 16);
  for (zip_int64_t i = 0; i < entries; ++i) {
    zip_stat_t st;
    if (zip_stat_index(archive.get(), static_cast<zip_uint64_t>(i), 0, &st) != 0)
      throw FmuError(fmu_path + ": entry " + std::to_string(i) +
                     " unreadable: " + zip_strerror(archive.get()));
    const std::string name = st.name;
    const fs::path rel = safe_relative(name);
    if (rel.empty())
      throw FmuError(fmu_path + ": entry \"" + name + "\" would unpack outside its directory");
    const fs::path target = root / rel;
    if (name.back() == '/') {
      fs::create_directories(target, ec);
      if (ec) throw FmuError(target.string() + ": cannot create: " + ec.message());
      continue;
    }
    fs::create_directories(target.parent_path(), ec);
    if (ec) throw FmuError(target.parent_path().string() + ": cannot create: " + ec.message());
    std::unique_ptr<zip_file_t, FileCloser> in(
        zip_fopen_index(archive.get(), static_cast<zip_uint64_t>(i), 0));
    if (!in)
      throw FmuError(fmu_path + ": entry \"" + name +
                     "\" unreadable: " + zip_strerror(archive.get()));
    std::ofstream out(target, std::ios::binary | std::ios::trunc);
    if (!out) throw FmuError(target.string() + ": cannot write");
    for (;;) {
      const zip_int64_t got = zip_fread(in.get(), buffer.data(), buffer.size());
      if (got < 0)
        throw FmuError(fmu_path + ": entry \"" + name +
                       "\" corrupt: " + zip_file_strerror(in.get()));
      if (got == 0) break;
      total += static_cast<std::size_t>(got);
      if (total > kMaxUnpackedBytes)
        throw FmuError(fmu_path + ": unpacks to more than " +
                       std::to_string(kMaxUnpackedBytes >> 20) + " MiB");
      out.write(buffer.data(), static_cast<std::streamsize>(got));
    }
    out.close();
    if (!out) throw FmuError(target.string() + ": write failed");
  }
}

}  // namespace hvac_twin::fmi

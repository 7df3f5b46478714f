// Test program: saves checkpoints of the fixture's snapshots with increasing cycle counters,
// as a daemon would, for the kill -9 and fault-injection tests.
//
//   hvac_twin_ckpt_writer DIR [--start C] [--count K] [--states N] [--naive] [--report]
//                             [--fsize-limit-after K BYTES]
//
//  --start C    first cycle (default 1); --count K saves (0: until killed; default 0)
//  --states N   states per snapshot (default 64: a 33 kB file, so a naive write is not instant)
//  --naive      the negative control: writes DIR/state.ckpt in place (open O_TRUNC, two write()
//               calls, close; no temporary, no fsync, no rename), as a naive daemon would
//  --report     after each save prints "save C ok|fail STEP ERRNO disk=D tmp=T": D the cycle of
//               the checkpoint on disk (none, or corrupt), T whether state.ckpt.tmp exists.
//               Lines are collected and printed at exit, so that under strace's fault injection
//               into write() the writer's own output never consumes an injected call; the check
//               only reads (open, read, close, access), so it shifts no injected call either.
//  --fsize-limit-after K BYTES   after K saves, RLIMIT_FSIZE = BYTES and SIGXFSZ ignored: the
//               next write() is short, the one after it fails with EFBIG (real, no tracer)
//
// Exit status 0 after --count saves, whether they succeeded or not (a daemon keeps running); 2
// on a usage error.
#include <fcntl.h>
#include <sys/resource.h>
#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "daemon/runtime/checkpoint_store.hpp"
#include "tests/checkpoint/checkpoint_fixture.hpp"

namespace {

using namespace hvac_twin;

constexpr const char* kName = "state.ckpt";

// The naive writer: a crash between the truncation and the last write leaves a short file.
bool save_naive(const std::string& path, std::span<const std::byte> bytes) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) return false;
  const std::size_t half = bytes.size() / 2;
  bool ok = ::write(fd, bytes.data(), half) == static_cast<ssize_t>(half);
  ok = ok && ::write(fd, bytes.data() + half, bytes.size() - half) ==
                 static_cast<ssize_t>(bytes.size() - half);
  return ::close(fd) == 0 && ok;
}

// Which cycle the file on disk holds, by reading it (never load(), which would clean up).
std::string disk_cycle(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return "none";
  std::vector<std::byte> bytes(1 << 20);
  std::size_t got = 0;
  for (ssize_t r; (r = ::read(fd, bytes.data() + got, bytes.size() - got)) > 0;)
    got += static_cast<std::size_t>(r);
  ::close(fd);
  bytes.resize(got);
  const auto decoded = runtime::decode_checkpoint(bytes);
  if (!decoded.ok() || !test::is_snapshot_of_its_cycle(decoded.snapshot)) return "corrupt";
  return std::to_string(decoded.snapshot.cycle);
}

int usage() {
  std::fprintf(stderr,
               "usage: hvac_twin_ckpt_writer DIR [--start C] [--count K] [--states N] "
               "[--naive] [--report] [--fsize-limit-after K BYTES]\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return usage();
  const std::string dir = argv[1];
  unsigned long long start = 1, count = 0, limit_after = 0, limit_bytes = 0;
  std::size_t states = 64;
  bool naive = false, report = false, limit = false;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--start" && has_value) {
      start = std::strtoull(argv[++i], nullptr, 10);
    } else if (a == "--count" && has_value) {
      count = std::strtoull(argv[++i], nullptr, 10);
    } else if (a == "--states" && has_value) {
      states = std::strtoull(argv[++i], nullptr, 10);
    } else if (a == "--naive") {
      naive = true;
    } else if (a == "--report") {
      report = true;
    } else if (a == "--fsize-limit-after" && i + 2 < argc) {
      limit = true;
      limit_after = std::strtoull(argv[++i], nullptr, 10);
      limit_bytes = std::strtoull(argv[++i], nullptr, 10);
    } else {
      return usage();
    }
  }

  runtime::CheckpointStore store(dir, kName, test::checkpoint_expectation(states));
  runtime::FilterSnapshot snapshot;
  test::fill_snapshot(snapshot, start, states);
  std::vector<std::byte> naive_buffer(runtime::checkpoint_size(snapshot));
  std::string lines;
  rlimit fsize{};
  ::getrlimit(RLIMIT_FSIZE, &fsize);
  const rlim_t unlimited = fsize.rlim_cur;
  for (unsigned long long k = 0; count == 0 || k < count; ++k) {
    if (limit && k == limit_after) {
      std::signal(SIGXFSZ, SIG_IGN);
      fsize.rlim_cur = limit_bytes;  // the soft limit only, so that it can be lifted again
      if (::setrlimit(RLIMIT_FSIZE, &fsize) != 0) return 3;
    }
    const std::uint64_t cycle = start + k;
    test::fill_snapshot(snapshot, cycle, states);
    runtime::SaveStatus status;
    if (naive) {
      runtime::encode_checkpoint(snapshot, naive_buffer);
      if (!save_naive(store.path(), naive_buffer)) status = {runtime::SaveStep::kWrite, errno};
    } else {
      status = store.save(snapshot);
    }
    if (!report) continue;
    lines += "save " + std::to_string(cycle) + (status.ok() ? " ok" : " fail") + " " +
             std::string(runtime::to_string(status.failed_step)) + " " +
             std::to_string(status.error) + " disk=" + disk_cycle(store.path()) +
             " tmp=" + (::access(store.tmp_path().c_str(), F_OK) == 0 ? "1" : "0") + "\n";
  }
  fsize.rlim_cur = unlimited;  // stdout may be a file
  ::setrlimit(RLIMIT_FSIZE, &fsize);
  std::fputs(lines.c_str(), stdout);
  return 0;
}

// Helpers for the service tests: run a command and collect its output, read and edit files, read
// a unit file, and expand systemd's system-call groups the way a unit's SystemCallFilter= does.
#pragma once

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

extern char** environ;

namespace hvac_twin::test {

struct RunResult {
  int status = -1;     // exit status, 128 + signal, or -1 if it could not start
  std::string output;  // stdout and stderr, interleaved
};

inline std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

inline void replace_all(std::string& s, const std::string& from, const std::string& to) {
  for (std::size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size()))
    s.replace(at, from.size(), to);
}

// Runs `args` (args[0] looked up in PATH) to completion.
inline RunResult run(std::vector<std::string> args) {
  RunResult r;
  char path[] = "/tmp/hvac-twin-run-XXXXXX";
  const int fd = ::mkstemp(path);
  if (fd < 0) return r;
  std::vector<char*> argv;
  for (auto& a : args)
    argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_adddup2(&fa, fd, 1);
  posix_spawn_file_actions_adddup2(&fa, fd, 2);
  posix_spawn_file_actions_addopen(&fa, 0, "/dev/null", O_RDONLY, 0);
  pid_t pid = 0;
  const int rc = posix_spawnp(&pid, argv[0], &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  ::close(fd);
  if (rc == 0) {
    int st = 0;
    ::waitpid(pid, &st, 0);
    r.status = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
  } else {
    r.output = "cannot run " + args[0] + "\n";
  }
  r.output += read_file(path);
  ::unlink(path);
  return r;
}

// A unit file as "Section.Key" -> every value given (in order; an empty assignment resets).
inline std::map<std::string, std::vector<std::string>> parse_unit(const std::string& file) {
  std::map<std::string, std::vector<std::string>> out;
  std::istringstream in(read_file(file));
  std::string line, section;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || line[0] == ';') continue;
    if (line.front() == '[' && line.back() == ']') {
      section = line.substr(1, line.size() - 2);
      continue;
    }
    const auto eq = line.find('=');
    if (eq == std::string::npos) continue;
    auto& values = out[section + "." + line.substr(0, eq)];
    const std::string value = line.substr(eq + 1);
    if (value.empty())
      values.clear();
    else
      values.push_back(value);
  }
  return out;
}

// The system calls a unit's SystemCallFilter= lines allow: the union of the allow lines minus
// the union of the "~" lines, with every @group expanded from `systemd-analyze syscall-filter`.
inline std::set<std::string> allowed_syscalls(const std::vector<std::string>& filter_lines) {
  const RunResult r = run({"systemd-analyze", "syscall-filter", "--no-pager"});
  if (r.status != 0) throw std::runtime_error("systemd-analyze syscall-filter: " + r.output);
  std::map<std::string, std::vector<std::string>> groups;
  std::istringstream in(r.output);
  std::string line, group;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    if (line[0] == '@') {
      group = line.substr(0, line.find_first_of(" \t"));
      continue;
    }
    const auto start = line.find_first_not_of(" \t");
    if (group.empty() || start == std::string::npos || line[start] == '#') continue;
    groups[group].push_back(line.substr(start, line.find_first_of(" \t", start) - start));
  }
  std::set<std::string> expanding;
  const auto expand = [&](const auto& self, const std::string& item, std::set<std::string>& into) {
    if (item[0] != '@') {
      into.insert(item);
      return;
    }
    const auto it = groups.find(item);
    if (it == groups.end()) throw std::runtime_error("unknown system call group " + item);
    if (!expanding.insert(item).second) return;
    for (const auto& member : it->second)
      self(self, member, into);
    expanding.erase(item);
  };
  std::set<std::string> allowed, denied;
  for (const auto& value : filter_lines) {
    const bool deny = !value.empty() && value[0] == '~';
    std::istringstream words(deny ? value.substr(1) : value);
    std::string word;
    while (words >> word)
      expand(expand, word, deny ? denied : allowed);
  }
  for (const auto& d : denied)
    allowed.erase(d);
  return allowed;
}

}  // namespace hvac_twin::test

// Running the real binaries from a test: a shell command with its combined output and exit code.
// POSIX only (popen), like the rest of the suite's tool tests.
#pragma once

#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>

namespace shrefract::testing {

struct CommandResult {
  int exitCode = -1;   // the process's exit status; 128 + signal when it was killed
  std::string output;  // stdout and stderr, interleaved
};

inline CommandResult runCommand(const std::string& command) {
  CommandResult result;
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (!pipe) return result;
  char buffer[4096];
  size_t n = 0;
  while ((n = std::fread(buffer, 1, sizeof(buffer), pipe)) > 0) result.output.append(buffer, n);
  const int status = pclose(pipe);
  if (WIFEXITED(status)) result.exitCode = WEXITSTATUS(status);
  else if (WIFSIGNALED(status)) result.exitCode = 128 + WTERMSIG(status);
  return result;
}

// Single-quotes `text` for /bin/sh.
inline std::string shellQuote(const std::string& text) {
  std::string out = "'";
  for (char c : text) {
    if (c == '\'') out += "'\\''";
    else out += c;
  }
  return out + "'";
}

// True when `program` is an executable file in a directory of PATH.
inline bool onPath(const std::string& program) {
  const char* path = std::getenv("PATH");
  if (!path) return false;
  std::stringstream dirs(path);
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    if (dir.empty()) continue;
    const std::filesystem::path candidate = std::filesystem::path(dir) / program;
    std::error_code ec;
    if (std::filesystem::is_regular_file(candidate, ec) &&
        (std::filesystem::status(candidate, ec).permissions() & std::filesystem::perms::owner_exec) !=
            std::filesystem::perms::none)
      return true;
  }
  return false;
}

// Number of lines in `text` that are not empty.
inline int nonEmptyLines(const std::string& text) {
  int lines = 0;
  std::stringstream in(text);
  std::string line;
  while (std::getline(in, line))
    if (!line.empty()) ++lines;
  return lines;
}

}  // namespace shrefract::testing

#include "cli/interrupt.h"

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

namespace shrefract::cli {
namespace {

namespace fs = std::filesystem;

struct Registry {
  std::mutex mutex;
  std::vector<fs::path> paths;
};

Registry& registry() {
  static Registry r;
  return r;
}

sigset_t interruptSignals() {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGTERM);
  sigaddset(&set, SIGHUP);
  return set;
}

// Runs on the waiting thread, an ordinary thread: std::filesystem is safe here, unlike in a
// signal handler. The registry stays locked until the exit, so no stage is published meanwhile.
[[noreturn]] void cleanUpAndExit(int signal) {
  Registry& r = registry();
  r.mutex.lock();
  std::string removed;
  for (const fs::path& p : r.paths) {
    std::error_code ec;
    if (fs::remove_all(p, ec) > 0 && !ec) removed += (removed.empty() ? "" : ", ") + p.string();
  }
  // A progress bar on a terminal ends without a newline: start the message on a line of its own.
  const char* lead = isatty(STDERR_FILENO) ? "\n" : "";
  const char* name = signal == SIGINT ? "SIGINT" : signal == SIGTERM ? "SIGTERM" : "SIGHUP";
  if (removed.empty())
    std::fprintf(stderr, "%sshrefract: interrupted (%s)\n", lead, name);
  else
    std::fprintf(stderr, "%sshrefract: interrupted (%s); removed the partial output %s\n", lead, name, removed.c_str());
  std::fflush(stderr);
  std::_Exit(128 + signal);
}

}  // namespace

void installInterruptCleanup() {
  const sigset_t set = interruptSignals();
  if (pthread_sigmask(SIG_BLOCK, &set, nullptr) != 0) return;  // the defaults stay: no clean-up
  std::thread([set] {
    int signal = 0;
    while (sigwait(&set, &signal) != 0) {
    }
    cleanUpAndExit(signal);
  }).detach();
}

std::unique_lock<std::mutex> holdInterrupts() { return std::unique_lock(registry().mutex); }

RemoveOnInterrupt::RemoveOnInterrupt(fs::path path) : path_(std::move(path)) {
  Registry& r = registry();
  std::lock_guard lock(r.mutex);
  r.paths.push_back(path_);
}

RemoveOnInterrupt::~RemoveOnInterrupt() {
  Registry& r = registry();
  std::lock_guard lock(r.mutex);
  if (auto it = std::find(r.paths.begin(), r.paths.end(), path_); it != r.paths.end()) r.paths.erase(it);
}

}  // namespace shrefract::cli

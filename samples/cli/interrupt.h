// An interrupted run (Ctrl-C, SIGTERM from a job scheduler or mpirun, a closed terminal) leaves no
// partial output, as a failed run does: work that stages its output somewhere (the report's
// DIR.partial-PID) registers it here, and the interrupt removes it before the process exits.
#pragma once

#include <filesystem>
#include <mutex>

namespace shrefract::cli {

// Blocks SIGINT, SIGTERM and SIGHUP in the calling thread and starts the thread that waits for
// them. Call first in main, before any other thread starts: threads inherit the blocked mask, so
// the signal reaches only the waiting thread, which removes what is registered, prints one line
// and exits with 128 + the signal's number. Call once.
void installInterruptCleanup();

// Holds an interrupt's clean-up off while the returned lock lives: publish a staged output (its
// rename into place) under it, so that an interrupt removes either the whole stage or nothing.
std::unique_lock<std::mutex> holdInterrupts();

// Registers `path` (a file or a directory, removed recursively) for removal on an interrupt, for
// the lifetime of this object. Registering a new path replaces nothing: several may be held.
class RemoveOnInterrupt {
 public:
  explicit RemoveOnInterrupt(std::filesystem::path path);
  ~RemoveOnInterrupt();
  RemoveOnInterrupt(const RemoveOnInterrupt&) = delete;
  RemoveOnInterrupt& operator=(const RemoveOnInterrupt&) = delete;

 private:
  std::filesystem::path path_;
};

}  // namespace shrefract::cli

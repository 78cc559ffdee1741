// Progress for long work: a redrawn bar on a terminal, a plain line every 10% otherwise.
#pragma once

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <string>

namespace shrefract::cli {

class Progress {
 public:
  Progress(std::string label, FILE* out);
  // `done` of `total` units; `rate` and `rateUnit` describe throughput (e.g. rays/s).
  void update(uint64_t done, uint64_t total, double seconds, double rate, const char* rateUnit);
  void finish();
  // A stage of the work that has no count (a bake's basis, its quantization): one line with the
  // seconds since this object was made, after any bar.
  void stage(const std::string& what);

 private:
  std::string label_;
  FILE* out_;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
  bool terminal_;
  int lastDecile_ = -1;
  bool drawn_ = false;
};

}  // namespace shrefract::cli

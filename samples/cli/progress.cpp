#include "cli/progress.h"

#include <unistd.h>

#include <cinttypes>
#include <cmath>

namespace shrefract::cli {

Progress::Progress(std::string label, FILE* out)
    : label_(std::move(label)), out_(out), terminal_(isatty(fileno(out)) != 0) {}

void Progress::update(uint64_t done, uint64_t total, double seconds, double rate, const char* rateUnit) {
  const double fraction = total ? double(done) / double(total) : 1.0;
  const double eta = fraction > 0.0 ? seconds * (1.0 - fraction) / fraction : 0.0;
  const double scaled = rate >= 1e6 ? rate / 1e6 : rate >= 1e3 ? rate / 1e3 : rate;
  const char* prefix = rate >= 1e6 ? "M" : rate >= 1e3 ? "k" : "";
  if (terminal_) {
    constexpr int kWidth = 30;
    const int filled = static_cast<int>(fraction * kWidth);
    std::string bar(static_cast<size_t>(filled), '#');
    bar.resize(kWidth, '.');
    std::fprintf(out_, "\r%s [%s] %5.1f%% %" PRIu64 "/%" PRIu64 "  %.2f %s%s  ETA %.0f s   ", label_.c_str(),
                 bar.c_str(), fraction * 100.0, done, total, scaled, prefix, rateUnit, eta);
    std::fflush(out_);
    drawn_ = true;
    return;
  }
  const int decile = static_cast<int>(std::floor(fraction * 10.0));
  if (decile != lastDecile_) {
    lastDecile_ = decile;
    std::fprintf(out_, "%s: %3d%% (%" PRIu64 "/%" PRIu64 "), %.2f %s%s, ETA %.0f s\n", label_.c_str(), decile * 10,
                 done, total, scaled, prefix, rateUnit, eta);
    std::fflush(out_);
  }
}

void Progress::finish() {
  if (terminal_ && drawn_) std::fprintf(out_, "\n");
  drawn_ = false;
}

void Progress::stage(const std::string& what) {
  finish();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  std::fprintf(out_, "%s: %s (%.0f s in)\n", label_.c_str(), what.c_str(), seconds);
  std::fflush(out_);
}

}  // namespace shrefract::cli

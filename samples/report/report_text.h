// Small helpers the report's sections share: printf-style formatting and wall-clock seconds.
#pragma once

#include <chrono>
#include <cstdarg>
#include <cstdio>
#include <string>

namespace shrefract::report {

using Clock = std::chrono::steady_clock;
inline double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// printf into a string (lines of the report are short: 1023 characters at most).
__attribute__((format(printf, 1, 2))) inline std::string fmt(const char* f, ...) {
  char buf[1024];
  va_list args;
  va_start(args, f);
  std::vsnprintf(buf, sizeof buf, f, args);
  va_end(args);
  return buf;
}

}  // namespace shrefract::report

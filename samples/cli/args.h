// Strict command line parsing: every flag a command accepts is declared; anything else is an error.
#pragma once

#include <shrefract/result.h>

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace shrefract::cli {

struct FlagSpec {
  std::string name;   // without the leading "--"
  bool takesValue;    // "--name VALUE" or "--name=VALUE"; otherwise a switch
  std::string help;
};

class Args {
 public:
  // Parses argv[first..argc) against `flags`. Positional arguments are kept in order.
  static Result<Args> parse(const std::string& command, int argc, char** argv, int first,
                            const std::vector<FlagSpec>& flags);

  const std::vector<std::string>& positional() const { return positional_; }
  bool has(const std::string& name) const { return values_.count(name) != 0; }
  std::optional<std::string> get(const std::string& name) const;

  // Typed accessors: a present but malformed value is an error naming the flag.
  Result<std::optional<double>> number(const std::string& name) const;
  Result<std::optional<int64_t>> integer(const std::string& name) const;
  Result<std::optional<std::array<float, 3>>> vec3(const std::string& name) const;
  Result<std::optional<std::array<uint32_t, 2>>> size(const std::string& name) const;  // "WxH"

 private:
  std::string command_;
  std::vector<std::string> positional_;
  std::map<std::string, std::string> values_;
};

std::string usageLines(const std::vector<FlagSpec>& flags);

// True when `path` ends in `extension` (e.g. ".png"), ignoring case.
bool hasExtension(const std::string& path, const std::string& extension);

// Checked before long work (a bake, a GPU session): the output is not a directory and its
// directory exists and is writable. Errors name the path.
Result<void> checkOutputPath(const std::string& path);

}  // namespace shrefract::cli

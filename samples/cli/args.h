// Strict command line parsing: every flag a command accepts is declared; anything else is an error.
// The one flag table of every program: the `shrefract` tool's commands and the benchmarks (a
// library of its own, shrefract_flags, so that a benchmark links it without the tool).
//
// A command's flags are of two kinds. User flags are listed by --help. Developer options
// (FlagSpec::developer: experiment switches and the knobs tests and measurements turn) are given
// as `--dev KEY=VALUE` (`--dev KEY` for a switch), repeatable, and listed by --help-dev only; their
// values are checked exactly as a user flag's, and the command reads both the same way
// (Args::has, get, integer ... by name). docs/developer-options.md lists them. Their former
// spellings (`--held-out 0`) still parse, unlisted, for the scripts and tests written before.
#pragma once

#include <shrefract/result.h>

#include <array>
#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace shrefract::cli {

// What a flag's value must be. Checked by Args::parse, before any other check of a command, and
// printed by usageLines from the same declaration: help and parser cannot disagree.
enum class ValueKind { Text, Integer, Real, Size };

inline constexpr double kUnbounded = std::numeric_limits<double>::infinity();

// An interval; an open end excludes its bound. Unbounded ends are +-kUnbounded.
struct Bounds {
  double lo = -kUnbounded;
  double hi = kUnbounded;
  bool loOpen = false;
  bool hiOpen = false;
  bool contains(double v) const {
    return (loOpen ? v > lo : v >= lo) && (hiOpen ? v < hi : v <= hi);
  }
  std::string text() const;  // "0..24", "> 0", "(0, 180)", ">= 0"
};

struct FlagSpec {
  std::string name;   // without the leading "--"
  bool takesValue;    // "--name VALUE" or "--name=VALUE"; otherwise a switch
  std::string help;
  ValueKind kind = ValueKind::Text;
  Bounds range{};     // Integer, Real; Size: the first number (width, rows)
  Bounds range2{};    // Size: the second number (height, columns)
  bool developer = false;  // given as --dev NAME[=VALUE]; listed by --help-dev, not by --help

  // The range as help prints it ("0..24", "WxH: 1..16384 x 1..16384"); empty for Text.
  std::string rangeText() const;
};

class Args {
 public:
  // Parses argv[first..argc) against `flags`. Positional arguments are kept in order. Where
  // `flags` has developer options, --dev KEY[=VALUE] sets them (and --help-dev is a switch).
  static Result<Args> parse(const std::string& command, int argc, char** argv, int first,
                            const std::vector<FlagSpec>& flags);
  // The same for a program of its own (a benchmark): argv[1..argc), errors begin "PROGRAM: ",
  // --help (or -h) is added to `flags`, and "-o" is no flag.
  static Result<Args> parseProgram(const std::string& program, int argc, char** argv,
                                   const std::vector<FlagSpec>& flags);

  const std::vector<std::string>& positional() const { return positional_; }
  bool has(const std::string& name) const { return values_.count(name) != 0; }
  std::optional<std::string> get(const std::string& name) const;

  // Typed accessors: a present but malformed value is an error naming the flag.
  Result<std::optional<double>> number(const std::string& name) const;
  Result<std::optional<int64_t>> integer(const std::string& name) const;
  Result<std::optional<std::array<float, 3>>> vec3(const std::string& name) const;
  Result<std::optional<std::array<uint32_t, 2>>> size(const std::string& name) const;  // "WxH"

  // For flags whose kind and range parse checked: the value into `out` when given, and whether
  // it was.
  bool read(const std::string& name, uint32_t& out) const;
  bool read(const std::string& name, double& out) const;
  bool read(const std::string& name, std::string& out) const;
  bool read(const std::string& name, uint32_t& width, uint32_t& height) const;  // Size

 private:
  // A value against its declaration (kind and range); errors name the flag as given (`shown`)
  // and the range.
  Result<void> check(const FlagSpec& spec, const std::string& shown, const std::string& value) const;
  // `--dev KEY[=VALUE]`: the option recorded under KEY, or the error naming it.
  Result<void> setDeveloperOption(const std::string& text);
  const FlagSpec* spec(const std::string& name) const;
  std::string shownName(const std::string& name) const;  // flagName of its declaration

  static Result<Args> parseAs(const std::string& who, const std::string& command, int argc, char** argv,
                              int first, const std::vector<FlagSpec>& flags, bool tool);

  std::string command_;
  std::string who_;  // what errors begin with: "shrefract COMMAND" or the program's name
  std::vector<FlagSpec> flags_;
  std::vector<std::string> positional_;
  std::map<std::string, std::string> values_;
};

// `f` as a developer option.
FlagSpec developerOption(FlagSpec f);

// How messages name a flag: "--name", or "--dev name" for a developer option.
std::string flagName(const FlagSpec& f);

// One line per user flag: "--name VALUE  help [range: R]". Tests read the ranges back from here.
std::string usageLines(const std::vector<FlagSpec>& flags);

// One line per developer option: "--dev name=VALUE  help [range: R]" (--help-dev).
std::string developerUsageLines(const std::vector<FlagSpec>& flags);

// True when `path` ends in `extension` (e.g. ".png"), ignoring case.
bool hasExtension(const std::string& path, const std::string& extension);

// Checked before long work (a bake, a GPU session): the output is not a directory and its
// directory exists and is writable. Errors name the path.
Result<void> checkOutputPath(const std::string& path);

}  // namespace shrefract::cli

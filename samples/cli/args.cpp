#include "cli/args.h"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>

#include <unistd.h>

namespace shrefract::cli {

Result<Args> Args::parse(const std::string& command, int argc, char** argv, int first,
                         const std::vector<FlagSpec>& flags) {
  Args args;
  args.command_ = command;
  for (int i = first; i < argc; ++i) {
    std::string a = argv[i];
    if (a.size() > 2 && a.rfind("--", 0) == 0) {
      std::string name = a.substr(2);
      std::optional<std::string> inlineValue;
      if (auto eq = name.find('='); eq != std::string::npos) {
        inlineValue = name.substr(eq + 1);
        name = name.substr(0, eq);
      }
      const FlagSpec* spec = nullptr;
      for (const auto& f : flags)
        if (f.name == name) spec = &f;
      if (!spec) return makeError(ErrorCode::InvalidArgument, "shrefract " + command + ": unknown flag --" + name);
      if (args.values_.count(name))
        return makeError(ErrorCode::InvalidArgument, "shrefract " + command + ": flag --" + name + " given twice");
      if (spec->takesValue) {
        if (inlineValue) {
          args.values_[name] = *inlineValue;
        } else {
          // The next argument is the value unless it is another flag ("--x" or "-o"): "--order -o F"
          // forgot the order's value, and taking "-o" as it would blame a different argument.
          const std::string next = i + 1 < argc ? argv[i + 1] : "";
          if (i + 1 >= argc || (next.size() > 2 && next.rfind("--", 0) == 0) || next == "-o")
            return makeError(ErrorCode::InvalidArgument, "shrefract " + command + ": flag --" + name + " needs a value");
          args.values_[name] = argv[++i];
        }
      } else {
        if (inlineValue)
          return makeError(ErrorCode::InvalidArgument, "shrefract " + command + ": flag --" + name + " takes no value");
        args.values_[name] = "";
      }
    } else if (a == "-o") {
      if (i + 1 >= argc) return makeError(ErrorCode::InvalidArgument, "shrefract " + command + ": -o needs a path");
      if (args.values_.count("output"))
        return makeError(ErrorCode::InvalidArgument, "shrefract " + command + ": output given twice");
      args.values_["output"] = argv[++i];
    } else if (a.size() > 1 && a[0] == '-' && !(a[1] >= '0' && a[1] <= '9')) {
      return makeError(ErrorCode::InvalidArgument, "shrefract " + command + ": unknown flag " + a);
    } else {
      args.positional_.push_back(a);
    }
  }
  return args;
}

std::optional<std::string> Args::get(const std::string& name) const {
  auto it = values_.find(name);
  if (it == values_.end()) return std::nullopt;
  return it->second;
}

Result<std::optional<double>> Args::number(const std::string& name) const {
  auto v = get(name);
  if (!v) return std::optional<double>{};
  errno = 0;
  char* end = nullptr;
  const double d = std::strtod(v->c_str(), &end);
  if (v->empty() || *end != '\0' || errno == ERANGE || !std::isfinite(d))
    return makeError(ErrorCode::InvalidArgument,
                     "shrefract " + command_ + ": --" + name + " expects a finite number, got '" + *v + "'");
  return std::optional<double>{d};
}

Result<std::optional<int64_t>> Args::integer(const std::string& name) const {
  auto v = get(name);
  if (!v) return std::optional<int64_t>{};
  errno = 0;
  char* end = nullptr;
  const long long n = std::strtoll(v->c_str(), &end, 10);
  if (v->empty() || *end != '\0' || errno == ERANGE)
    return makeError(ErrorCode::InvalidArgument,
                     "shrefract " + command_ + ": --" + name + " expects an integer, got '" + *v + "'");
  return std::optional<int64_t>{static_cast<int64_t>(n)};
}

Result<std::optional<std::array<float, 3>>> Args::vec3(const std::string& name) const {
  auto v = get(name);
  if (!v) return std::optional<std::array<float, 3>>{};
  std::array<float, 3> out{};
  const char* p = v->c_str();
  for (int k = 0; k < 3; ++k) {
    char* end = nullptr;
    errno = 0;
    const double d = std::strtod(p, &end);
    const bool sepOk = (k < 2) ? (*end == ',') : (*end == '\0');
    if (end == p || !sepOk || errno == ERANGE || !std::isfinite(d))
      return makeError(ErrorCode::InvalidArgument,
                       "shrefract " + command_ + ": --" + name + " expects x,y,z, got '" + *v + "'");
    out[static_cast<size_t>(k)] = static_cast<float>(d);
    p = end + 1;
  }
  return std::optional<std::array<float, 3>>{out};
}

Result<std::optional<std::array<uint32_t, 2>>> Args::size(const std::string& name) const {
  auto v = get(name);
  if (!v) return std::optional<std::array<uint32_t, 2>>{};
  const auto x = v->find('x');
  auto bad = [&]() {
    return makeError(ErrorCode::InvalidArgument,
                     "shrefract " + command_ + ": --" + name + " expects WxH (1..16384 each), got '" + *v + "'");
  };
  if (x == std::string::npos) return bad();
  char* end = nullptr;
  const std::string ws = v->substr(0, x), hs = v->substr(x + 1);
  const long w = std::strtol(ws.c_str(), &end, 10);
  if (ws.empty() || *end != '\0') return bad();
  const long h = std::strtol(hs.c_str(), &end, 10);
  if (hs.empty() || *end != '\0') return bad();
  if (w < 1 || h < 1 || w > 16384 || h > 16384) return bad();
  return std::optional<std::array<uint32_t, 2>>{std::array<uint32_t, 2>{static_cast<uint32_t>(w), static_cast<uint32_t>(h)}};
}

std::string usageLines(const std::vector<FlagSpec>& flags) {
  std::string out;
  for (const auto& f : flags) {
    std::string left = "  --" + f.name + (f.takesValue ? " VALUE" : "");
    if (left.size() < 26) left.resize(26, ' ');
    out += left + " " + f.help + "\n";
  }
  return out;
}

bool hasExtension(const std::string& path, const std::string& extension) {
  if (path.size() < extension.size()) return false;
  for (size_t i = 0; i < extension.size(); ++i) {
    const auto a = static_cast<unsigned char>(path[path.size() - extension.size() + i]);
    if (std::tolower(a) != std::tolower(static_cast<unsigned char>(extension[i]))) return false;
  }
  return true;
}

Result<void> checkOutputPath(const std::string& path) {
  namespace fs = std::filesystem;
  fs::path dir = fs::path(path).parent_path();
  if (dir.empty()) dir = ".";
  std::error_code ec;
  if (fs::is_directory(path, ec)) return makeError(ErrorCode::Io, path + ": is a directory");
  if (!fs::is_directory(dir, ec)) return makeError(ErrorCode::Io, path + ": directory does not exist");
  if (access(dir.c_str(), W_OK) != 0) return makeError(ErrorCode::Io, path + ": directory is not writable");
  return {};
}

}  // namespace shrefract::cli

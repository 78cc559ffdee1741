// Sharded and distributed bakes through the real `shrefract` binary ($SHREFRACT_TOOL): the parts
// of `bake --shard I/N` merged by `shrefract merge`, and `mpirun -np 2 shrefract bake` (when the
// build found MPI: $SHREFRACT_MPIEXEC), must give the single-process bake's file byte for byte,
// the timing statistics aside (fieldsEqualButTimings). Bad parts must give one line naming the
// file, exit 1 and leave the output alone.
#include <gtest/gtest.h>
#include <shrefract/bake/shard.h>
#include <shrefract/field.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

namespace shrefract {
namespace {

namespace fs = std::filesystem;

std::string env(const char* name) {
  const char* v = std::getenv(name);
  return v ? v : "";
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

struct Outcome {
  int exitCode = -1;  // -1: killed by a signal
  std::string out, err;
};

// Runs argv in `dir`, stdin from /dev/null, stdout and stderr captured.
Outcome run(const fs::path& dir, std::vector<std::string> args) {
  const fs::path outPath = dir / ".stdout", errPath = dir / ".stderr";
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t pid = fork();
  if (pid == 0) {
    if (chdir(dir.c_str()) != 0) _exit(126);
    const int in = open("/dev/null", O_RDONLY);
    const int out = open(outPath.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int err = open(errPath.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (in < 0 || out < 0 || err < 0) _exit(126);
    dup2(in, 0);
    dup2(out, 1);
    dup2(err, 2);
    execvp(argv[0], argv.data());
    _exit(127);
  }
  Outcome o;
  int status = 0;
  if (pid < 0 || waitpid(pid, &status, 0) != pid) return o;
  if (WIFEXITED(status)) o.exitCode = WEXITSTATUS(status);
  o.out = slurp(outPath);
  o.err = slurp(errPath);
  return o;
}

Outcome tool(const fs::path& dir, std::vector<std::string> args) {
  args.insert(args.begin(), env("SHREFRACT_TOOL"));
  return run(dir, std::move(args));
}

fs::path workDir(const std::string& name) {
  const fs::path dir = fs::current_path() / "shard_work" / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// Bytes of the file with the timing statistics zeroed: serializeField of the parsed file, after
// checking that it reproduces the file exactly (so comparing these compares the files' bytes).
std::string bytesButTimings(const fs::path& path) {
  const std::string raw = slurp(path);
  auto field = parseField(reinterpret_cast<const uint8_t*>(raw.data()), raw.size(), path.string());
  if (!field) {
    ADD_FAILURE() << field.error().message;
    return {};
  }
  const std::vector<uint8_t> again = serializeField(field.value());
  EXPECT_EQ(std::string(again.begin(), again.end()), raw) << path << " does not serialize back to its bytes";
  BakeStatistics& st = field->statistics;
  st.bakeSeconds = st.traceSeconds = st.fitSeconds = st.raysPerSecond = 0.0;
  st.peakMemoryBytes = 0;
  const std::vector<uint8_t> bytes = serializeField(field.value());
  return std::string(bytes.begin(), bytes.end());
}

void expectSameField(const fs::path& expected, const fs::path& actual) {
  const std::string a = bytesButTimings(expected), b = bytesButTimings(actual);
  ASSERT_FALSE(a.empty());
  ASSERT_EQ(a.size(), b.size()) << actual << " against " << expected;
  size_t first = 0;
  while (first < a.size() && a[first] == b[first]) ++first;
  EXPECT_EQ(first, a.size()) << actual << " differs from " << expected << " first at byte " << first << " of "
                             << a.size();
}

// Small bakes (8x16 directions): the sphere's 642 samples (split layout) in the default encoding
// (Pca, with spatial smoothing: both global steps) and in SH with a window and the throughput
// channel, in u8; the glass of water (absorbing: 4 channels) in the charts layout, Table in f16.
const std::vector<std::vector<std::string>> kBakes = {
    {"builtin:sphere", "--layout", "split", "--samples", "1500", "--directions", "8x16", "--threads", "2", "--components", "24",
     "--table-size", "6", "--spatial", "3"},
    {"builtin:sphere", "--layout", "split", "--samples", "1500", "--directions", "8x16", "--threads", "2", "--order", "3", "--window",
     "hann", "--spatial", "5", "--throughput"},
    {"builtin:glass-of-water", "--layout", "charts", "--samples", "800", "--directions", "8x16", "--threads", "2", "--encoding", "table",
     "--table-size", "4", "--quant", "f16"},
};

std::vector<std::string> with(std::vector<std::string> args, const std::vector<std::string>& more) {
  args.insert(args.begin(), "bake");
  args.insert(args.end(), more.begin(), more.end());
  return args;
}

// Bakes `parts` shards of `bake` into part files p0.shrfpart... in `dir`; returns their names.
std::vector<std::string> bakeParts(const fs::path& dir, const std::vector<std::string>& bake, int parts,
                                   const std::string& prefix = "p") {
  std::vector<std::string> names;
  for (int i = 0; i < parts; ++i) {
    const std::string name = prefix + std::to_string(i) + ".shrfpart";
    const Outcome o = tool(dir, with(bake, {"--shard", std::to_string(i) + "/" + std::to_string(parts), "-o", name}));
    EXPECT_EQ(o.exitCode, 0) << o.err;
    names.push_back(name);
  }
  return names;
}

// The lines of a bake's stderr that say a choice made after the tracing (bake/src/driver/basis.cpp keepSampleFrame
// and keepClusters).
std::vector<std::string> choiceLines(const std::string& err) {
  std::vector<std::string> out;
  std::istringstream in(err);
  for (std::string line; std::getline(in, line);)
    if (line.rfind("exit frame: ", 0) == 0 || line.rfind("pca basis: ", 0) == 0) out.push_back(line);
  return out;
}

TEST(Shard, MergedPartsAreTheSingleProcessBake) {
  ASSERT_FALSE(env("SHREFRACT_TOOL").empty());
  for (size_t b = 0; b < kBakes.size(); ++b) {
    const fs::path dir = workDir("merge" + std::to_string(b));
    const Outcome one = tool(dir, with(kBakes[b], {"-o", "one.shrf"}));
    ASSERT_EQ(one.exitCode, 0) << one.err;
    const int shards = b == 0 ? 3 : 2;
    std::vector<std::string> parts = bakeParts(dir, kBakes[b], shards);
    std::vector<std::string> merge{"merge"};
    merge.insert(merge.end(), parts.rbegin(), parts.rend());  // order does not matter
    merge.insert(merge.end(), {"-o", "merged.shrf"});
    const Outcome m = tool(dir, merge);
    ASSERT_EQ(m.exitCode, 0) << m.err;
    expectSameField(dir / "one.shrf", dir / "merged.shrf");
    // The merge learns the Pca basis and quantizes: its stages say so, as the bake's do.
    if (b == 0) {
      EXPECT_NE(m.err.find("merge: learning the pca basis: 24 components"), std::string::npos) << m.err;
    }
    EXPECT_NE(m.err.find("merge: quantizing"), std::string::npos) << m.err;
    // ... and it says the choices it makes after the tracing, word for word as the bake said them.
    const std::vector<std::string> choices = choiceLines(one.err);
    if (b == 0) {
      EXPECT_FALSE(choices.empty()) << one.err;
    }
    for (const std::string& line : choices) {
      EXPECT_NE(m.err.find(line), std::string::npos) << line << "\n" << m.err;
    }
  }
}

TEST(Shard, MpiBakeIsTheSingleProcessBake) {
  const std::string mpiexec = env("SHREFRACT_MPIEXEC");
  if (mpiexec.empty()) GTEST_SKIP() << "built without MPI";
  // CI runs as root on 2 cores: Open MPI refuses root and more ranks than cores unless told.
  setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
  setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
  for (size_t b = 0; b < 2; ++b) {
    const fs::path dir = workDir("mpi" + std::to_string(b));
    const Outcome one = tool(dir, with(kBakes[b], {"-o", "one.shrf"}));
    ASSERT_EQ(one.exitCode, 0) << one.err;
    std::vector<std::string> args{mpiexec, "--oversubscribe", "-np", "2", env("SHREFRACT_TOOL")};
    const std::vector<std::string> bake = with(kBakes[b], {"-o", "mpi.shrf"});
    args.insert(args.end(), bake.begin(), bake.end());
    const Outcome o = run(dir, args);
    ASSERT_EQ(o.exitCode, 0) << o.err;
    expectSameField(dir / "one.shrf", dir / "mpi.shrf");
  }
}

// A rank whose part does not fit (here: rank 1 bakes with another bounce cap, through mpirun's MPMD form)
// ends the job: a line naming it, a non-zero exit, no output file and no temporary file.
TEST(Shard, MpiRankThatFailsEndsTheJob) {
  const std::string mpiexec = env("SHREFRACT_MPIEXEC");
  if (mpiexec.empty()) GTEST_SKIP() << "built without MPI";
  setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
  setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
  const fs::path dir = workDir("mpi-fail");
  std::vector<std::string> args{mpiexec, "--oversubscribe", "-np", "1", env("SHREFRACT_TOOL")};
  const std::vector<std::string> first = with(kBakes[1], {"-o", "mpi.shrf"});
  args.insert(args.end(), first.begin(), first.end());
  args.insert(args.end(), {":", "-np", "1", env("SHREFRACT_TOOL")});
  const std::vector<std::string> second = with(kBakes[1], {"--max-bounces", "3", "-o", "mpi.shrf"});
  args.insert(args.end(), second.begin(), second.end());
  const Outcome o = run(dir, args);
  EXPECT_NE(o.exitCode, 0);
  EXPECT_NE(o.err.find("rank 0 of 2: rank 1: not a part of the same bake as rank 0 (setting 'max bounces' differs)"),
            std::string::npos) << o.err;
  for (const auto& entry : fs::directory_iterator(dir))
    EXPECT_EQ(entry.path().filename().string().find("mpi.shrf"), std::string::npos) << entry.path();
}

// One stderr line naming `names`, exit 1, and the existing output untouched.
void expectRefused(const fs::path& dir, std::vector<std::string> parts, const std::string& names) {
  const std::string before = "not a field: must survive a failed merge";
  std::ofstream(dir / "out.shrf", std::ios::binary) << before;
  parts.insert(parts.begin(), "merge");
  parts.insert(parts.end(), {"-o", "out.shrf"});
  const Outcome o = tool(dir, parts);
  EXPECT_EQ(o.exitCode, 1) << o.err;
  EXPECT_EQ(std::count(o.err.begin(), o.err.end(), '\n'), 1) << o.err;
  EXPECT_NE(o.err.find(names), std::string::npos) << "expected '" << names << "' in: " << o.err;
  EXPECT_EQ(slurp(dir / "out.shrf"), before);
  for (const auto& entry : fs::directory_iterator(dir))
    EXPECT_EQ(entry.path().filename().string().find(".tmp"), std::string::npos) << entry.path();
}

TEST(Shard, BadPartsAreRefused) {
  const fs::path dir = workDir("bad");
  const std::vector<std::string>& bake = kBakes[0];
  const std::vector<std::string> p = bakeParts(dir, bake, 3);
  {
    SCOPED_TRACE("missing part");
    expectRefused(dir, {p[0], p[2]}, "shard 1/3 is missing");
  }
  {
    SCOPED_TRACE("duplicated part");
    expectRefused(dir, {p[0], p[1], p[1], p[2]}, p[1] + ": shard 1/3 given twice");
  }
  {
    SCOPED_TRACE("other settings");
    std::vector<std::string> other = bake;
    other[other.size() - 1] = "5";  // --spatial 5
    const std::vector<std::string> q = bakeParts(dir, other, 3, "q");
    expectRefused(dir, {p[0], q[1], p[2]}, q[1] + ": not a part of the same bake as " + p[0] + " (setting 'spatial'");
  }
  {
    SCOPED_TRACE("other shard count");
    const std::vector<std::string> r = bakeParts(dir, bake, 2, "r");
    expectRefused(dir, {p[0], r[1], p[2]}, r[1] + ": not a part of the same bake as " + p[0] + " (shard 1/2");
  }
  {
    SCOPED_TRACE("truncated part");
    const std::string bytes = slurp(dir / p[1]);
    std::ofstream(dir / "cut.shrfpart", std::ios::binary) << bytes.substr(0, bytes.size() - 100);
    expectRefused(dir, {p[0], "cut.shrfpart", p[2]}, "cut.shrfpart: not a valid bake part: truncated");
  }
  {
    SCOPED_TRACE("flipped byte");
    std::string bytes = slurp(dir / p[1]);
    bytes[bytes.size() / 2] ^= 0x10;
    std::ofstream(dir / "flip.shrfpart", std::ios::binary) << bytes;
    expectRefused(dir, {p[0], "flip.shrfpart", p[2]}, "flip.shrfpart: not a valid bake part: checksum");
  }
  {
    SCOPED_TRACE("not a part");
    expectRefused(dir, {p[0], "out.shrf", p[2]}, "out.shrf: not a valid bake part");
  }
  {
    SCOPED_TRACE("missing file");
    expectRefused(dir, {p[0], "nowhere.shrfpart", p[2]}, "nowhere.shrfpart: cannot open");
  }
}

// A part round-trips through its bytes; one with a NaN is never written (nor would it be read).
TEST(Shard, PartBytesRoundTripAndNonFiniteValuesAreRefused) {
  bake::BakePart p;
  p.settings.source = "builtin:sphere";
  p.heldOutDirections = 1;
  p.shard = {1, 2};
  p.sampleCount = 3;  // shard 1/2 holds sample 1 only (not on the grid-check lattice)
  p.channels = 3;
  p.directions = 2;
  p.stride = 4;
  p.coefficients = {0.5f, -1.0f, 2.0f, 0.0f};
  p.heldOut = {0.0f, 0.0f, 1.0f, 0.0f, 1.0f, 0.0f};
  p.settings.tryVolume = p.settings.volumeDensify = true;  // what the merge does with the volume
  p.settings.moreClusters = true;                          // and with the clusters
  const std::vector<uint8_t> bytes = bake::serializePart(p);
  auto back = bake::parsePart(bytes.data(), bytes.size(), "memory");
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(bake::serializePart(back.value()), bytes);
  EXPECT_TRUE(back.value().settings.tryVolume);
  EXPECT_TRUE(back.value().settings.volumeDensify);
  EXPECT_TRUE(back.value().settings.moreClusters);

  const fs::path dir = workDir("nan");
  p.coefficients[2] = std::numeric_limits<float>::quiet_NaN();
  auto written = bake::writePart((dir / "nan.shrfpart").string(), p);
  ASSERT_FALSE(written.ok());
  EXPECT_NE(written.error().message.find("nan.shrfpart: not a valid bake part: a value is not finite"), std::string::npos)
      << written.error().message;
  EXPECT_TRUE(fs::is_empty(dir));
  const std::vector<uint8_t> nanBytes = bake::serializePart(p);
  EXPECT_FALSE(bake::parsePart(nanBytes.data(), nanBytes.size(), "memory").ok());
}

TEST(Shard, UsageErrors) {
  const fs::path dir = workDir("usage");
  for (const auto& args : std::vector<std::vector<std::string>>{
           {"bake", "builtin:sphere", "--shard", "2/2", "-o", "a.shrfpart"},
           {"bake", "builtin:sphere", "--shard", "1", "-o", "a.shrfpart"},
           {"bake", "builtin:sphere", "--shard", "0/2", "-o", "a.shrf"},
           {"merge", "-o", "a.shrf"},
           {"merge", "a.shrfpart"},
           {"merge", "a.shrfpart", "-o", "a.png"}}) {
    const Outcome o = tool(dir, args);
    EXPECT_EQ(o.exitCode, 2) << args[0] << " " << args[args.size() - 1] << ": " << o.err;
    EXPECT_EQ(std::count(o.err.begin(), o.err.end(), '\n'), 1) << o.err;
  }
  EXPECT_TRUE(fs::is_empty(dir) || !fs::exists(dir / "a.shrfpart"));
}

}  // namespace
}  // namespace shrefract

// The tool on scenes as users hand them over, through the real binary ($SHREFRACT_TOOL,
// set by ctest): a Blender-style glTF written here bakes with a warning per repair and renders in
// every mode; a field finds its scene from any working directory (and through --dev scene once the
// scene moved); camera errors exit 2 with one line before any work and never touch an existing
// output; every range --help and --help-dev print is the range the parser enforces (and the bake
// library's); bake's and render's --help stay short (at most 20 flags, one short line each).
// GPU modes run on lavapipe like the GPU tests and are skipped, with a line, without a device.
#include <gtest/gtest.h>
#include <shrefract/bake/bake.h>
#include <shrefract/assets/image.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "import/gltf_writer.h"
#include "viewer/run_command.h"

namespace shrefract {
namespace {

namespace fs = std::filesystem;
using testing::shellQuote;

struct ToolRun {
  int exit = -1;
  std::string out, err;
};

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

size_t lineCount(const std::string& text) { return static_cast<size_t>(std::count(text.begin(), text.end(), '\n')); }

// The tool's exit status for "no Vulkan device" (samples/cli/commands.h); a build that requires a
// device (CI) never skips.
bool noDevice(const ToolRun& r) { return r.exit == 3 && !SHREFRACT_REQUIRE_GPU; }

class SceneCli : public ::testing::Test {
 protected:
  void SetUp() override {
    const char* tool = std::getenv("SHREFRACT_TOOL");
    ASSERT_NE(tool, nullptr) << "SHREFRACT_TOOL is not set (ctest sets it to the shrefract binary)";
    tool_ = tool;
    dir_ = fs::current_path() / "scene_cli_work" / ::testing::UnitTest::GetInstance()->current_test_info()->name();
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(dir_);
  }

  // Runs the tool in `where` (relative to the test's directory) with stdout and stderr apart.
  ToolRun run(const std::string& where, const std::vector<std::string>& args) const {
    const fs::path errPath = dir_ / ".stderr";
    std::string command = "{ cd " + shellQuote((dir_ / where).string()) + " && " + shellQuote(tool_);
    for (const auto& a : args) {
      command.push_back(' ');
      command.append(shellQuote(a));
    }
    command.append(" 2>");
    command.append(shellQuote(errPath.string()));
    command.append("; }");
    const testing::CommandResult result = testing::runCommand(command);
    ToolRun r{result.exitCode, result.output, slurp(errPath)};
    fs::remove(errPath);
    return r;
  }

  void writeBoxes(const fs::path& relative) const {
    fs::create_directories((dir_ / relative).parent_path());
    gltf_test::blenderStyleBoxes().writeGltf(dir_ / relative);
  }

  std::string tool_;
  fs::path dir_;
};

// A rendered image: finite everywhere, and not flat (the object is in view).
void expectFiniteAndNotFlat(const fs::path& image) {
  auto read = bake::loadImage(image.string());
  ASSERT_TRUE(read.ok()) << read.error().message;
  const auto& px = read.value().rgba;
  ASSERT_FALSE(px.empty());
  float lo = px[0], hi = px[0];
  for (float v : px) {
    ASSERT_TRUE(std::isfinite(v)) << image;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  EXPECT_GT(hi - lo, 0.05f) << image << " is flat";
}

TEST_F(SceneCli, BlenderStyleGltfBakesWithRepairWarningsAndRendersInEveryMode) {
  writeBoxes("boxes.gltf");
  const gltf_test::BlenderBoxesCounts counts;
  const ToolRun bake = run(".", {"bake", "boxes.gltf", "-o", "boxes.shrf", "--samples", "800", "--dev",
                             "directions=8x16", "--order", "2", "--threads", "2", "--dev", "held-out=0"});
  ASSERT_EQ(bake.exit, 0) << bake.err;
  const std::string a = "warning: boxes.gltf: mesh 0 ('boxA') in node 0 ('A'): ";
  const std::string b = "warning: boxes.gltf: mesh 1 ('boxB') in node 1 ('B'): ";
  for (const std::string& expected :
       {a + "welded " + std::to_string(counts.welded) + " vertex(es)",
        a + "dropped " + std::to_string(counts.duplicated) + " duplicated triangle(s)",
        a + "dropped " + std::to_string(counts.degenerateA) + " degenerate triangle(s)",
        b + "dropped " + std::to_string(counts.degenerateB) + " degenerate triangle(s)",
        std::string("warning: boxes.gltf: mesh 0 ('boxA') in node 0 ('A') and mesh 1 ('boxB') in node 1 ('B') overlap")})
    EXPECT_NE(bake.err.find(expected), std::string::npos) << "missing '" << expected << "' in:\n" << bake.err;

  // CPU modes of the scene and of the field (its scene rebuilt from the record).
  for (const auto& [input, mode] : std::vector<std::pair<std::string, std::string>>{
           {"boxes.gltf", "exact"}, {"boxes.gltf", "full-tree"}, {"boxes.shrf", "exact"}, {"boxes.shrf", "full-tree"}}) {
    const std::string out = fs::path(input).stem().string() + "_" + mode + ".exr";
    const ToolRun r = run(".", {"render", input, "--mode", mode, "--dev", "tree-depth=3", "--size", "48x36", "-o", out});
    ASSERT_EQ(r.exit, 0) << input << " " << mode << ": " << r.err;
    EXPECT_NE(r.err.find("render " + mode + ": 100%"), std::string::npos) << "no progress: " << r.err;
    expectFiniteAndNotFlat(dir_ / out);
  }
  // A field-only mode on a scene: one usage line.
  const ToolRun sh = run(".", {"render", "boxes.gltf", "--mode", "sh", "-o", "no.png"});
  EXPECT_EQ(sh.exit, 2);
  EXPECT_EQ(lineCount(sh.err), 1u) << sh.err;
  EXPECT_NE(sh.err.find("needs a refraction field"), std::string::npos) << sh.err;
  EXPECT_FALSE(fs::exists(dir_ / "no.png"));

  // GPU modes: the scene in single-interface, the field in sh.
  for (const auto& [input, mode] : std::vector<std::pair<std::string, std::string>>{
           {"boxes.gltf", "single-interface"}, {"boxes.shrf", "sh"}, {"boxes.shrf", "single-interface"}}) {
    const std::string out = fs::path(input).stem().string() + "_" + mode + ".exr";
    const ToolRun r = run(".", {"render", input, "--mode", mode, "--size", "48x36", "-o", out});
    if (r.exit != 0 && noDevice(r)) GTEST_SKIP() << "no Vulkan device: " << r.err;
    ASSERT_EQ(r.exit, 0) << input << " " << mode << ": " << r.err;
    expectFiniteAndNotFlat(dir_ / out);
  }
}

TEST_F(SceneCli, ExactModeOfAFieldWorksFromAnotherDirectoryAndWithScene) {
  writeBoxes("a/models/boxes.gltf");
  fs::create_directories(dir_ / "a/fields");
  fs::create_directories(dir_ / "b");
  const ToolRun bake = run("a", {"bake", "models/boxes.gltf", "-o", "fields/f.shrf", "--samples", "800", "--dev",
                             "directions=8x16", "--order", "2", "--threads", "2", "--dev", "held-out=0"});
  ASSERT_EQ(bake.exit, 0) << bake.err;
  const std::vector<std::string> exact = {"render", "../a/fields/f.shrf", "--mode", "exact", "--size", "32x24"};
  auto with = [&exact](std::vector<std::string> extra) {
    std::vector<std::string> args = exact;
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  };
  const ToolRun fromB = run("b", with({"-o", "x.png"}));
  EXPECT_EQ(fromB.exit, 0) << fromB.err;
  EXPECT_TRUE(fs::exists(dir_ / "b/x.png"));

  fs::rename(dir_ / "a/models/boxes.gltf", dir_ / "moved.gltf");
  const ToolRun lost = run("b", with({"-o", "y.png"}));
  EXPECT_EQ(lost.exit, 1);
  EXPECT_EQ(lineCount(lost.err), 1u) << lost.err;
  EXPECT_NE(lost.err.find("--dev scene=PATH"), std::string::npos) << lost.err;
  EXPECT_NE(lost.err.find("f.shrf"), std::string::npos) << lost.err;
  EXPECT_FALSE(fs::exists(dir_ / "b/y.png"));
  const ToolRun found = run("b", with({"--dev", "scene=../moved.gltf", "-o", "z.png"}));
  EXPECT_EQ(found.exit, 0) << found.err;
  EXPECT_TRUE(fs::exists(dir_ / "b/z.png"));
}

// The default bake (Pca, charts layout) traces the table's nodes; asking for a grid size asks for
// grid sampling; the field file and `info` say which (docs/encodings.md, "Sampling";
// docs/technique.md, "Choosing a layout").
TEST_F(SceneCli, DefaultBakeTracesTheTableNodesAndAGridSizeAsksForTheGrid) {
  const std::vector<std::string> base{"bake", "builtin:sphere?tessellation=1", "--samples", "100", "--components", "8"};
  std::string bakeErr;
  auto bakeAndInfo = [&](std::vector<std::string> args, const std::string& out) {
    args.insert(args.end(), {"-o", out});
    const ToolRun bake = run(".", args);
    EXPECT_EQ(bake.exit, 0) << bake.err;
    bakeErr = bake.err;
    return run(".", {"info", out, "--json"});
  };
  const ToolRun nodes = bakeAndInfo(base, "nodes.shrf");
  ASSERT_EQ(nodes.exit, 0) << nodes.err;
  // The stages after the tracing, which take minutes on the default 64x64 tables, each say so as
  // they begin, in order (a line each, with the seconds since the start).
  size_t at = 0;
  for (const char* stage : {"bake: choosing the exit frame: bases of 8 components", "bake: learning the pca basis: 8 "
                            "components from", "bake: checking the fit", "bake: quantizing"}) {
    const size_t found = bakeErr.find(stage, at);
    EXPECT_NE(found, std::string::npos) << stage << " after offset " << at << " in:\n" << bakeErr;
    if (found != std::string::npos) at = found;
  }
  EXPECT_NE(nodes.out.find("\"direction_sampling\": \"nodes\""), std::string::npos) << nodes.out;
  EXPECT_NE(nodes.out.find("\"layout\": \"charts\""), std::string::npos) << nodes.out;
  std::vector<std::string> gridArgs = base;
  gridArgs.insert(gridArgs.end(), {"--dev", "directions=8x16"});
  const ToolRun grid = bakeAndInfo(gridArgs, "grid.shrf");
  ASSERT_EQ(grid.exit, 0) << grid.err;
  EXPECT_NE(grid.out.find("\"direction_sampling\": \"grid\""), std::string::npos) << grid.out;
  const ToolRun text = run(".", {"info", "nodes.shrf"});
  const std::string n = std::to_string(bake::kDefaultPcaTableSize);
  EXPECT_NE(text.out.find("directions the " + n + "x" + n + " table nodes"), std::string::npos) << text.out;
  // The node-sampled field stores the jump distance (docs/encodings.md, "Placing the jump"); the
  // grid-fitted one cannot, and --dev no-jump-distance leaves it out.
  EXPECT_NE(nodes.out.find("\"jump_distance\": true"), std::string::npos) << nodes.out;
  EXPECT_NE(text.out.find("(with jump distance)"), std::string::npos) << text.out;
  EXPECT_NE(grid.out.find("\"jump_distance\": false"), std::string::npos) << grid.out;
  std::vector<std::string> without = base;
  without.insert(without.end(), {"--dev", "no-jump-distance"});
  const ToolRun plain = bakeAndInfo(without, "plain.shrf");
  ASSERT_EQ(plain.exit, 0) << plain.err;
  EXPECT_NE(plain.out.find("\"jump_distance\": false"), std::string::npos) << plain.out;
  EXPECT_NE(nodes.out.find("\"channels\": 5"), std::string::npos) << nodes.out;  // x, y, z, tau, distance
  EXPECT_NE(plain.out.find("\"channels\": 4"), std::string::npos) << plain.out;
  // The default bake chooses the frame of the exits (docs/encodings.md, "Exits in the sample's
  // frame"; on this sphere, the sample's); --dev exit-frame=object stores them in object space; any
  // other value is a usage error that leaves an existing output alone.
  EXPECT_NE(nodes.out.find("\"exit_frame\": \"sample\""), std::string::npos) << nodes.out;
  EXPECT_NE(text.out.find("exits stored in each sample's frame"), std::string::npos) << text.out;
  std::vector<std::string> objectArgs = base;
  objectArgs.insert(objectArgs.end(), {"--dev", "exit-frame=object"});
  const ToolRun object = bakeAndInfo(objectArgs, "object.shrf");
  ASSERT_EQ(object.exit, 0) << object.err;
  EXPECT_NE(object.out.find("\"exit_frame\": \"object\""), std::string::npos) << object.out;
  const auto before = fs::file_size(dir_ / "object.shrf");
  std::vector<std::string> badArgs = base;
  badArgs.insert(badArgs.end(), {"--dev", "exit-frame=world", "-o", "object.shrf"});
  const ToolRun bad = run(".", badArgs);
  EXPECT_EQ(bad.exit, 2);
  EXPECT_NE(bad.err.find("--dev exit-frame must be auto, sample or object, got 'world'"), std::string::npos) << bad.err;
  EXPECT_EQ(fs::file_size(dir_ / "object.shrf"), before);
}

// --choose-by-images (no --encoding nor a flag of Pca's) makes the Pca field and, where the scene
// is one medium in air, the volume beside it at 128^3 (and 256^3 where that grid fits 324 bytes a
// sample: not these), and keeps the one whose images come closer to exact renders (the Pca by its
// texels, the volume traced per fragment): one line says which, with every figure, and the file is
// that field, recording that it tried. The default bake decides from the scene without images (one
// closed medium in air: the volume; docs/encodings.md, "The default encoding"); --encoding pca
// keeps the Pca without trying; nested media (the glass of water) have no volume to try.
TEST_F(SceneCli, ChooseByImagesTriesTheVolumeAndKeepsTheCloser) {
  const ToolRun tried = run(".", {"bake", "builtin:sphere?tessellation=1", "--samples", "100", "--choose-by-images",
                                  "-o", "tried.shrf"});
  ASSERT_EQ(tried.exit, 0) << tried.err;
  const size_t note = tried.err.find("encoding: chose ");
  ASSERT_NE(note, std::string::npos) << tried.err;
  const std::string chosen = tried.err.substr(note + 16, tried.err.find(' ', note + 16) - note - 16);
  EXPECT_TRUE(chosen == "pca" || chosen == "volume") << tried.err;
  // The figures of the three images against the exact renders; the kept field has the highest.
  auto figureBefore = [&](const std::string& tail) {
    const size_t at = tried.err.find(tail, note);
    if (at == std::string::npos) return std::nan("");
    const size_t start = tried.err.rfind(' ', at - 2) + 1;
    return std::stod(tried.err.substr(start, at - 1 - start));
  };
  // The sphere's 256^3 grid in bricks (about 14 MiB) is over 324 bytes a sample of this small
  // budget: built, then left out, the coarser grid alone drawn.
  const double pcaDb = figureBefore("dB with pca by its texels, "),
               volumeDb = figureBefore("dB with volume 128^3 traced per fragment");
  ASSERT_TRUE(std::isfinite(pcaDb) && std::isfinite(volumeDb)) << tried.err;
  EXPECT_EQ(tried.err.find("dB with volume 256^3"), std::string::npos) << tried.err;
  EXPECT_NE(tried.err.find("(256^3 left out: its "), std::string::npos) << tried.err;
  EXPECT_NE(tried.err.find(" bytes are over 324 bytes a sample of "), std::string::npos) << tried.err;
  EXPECT_EQ(chosen, volumeDb > pcaDb ? "volume" : "pca") << tried.err;
  if (chosen == "volume") {
    EXPECT_NE(tried.err.find("chose volume 128^3"), std::string::npos) << tried.err;
  }
  EXPECT_NE(tried.err.find("their images against exact renders, 4 views"), std::string::npos) << tried.err;
  const ToolRun info = run(".", {"info", "tried.shrf", "--json"});
  ASSERT_EQ(info.exit, 0) << info.err;
  EXPECT_NE(info.out.find("\"encoding\": \"" + chosen + "\""), std::string::npos) << info.out;
  const Result<Field> field = readField((dir_ / "tried.shrf").string());
  ASSERT_TRUE(field.ok()) << field.error().message;
  EXPECT_TRUE(field.value().settings.tryVolume);
  if (chosen == "volume") {
    EXPECT_EQ(field.value().volume.size, 128u);
  }
  const ToolRun decided = run(".", {"bake", "builtin:sphere?tessellation=1", "--samples", "100", "-o", "decided.shrf"});
  ASSERT_EQ(decided.exit, 0) << decided.err;
  EXPECT_EQ(decided.err.find("encoding: chose"), std::string::npos) << decided.err;
  EXPECT_NE(decided.err.find("encoding: volume 128^3, one closed medium in air"), std::string::npos) << decided.err;
  const ToolRun pca = run(".", {"bake", "builtin:sphere?tessellation=1", "--samples", "100", "--encoding", "pca",
                                "-o", "pca.shrf"});
  ASSERT_EQ(pca.exit, 0) << pca.err;
  EXPECT_EQ(pca.err.find("encoding: chose"), std::string::npos) << pca.err;
  const ToolRun water = run(".", {"bake", "builtin:glass-of-water?tessellation=1", "--samples", "100", "-o", "w.shrf"});
  ASSERT_EQ(water.exit, 0) << water.err;
  EXPECT_EQ(water.err.find("encoding: chose"), std::string::npos) << water.err;
}

// A u8 Pca bake gives its widest components refinement layers (table_fit.h) and says how many;
// an f16 bake has none. The split layout's 42 samples at this budget leave the trailing components
// of K = 64 empty (the rank is at most the sample count), so the bake refines: 22 layers measured.
TEST_F(SceneCli, InfoCountsTheRefinementLayersOfAU8PcaField) {
  const std::vector<std::string> bake{"bake", "builtin:sphere?tessellation=1", "--layout", "split",
                                       "--samples", "100", "--components", "64"};
  auto bakeAndInfo = [&](std::vector<std::string> args, const std::string& out) {
    args.insert(args.end(), {"-o", out});
    const ToolRun baked = run(".", args);
    EXPECT_EQ(baked.exit, 0) << baked.err;
    return run(".", {"info", out, "--json"});
  };
  const ToolRun u8 = bakeAndInfo(bake, "u8.shrf");
  ASSERT_EQ(u8.exit, 0) << u8.err;
  const size_t at = u8.out.find("\"refinement_layers\": ");
  ASSERT_NE(at, std::string::npos) << u8.out;
  EXPECT_GT(std::stoul(u8.out.substr(at + 21)), 0u) << u8.out;
  EXPECT_NE(run(".", {"info", "u8.shrf"}).out.find("of them u8 refinement layers"), std::string::npos);
  std::vector<std::string> f16 = bake;
  f16.insert(f16.end(), {"--quant", "f16"});
  const ToolRun half = bakeAndInfo(f16, "f16.shrf");
  ASSERT_EQ(half.exit, 0) << half.err;
  EXPECT_NE(half.out.find("\"refinement_layers\": 0,"), std::string::npos) << half.out;
}

TEST_F(SceneCli, CameraErrorsExit2WithOneLineAndKeepAnExistingOutput) {
  std::ofstream(dir_ / "out.png") << "an earlier image";
  const std::vector<std::string> base = {"render", "builtin:sphere", "--tessellation", "1", "--size", "16x12",
                                         "--mode", "exact", "-o", "out.png"};
  struct Bad {
    std::vector<std::string> flags;
    std::vector<std::string> named;
    int exit;
  };
  const std::vector<Bad> cases = {
      {{"--eye", "0,0,3", "--target", "0,0,3"}, {"--eye 0,0,3", "same point", "--target 0,0,3"}, 2},
      {{"--eye", "0,3,0"}, {"--eye 0,3,0", "up 0,1,0 is parallel"}, 2},
      {{"--eye", "0,0,3", "--up", "0,0,-2"}, {"--up 0,0,-2 is parallel"}, 2},
      {{"--up", "0,0,0"}, {"--up 0,0,0"}, 2},
      {{"--eye", "1e39,0,0"}, {"--eye"}, 2},
      {{"--exposure", "-1"}, {"--exposure"}, 2},
      {{"--exposure", "0"}, {"--exposure"}, 2},
      {{"--env", "missing.hdr"}, {"missing.hdr"}, 1},
  };
  for (const Bad& c : cases) {
    std::vector<std::string> args = base;
    args.insert(args.end(), c.flags.begin(), c.flags.end());
    const ToolRun r = run(".", args);
    EXPECT_EQ(r.exit, c.exit) << c.flags.front() << ": " << r.err;
    EXPECT_EQ(lineCount(r.err), 1u) << r.err;
    for (const std::string& name : c.named) EXPECT_NE(r.err.find(name), std::string::npos) << r.err;
    EXPECT_EQ(slurp(dir_ / "out.png"), "an earlier image") << "clobbered by " << c.flags.front();
  }
}

// A report that fails after it has written images leaves no partial directory, and an earlier
// report in DIR stays as it was.
TEST_F(SceneCli, AFailedReportLeavesNoPartialDirectory) {
  fs::create_directories(dir_ / "rep");
  std::ofstream(dir_ / "rep/report.md") << "an earlier report";
  const ToolRun r = run(".", {"report", "builtin:sphere", "--tessellation", "1", "--smoke", "--threads", "2",
                              "--samples", "10", "-o", "rep"});
  if (r.exit != 0 && noDevice(r)) GTEST_SKIP() << "no Vulkan device: " << r.err;
  EXPECT_EQ(r.exit, 1) << r.err;
  EXPECT_NE(r.err.find("raise --samples"), std::string::npos) << r.err;
  std::vector<std::string> entries;
  for (const auto& e : fs::directory_iterator(dir_)) entries.push_back(e.path().filename().string());
  EXPECT_EQ(entries, std::vector<std::string>{"rep"});
  std::vector<std::string> inside;
  for (const auto& e : fs::directory_iterator(dir_ / "rep")) inside.push_back(e.path().filename().string());
  EXPECT_EQ(inside, std::vector<std::string>{"report.md"});
  EXPECT_EQ(slurp(dir_ / "rep/report.md"), "an earlier report");
}

// One probe of a range: a value and whether the parser must accept it.
struct Probe {
  std::string value;
  bool accepted;
};

// Integers in full ("100000000"; an integer flag refuses "1e+08").
std::string text(double v) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.17g", v);
  return buffer;
}

// Values just outside and on (or inside) a range as --help prints it (args.cpp, Bounds::text).
std::vector<Probe> probesOf(const std::string& range) {
  std::smatch m;
  const std::string num = "(-?[0-9.e+]+)";
  if (std::regex_match(range, m, std::regex(num + "\\.\\." + num))) {
    const double lo = std::stod(m[1]), hi = std::stod(m[2]);
    return {{text(lo - 1), false}, {text(lo), true}, {text(hi), true}, {text(hi + 1), false}};
  }
  if (std::regex_match(range, m, std::regex(">= " + num)))
    return {{text(std::stod(m[1]) - 1), false}, {text(std::stod(m[1])), true}};
  if (std::regex_match(range, m, std::regex("> " + num)))
    return {{text(std::stod(m[1])), false}, {text(std::stod(m[1]) + 1), true}};
  if (std::regex_match(range, m, std::regex("([\\[(])" + num + ", " + num + "([\\])])"))) {
    const double lo = std::stod(m[2]), hi = std::stod(m[3]);
    return {{text(lo), m[1] == "["}, {text(hi), m[4] == "]"}, {text((lo + hi) / 2), true},
            {text(lo - 1), false}, {text(hi + 1), false}};
  }
  return {};
}

// "A..B x C..D" (sizes): each side's probes with the other side at its lowest accepted value.
std::vector<Probe> sizeProbesOf(const std::string& range) {
  const size_t x = range.find(" x ");
  const auto first = probesOf(range.substr(0, x)), second = probesOf(range.substr(x + 3));
  if (first.size() < 2 || second.size() < 2) return {};
  auto pair = [](const std::string& w, const std::string& h) {
    std::string v = w;
    v.push_back('x');
    v.append(h);
    return v;
  };
  std::vector<Probe> out;
  for (const Probe& p : first) out.push_back({pair(p.value, second[1].value), p.accepted});
  for (const Probe& p : second) out.push_back({pair(first[1].value, p.value), p.accepted});
  return out;
}

TEST_F(SceneCli, EveryRangeInHelpIsTheParsersRange) {
  // A user flag as --help prints it, and a developer option as --help-dev prints it; each is
  // probed the way it is given (--name=VALUE, --dev name=VALUE) and named so in the errors.
  const std::regex userLine("^  --([a-z0-9-]+) VALUE .*\\[range: (.*)\\]$");
  const std::regex devLine("^  --dev ([a-z0-9-]+)=VALUE .*\\[range: (.*)\\]$");
  std::map<std::string, std::string> bakeRanges;
  struct Listing {
    std::string command, helpFlag;
  };
  const std::vector<Listing> listings = {{"bake", "--help"},   {"bake", "--help-dev"}, {"render", "--help"},
                                         {"render", "--help-dev"}, {"view", "--help"},   {"report", "--help"}};
  for (const Listing& listing : listings) {
    const std::string& command = listing.command;
    const bool dev = listing.helpFlag == "--help-dev";
    const ToolRun help = run(".", {command, listing.helpFlag});
    ASSERT_EQ(help.exit, 0) << command << " " << listing.helpFlag;
    std::istringstream lines(help.out);
    size_t ranges = 0;
    for (std::string l; std::getline(lines, l);) {
      std::smatch m;
      if (!std::regex_match(l, m, dev ? devLine : userLine)) continue;
      const std::string flag = (dev ? "--dev " : "--") + m[1].str(), range = m[2];
      if (command == "bake") bakeRanges[flag] = range;
      const bool size = range.find(" x ") != std::string::npos;
      const std::vector<Probe> probes = size ? sizeProbesOf(range) : probesOf(range);
      ASSERT_GE(probes.size(), 2u) << command << " " << flag << ": cannot read the range '" << range << "'";
      ++ranges;
      for (const Probe& p : probes) {
        // No input and no output: a value the parser accepts gets the missing-argument error,
        // which names no flag; a rejected value gets the range error naming the flag and range.
        const ToolRun r = dev ? run(".", {command, "--dev", m[1].str() + "=" + p.value})
                              : run(".", {command, flag + "=" + p.value});
        EXPECT_EQ(r.exit, 2) << command << " " << flag << "=" << p.value << ": " << r.err;
        EXPECT_EQ(lineCount(r.err), 1u) << r.err;
        const bool rangeError = r.err.find(flag) != std::string::npos;
        EXPECT_EQ(rangeError, !p.accepted) << command << " " << flag << "=" << p.value << ": " << r.err;
        if (!p.accepted) {
          EXPECT_NE(r.err.find(range), std::string::npos) << r.err;
        }
      }
    }
    EXPECT_GE(ranges, 4u) << command << " " << listing.helpFlag << " prints too few ranges:\n" << help.out;
  }
  // The bake library's own limits are the ones printed.
  EXPECT_EQ(bakeRanges["--dev directions"], std::to_string(bake::kMinDirectionRows) + ".." +
                                                std::to_string(bake::kMaxDirectionRows) + " x " +
                                                std::to_string(bake::kMinDirectionColumns) + ".." +
                                                std::to_string(bake::kMaxDirectionColumns));
  EXPECT_EQ(bakeRanges["--dev max-bounces"], "1.." + std::to_string(bake::kMaxBakeBounces));
  EXPECT_EQ(bakeRanges["--table-size"], "2.." + std::to_string(bake::kMaxBakeTableSize));
}

// The product's limit on the user surface: `bake --help` and `render --help` list at most
// kMaxListedFlags flags (a line starting "  --" each), each flag's help one short sentence that
// cites no documentation page; the experiment switches are developer options, which --help-dev
// lists, and each of those is given as --dev KEY[=VALUE] and refused under its own name as a
// user flag nowhere in --help.
TEST_F(SceneCli, BakeAndRenderHelpListAtMostTwentyFlags) {
  constexpr size_t kMaxListedFlags = 20;
  for (const std::string command : {"bake", "render"}) {
    const ToolRun help = run(".", {command, "--help"});
    ASSERT_EQ(help.exit, 0) << command << ": " << help.err;
    std::istringstream lines(help.out);
    std::vector<std::string> flags;
    for (std::string l; std::getline(lines, l);) {
      if (l.rfind("  --", 0) != 0) continue;
      flags.push_back(l);
      // One short sentence: the help text (the range printed after it aside) in one clause of
      // at most 90 characters, no page cited.
      std::smatch m;
      ASSERT_TRUE(std::regex_match(l, m, std::regex("^  --[a-z0-9-]+( VALUE)? +(.*)$"))) << command << ": " << l;
      std::string text = m[2];
      if (const size_t range = text.find(" [range: "); range != std::string::npos) text.resize(range);
      EXPECT_LE(text.size(), 90u) << command << ": " << l;
      EXPECT_EQ(text.find(". "), std::string::npos) << command << ": more than one sentence: " << l;
      EXPECT_EQ(l.find(".md"), std::string::npos) << command << ": cites a page: " << l;
      EXPECT_EQ(l.find("docs/"), std::string::npos) << command << ": cites a page: " << l;
    }
    EXPECT_LE(flags.size(), kMaxListedFlags) << command << " --help lists " << flags.size() << " flags:\n" << help.out;
    EXPECT_GE(flags.size(), 10u) << command << " --help: the flags were not found:\n" << help.out;
    EXPECT_NE(help.out.find(command + " --help-dev"), std::string::npos) << help.out;

    const ToolRun dev = run(".", {command, "--help-dev"});
    ASSERT_EQ(dev.exit, 0) << command << ": " << dev.err;
    std::istringstream devLines(dev.out);
    size_t options = 0;
    for (std::string l; std::getline(devLines, l);) {
      if (l.rfind("  --dev ", 0) != 0) continue;
      ++options;
      const std::string key = l.substr(8, l.find_first_of("= ", 8) - 8);
      EXPECT_EQ(help.out.find("  --" + key + " "), std::string::npos) << command << " --help lists --" << key;
      EXPECT_EQ(l.find("docs/"), std::string::npos) << command << ": cites a page: " << l;
      // Given by its key, it is a developer option: "--dev KEY" is how the errors name it (here
      // without the value it takes, or with a value where it takes none).
      const bool takesValue = l.find(key + "=VALUE") != std::string::npos;
      const ToolRun given = run(".", {command, "--dev", takesValue ? key : key + "=1"});
      EXPECT_EQ(given.exit, 2) << given.err;
      EXPECT_NE(given.err.find("--dev " + key), std::string::npos) << given.err;
    }
    EXPECT_GE(options, 10u) << command << " --help-dev:\n" << dev.out;
  }
}

}  // namespace
}  // namespace shrefract

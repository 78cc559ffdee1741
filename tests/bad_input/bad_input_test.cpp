// Bad input through the real `shrefract` binary (its path in $SHREFRACT_TOOL, set by ctest):
// missing files, wrong formats, malformed glTF, environment maps with NaN, Inf or negative pixels,
// corrupt, truncated and version-mismatched field files, unknown or malformed flags, unwritable
// outputs. For every case the tool must exit with a non-zero status (not a signal), print exactly
// one line on stderr that names the file or flag at fault, print nothing that looks like progress,
// and leave no output file and no temporary file behind.
//
// Every case runs in a fresh directory under the test's working directory, with relative paths,
// so the messages read as a user would see them. With SHREFRACT_BAD_INPUT_TABLE set to a path, the
// observed messages are written there as the Markdown table of docs/bad-input.md.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <shrefract/assets/image.h>
#include <shrefract/field.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include "engine/synthetic_field.h"

namespace shrefract {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string tool() {
  const char* p = std::getenv("SHREFRACT_TOOL");
  return p ? p : "";
}

struct Outcome {
  int exitCode = -1;  // -1: killed by a signal
  int signal = 0;
  std::string out, err;
};

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Starts the tool with `args` in `dir`, stdin from /dev/null, stdout and stderr to files there.
pid_t startTool(const fs::path& dir, const std::vector<std::string>& args) {
  const fs::path outPath = dir / ".stdout", errPath = dir / ".stderr";
  const std::string exe = tool();
  std::vector<std::string> argStrings{exe};
  argStrings.insert(argStrings.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : argStrings) argv.push_back(a.data());
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
    execv(exe.c_str(), argv.data());
    _exit(127);
  }
  return pid;
}

// Waits for the tool started by startTool in `dir` and collects its outcome (removing the files
// its output went to).
Outcome finishTool(const fs::path& dir, pid_t pid) {
  Outcome o;
  int status = 0;
  if (pid < 0 || waitpid(pid, &status, 0) != pid) return o;
  if (WIFEXITED(status)) o.exitCode = WEXITSTATUS(status);
  if (WIFSIGNALED(status)) o.signal = WTERMSIG(status);
  o.out = slurp(dir / ".stdout");
  o.err = slurp(dir / ".stderr");
  fs::remove(dir / ".stdout");
  fs::remove(dir / ".stderr");
  return o;
}

// Runs the tool with `args` in `dir`, stdin from /dev/null, stdout and stderr captured.
Outcome runTool(const fs::path& dir, const std::vector<std::string>& args) {
  return finishTool(dir, startTool(dir, args));
}

// --- inputs -------------------------------------------------------------------------------------

void writeBytes(const fs::path& p, const std::string& bytes) {
  std::ofstream out(p, std::ios::binary);
  out << bytes;
}

std::string bytesOf(const std::vector<uint8_t>& v) { return std::string(v.begin(), v.end()); }

// A small valid field file (the synthetic band of the engine tests).
std::vector<uint8_t> validFieldBytes() {
  testing::SyntheticFieldOptions o;
  o.width = 8;
  o.height = 4;
  o.order = 1;
  o.meshSegments = 4;
  return serializeField(testing::makeSyntheticField(o));
}

void putU32(std::vector<uint8_t>& b, size_t at, uint32_t v) {
  for (int k = 0; k < 4; ++k) b[at + size_t(k)] = uint8_t(v >> (8 * k));
}

uint32_t crc32(const uint8_t* data, size_t size) {
  uint32_t crc = 0xFFFFFFFFu;
  for (size_t i = 0; i < size; ++i) {
    crc ^= data[i];
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

// A field file with another format version and a correct checksum (so only the version is wrong).
std::vector<uint8_t> fieldWithVersion(uint32_t version) {
  std::vector<uint8_t> b = validFieldBytes();
  putU32(b, 4, version);
  putU32(b, b.size() - 4, crc32(b.data(), b.size() - 4));
  return b;
}

std::string base64(const std::string& bytes) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (size_t i = 0; i < bytes.size(); i += 3) {
    const uint32_t b0 = uint8_t(bytes[i]);
    const uint32_t b1 = i + 1 < bytes.size() ? uint8_t(bytes[i + 1]) : 0u;
    const uint32_t b2 = i + 2 < bytes.size() ? uint8_t(bytes[i + 2]) : 0u;
    const uint32_t t = (b0 << 16) | (b1 << 8) | b2;
    out += k[(t >> 18) & 63u];
    out += k[(t >> 12) & 63u];
    out += i + 1 < bytes.size() ? k[(t >> 6) & 63u] : '=';
    out += i + 2 < bytes.size() ? k[t & 63u] : '=';
  }
  return out;
}

// A closed tetrahedron as glTF: one buffer (positions then u16 indices, as a data URI), one mesh,
// one node, one scene. Cases edit the JSON to break one thing.
json tetrahedronGltf(std::vector<float> positions = {}, std::vector<uint16_t> indices = {}) {
  if (positions.empty()) positions = {1, 1, 1, 1, -1, -1, -1, 1, -1, -1, -1, 1};
  if (indices.empty()) indices = {0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2};
  std::string bin(reinterpret_cast<const char*>(positions.data()), positions.size() * 4);
  const size_t indexOffset = bin.size();
  bin.append(reinterpret_cast<const char*>(indices.data()), indices.size() * 2);
  while (bin.size() % 4) bin.push_back('\0');
  json g;
  g["asset"] = {{"version", "2.0"}};
  g["buffers"] = json::array(
      {{{"byteLength", bin.size()}, {"uri", "data:application/octet-stream;base64," + base64(bin)}}});
  g["bufferViews"] = json::array({{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", indexOffset}},
                                  {{"buffer", 0}, {"byteOffset", indexOffset}, {"byteLength", indices.size() * 2}}});
  g["accessors"] = json::array({{{"bufferView", 0}, {"componentType", 5126}, {"count", positions.size() / 3},
                                 {"type", "VEC3"}},
                                {{"bufferView", 1}, {"componentType", 5123}, {"count", indices.size()},
                                 {"type", "SCALAR"}}});
  g["meshes"] = json::array({{{"name", "tetra"},
                              {"primitives", json::array({{{"attributes", {{"POSITION", 0}}}, {"indices", 1}}})}}});
  g["nodes"] = json::array({{{"name", "node"}, {"mesh", 0}}});
  g["scenes"] = json::array({{{"nodes", json::array({0})}}});
  g["scene"] = 0;
  return g;
}

// A binary glTF (.glb) of the tetrahedron, its buffer in the BIN chunk.
std::string tetrahedronGlb() {
  json g = tetrahedronGltf();
  std::vector<float> positions = {1, 1, 1, 1, -1, -1, -1, 1, -1, -1, -1, 1};
  std::vector<uint16_t> indices = {0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2};
  std::string bin(reinterpret_cast<const char*>(positions.data()), positions.size() * 4);
  bin.append(reinterpret_cast<const char*>(indices.data()), indices.size() * 2);
  while (bin.size() % 4) bin.push_back('\0');
  g["buffers"][0].erase("uri");
  std::string text = g.dump();
  while (text.size() % 4) text.push_back(' ');
  auto u32 = [](uint32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); };
  std::string glb = "glTF" + u32(2) + u32(uint32_t(12 + 8 + text.size() + 8 + bin.size()));
  glb += u32(uint32_t(text.size())) + "JSON" + text;
  glb += u32(uint32_t(bin.size())) + std::string("BIN\0", 4) + bin;
  return glb;
}

// A little-endian PFM (RGB float, rows bottom to top) of a 16x8 lat-long grey image with one pixel
// replaced by `bad` in channel 1.
std::string pfmWith(float bad) {
  const int w = 16, h = 8;
  std::vector<float> px(size_t(w) * h * 3, 0.5f);
  px[(size_t(3) * w + 5) * 3 + 1] = bad;
  return "PF\n16 8\n-1.0\n" + std::string(reinterpret_cast<const char*>(px.data()), px.size() * 4);
}

// --- cases --------------------------------------------------------------------------------------

struct Case {
  std::string name;                        // the input, in words (docs table)
  std::vector<std::string> args;           // command line after `shrefract`
  std::function<void(const fs::path&)> setup;  // writes the input files into the case's directory
  std::vector<std::string> mustName;       // substrings the message must contain (file, flag, ...)
  std::string output;                      // the output path that must not exist afterwards
  bool needsDevice = false;                // fails only after rendering (GPU needed to get there)
  int exit = 0;                            // the exit status required (0: any non-zero one)
};

std::vector<std::string> quickBake(const std::string& scene, const std::string& out) {
  std::vector<std::string> a{"bake", scene, "-o", out, "--samples", "50", "--dev", "directions=8x16", "--order", "2"};
  return a;
}

std::function<void(const fs::path&)> gltf(const std::string& name, std::function<void(json&)> edit) {
  return [name, edit](const fs::path& dir) {
    json g = tetrahedronGltf();
    edit(g);
    writeBytes(dir / name, g.dump(1));
  };
}

std::vector<Case> cases() {
  std::vector<Case> c;
  auto text = [](const std::string& name, const std::string& bytes) {
    return [name, bytes](const fs::path& dir) { writeBytes(dir / name, bytes); };
  };
  auto field = [](const std::string& name, std::function<void(std::vector<uint8_t>&)> edit) {
    return [name, edit](const fs::path& dir) {
      std::vector<uint8_t> b = validFieldBytes();
      edit(b);
      writeBytes(dir / name, bytesOf(b));
    };
  };
  const auto none = [](const fs::path&) {};

  // Missing files and wrong formats.
  c.push_back({"missing scene file", quickBake("missing.gltf", "out.shrf"), none, {"missing.gltf"}, "out.shrf"});
  c.push_back({"scene with an unknown extension", quickBake("scene.obj", "out.shrf"), text("scene.obj", "v 0 0 0\n"),
               {"scene.obj"}, "out.shrf"});
  c.push_back({"unknown built-in scene", quickBake("builtin:teapot", "out.shrf"), none, {"builtin:teapot"}, "out.shrf"});
  c.push_back({".gltf that is not JSON", quickBake("garbage.gltf", "out.shrf"), text("garbage.gltf", "not json {"),
               {"garbage.gltf"}, "out.shrf"});
  c.push_back({".glb of random bytes", quickBake("garbage.glb", "out.shrf"),
               text("garbage.glb", std::string("\x01\x02\x03\x04garbage garbage garbage", 27)), {"garbage.glb"},
               "out.shrf"});
  c.push_back({".glb cut in half", quickBake("cut.glb", "out.shrf"),
               [](const fs::path& dir) {
                 const std::string glb = tetrahedronGlb();
                 writeBytes(dir / "cut.glb", glb.substr(0, glb.size() / 2));
               },
               {"cut.glb"}, "out.shrf"});
  c.push_back({"missing field file (info)", {"info", "missing.shrf"}, none, {"missing.shrf"}, ""});
  c.push_back({"missing field file (render)", {"render", "missing.shrf", "-o", "out.png"}, none, {"missing.shrf"},
               "out.png"});
  c.push_back({"text file named .shrf", {"info", "notes.shrf"}, text("notes.shrf", "hello\n"), {"notes.shrf"}, ""});
  c.push_back({"empty .shrf", {"info", "empty.shrf"}, text("empty.shrf", ""), {"empty.shrf"}, ""});

  // Field files: truncated, corrupt, other versions.
  c.push_back({"field truncated to its header", {"info", "short.shrf"}, field("short.shrf", [](auto& b) { b.resize(40); }),
               {"short.shrf"}, ""});
  c.push_back({"field missing its last byte", {"info", "cut.shrf"}, field("cut.shrf", [](auto& b) { b.pop_back(); }),
               {"cut.shrf"}, ""});
  c.push_back({"field with trailing bytes", {"info", "long.shrf"},
               field("long.shrf", [](auto& b) { b.push_back(0); }), {"long.shrf"}, ""});
  c.push_back({"field with a flipped byte (checksum)", {"render", "flipped.shrf", "-o", "out.png"},
               field("flipped.shrf", [](auto& b) { b[b.size() / 2] ^= 0x40; }), {"flipped.shrf"}, "out.png"});
  c.push_back({"field of a newer format version", {"render", "future.shrf", "-o", "out.png"},
               [](const fs::path& dir) { writeBytes(dir / "future.shrf", bytesOf(fieldWithVersion(kFieldFormatVersion + 1))); },
               {"future.shrf", "version"}, "out.png"});
  c.push_back({"field of an older format version", {"render", "old.shrf", "-o", "out.png"},
               [](const fs::path& dir) {
                 writeBytes(dir / "old.shrf", bytesOf(fieldWithVersion(kOldestReadFieldFormatVersion - 1)));
               },
               {"old.shrf", "bake the field again"}, "out.png"});
  c.push_back({"field of format version 0", {"info", "zero.shrf"},
               [](const fs::path& dir) { writeBytes(dir / "zero.shrf", bytesOf(fieldWithVersion(0))); },
               {"zero.shrf", "version"}, ""});
  c.push_back({"field whose checksum matches but a count lies", {"info", "lying.shrf"},
               field("lying.shrf",
                     [](auto& b) {
                       // The atlas width in the header: 8 -> 9, checksum fixed up, so only the
                       // structure disagrees.
                       putU32(b, 16, 9);
                       putU32(b, b.size() - 4, crc32(b.data(), b.size() - 4));
                     }),
               {"lying.shrf"}, ""});

  // Malformed glTF.
  c.push_back({"glTF accessor beyond its buffer view", quickBake("accessor.gltf", "out.shrf"),
               gltf("accessor.gltf", [](json& g) { g["accessors"][0]["count"] = 400; }), {"accessor.gltf"}, "out.shrf"});
  c.push_back({"glTF buffer view beyond its buffer", quickBake("view.gltf", "out.shrf"),
               gltf("view.gltf", [](json& g) { g["bufferViews"][1]["byteLength"] = 4000; }), {"view.gltf"}, "out.shrf"});
  c.push_back({"glTF index out of range", quickBake("index.gltf", "out.shrf"),
               [](const fs::path& dir) {
                 writeBytes(dir / "index.gltf", tetrahedronGltf({}, {0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 9}).dump(1));
               },
               {"index.gltf"}, "out.shrf"});
  c.push_back({"glTF indices accessor that does not exist", quickBake("noindices.gltf", "out.shrf"),
               gltf("noindices.gltf", [](json& g) { g["meshes"][0]["primitives"][0]["indices"] = 7; }),
               {"noindices.gltf"}, "out.shrf"});
  c.push_back({"glTF without POSITION", quickBake("noposition.gltf", "out.shrf"),
               gltf("noposition.gltf", [](json& g) { g["meshes"][0]["primitives"][0]["attributes"].erase("POSITION"); }),
               {"noposition.gltf"}, "out.shrf"});
  c.push_back({"glTF index count not a multiple of 3", quickBake("count.gltf", "out.shrf"),
               gltf("count.gltf", [](json& g) { g["accessors"][1]["count"] = 11; }), {"count.gltf"}, "out.shrf"});
  c.push_back({"glTF line primitive (mode 1)", quickBake("lines.gltf", "out.shrf"),
               gltf("lines.gltf", [](json& g) { g["meshes"][0]["primitives"][0]["mode"] = 1; }), {"lines.gltf"},
               "out.shrf"});
  c.push_back({"glTF point primitive (mode 0)", quickBake("points.gltf", "out.shrf"),
               gltf("points.gltf", [](json& g) { g["meshes"][0]["primitives"][0]["mode"] = 0; }), {"points.gltf"},
               "out.shrf"});
  c.push_back({"glTF scene without nodes", quickBake("empty.gltf", "out.shrf"),
               gltf("empty.gltf", [](json& g) { g["scenes"][0]["nodes"] = json::array(); }), {"empty.gltf"},
               "out.shrf"});
  c.push_back({"glTF without scenes or meshes", quickBake("nothing.gltf", "out.shrf"),
               text("nothing.gltf", R"({"asset": {"version": "2.0"}})"), {"nothing.gltf"}, "out.shrf"});
  c.push_back({"glTF zero-area mesh (all corners equal)", quickBake("point.gltf", "out.shrf"),
               [](const fs::path& dir) {
                 writeBytes(dir / "point.gltf", tetrahedronGltf(std::vector<float>(12, 0.25f)).dump(1));
               },
               {"point.gltf"}, "out.shrf"});
  c.push_back({"glTF zero-area mesh (collinear corners)", quickBake("flat.gltf", "out.shrf"),
               [](const fs::path& dir) {
                 writeBytes(dir / "flat.gltf", tetrahedronGltf({0, 0, 0, 1, 0, 0, 2, 0, 0, 3, 0, 0}).dump(1));
               },
               {"flat.gltf"}, "out.shrf"});
  c.push_back({"glTF NaN position", quickBake("nan.gltf", "out.shrf"),
               [](const fs::path& dir) {
                 const float nan = std::numeric_limits<float>::quiet_NaN();
                 writeBytes(dir / "nan.gltf", tetrahedronGltf({1, 1, 1, 1, -1, -1, -1, 1, -1, -1, -1, nan}).dump(1));
               },
               {"nan.gltf"}, "out.shrf"});
  c.push_back({"glTF open mesh (one face missing)", quickBake("open.gltf", "out.shrf"),
               [](const fs::path& dir) {
                 writeBytes(dir / "open.gltf", tetrahedronGltf({}, {0, 1, 2, 0, 3, 1, 0, 2, 3}).dump(1));
               },
               {"open.gltf"}, "out.shrf"});
  c.push_back({"glTF node that is its own child", quickBake("cycle.gltf", "out.shrf"),
               gltf("cycle.gltf", [](json& g) { g["nodes"][0]["children"] = json::array({0}); }), {"cycle.gltf"},
               "out.shrf"});

  // Environment maps.
  const std::vector<std::string> render{"render", "builtin:sphere", "--tessellation", "1", "--size", "32x24"};
  auto renderWithEnv = [&](const std::string& env) {
    std::vector<std::string> a = render;
    a.insert(a.end(), {"--env", env, "-o", "out.png"});
    return a;
  };
  c.push_back({"environment with a NaN pixel (PFM)", renderWithEnv("nan.pfm"),
               text("nan.pfm", pfmWith(std::numeric_limits<float>::quiet_NaN())), {"nan.pfm"}, "out.png"});
  c.push_back({"environment with an Inf pixel (PFM)", renderWithEnv("inf.pfm"),
               text("inf.pfm", pfmWith(std::numeric_limits<float>::infinity())), {"inf.pfm"}, "out.png"});
  c.push_back({"environment with a negative pixel (PFM)", renderWithEnv("negative.pfm"), text("negative.pfm", pfmWith(-2.0f)),
               {"negative.pfm"}, "out.png"});
  c.push_back({"environment with a negative pixel (float EXR)", renderWithEnv("negative.exr"),
               [](const fs::path& dir) {
                 bake::Image img{16, 8, std::vector<float>(16 * 8 * 4, 0.5f)};
                 img.rgba[4 * 20 + 2] = -0.25f;  // writeImage rejects only NaN and Inf
                 bake::ImageWriteOptions o;
                 o.exrPixelType = bake::ExrPixelType::Float;
                 ASSERT_TRUE(bake::writeImage((dir / "negative.exr").string(), img, o).ok());
               },
               {"negative.exr"}, "out.png"});
  c.push_back({"environment that is not lat-long (16x16)", renderWithEnv("square.pfm"),
               text("square.pfm", "PF\n16 16\n-1.0\n" + std::string(16 * 16 * 12, '\0')), {"square.pfm"}, "out.png"});
  c.push_back({"environment file missing", renderWithEnv("missing.hdr"), none, {"missing.hdr"}, "out.png"});
  c.push_back({"environment of random bytes (.hdr)", renderWithEnv("garbage.hdr"),
               text("garbage.hdr", "#?RADIANCE\ngarbage"), {"garbage.hdr"}, "out.png"});
  c.push_back({"environment truncated (.pfm)", renderWithEnv("cut.pfm"),
               text("cut.pfm", pfmWith(0.5f).substr(0, 200)), {"cut.pfm"}, "out.png"});

  // Command lines.
  c.push_back({"unknown command", {"frobnicate"}, none, {"frobnicate"}, ""});
  c.push_back({"unknown flag", {"bake", "builtin:sphere", "-o", "out.shrf", "--bogus"}, none, {"--bogus"}, "out.shrf"});
  c.push_back({"unknown short flag", {"bake", "builtin:sphere", "-o", "out.shrf", "-x"}, none, {"-x"}, "out.shrf"});
  c.push_back({"flag without its value (last)", {"bake", "builtin:sphere", "-o", "out.shrf", "--order"}, none,
               {"--order"}, "out.shrf"});
  c.push_back({"flag without its value (before -o)", {"bake", "builtin:sphere", "--order", "-o", "out.shrf"}, none,
               {"--order"}, "out.shrf"});
  c.push_back({"-o without a path", {"bake", "builtin:sphere", "-o"}, none, {"-o"}, ""});
  c.push_back({"malformed integer", {"bake", "builtin:sphere", "-o", "out.shrf", "--order=abc"}, none, {"--order", "abc"},
               "out.shrf"});
  c.push_back({"integer out of range", {"bake", "builtin:sphere", "-o", "out.shrf", "--order", "99"}, none,
               {"--order"}, "out.shrf"});
  c.push_back({"malformed size", {"render", "builtin:sphere", "-o", "out.png", "--size", "8by16"}, none,
               {"--size", "8by16"}, "out.png"});
  c.push_back({"malformed vector", {"render", "builtin:sphere", "-o", "out.png", "--eye", "1,2"}, none, {"--eye", "1,2"},
               "out.png"});
  c.push_back({"non-finite number", {"render", "builtin:sphere", "-o", "out.png", "--fov", "nan"}, none, {"--fov"},
               "out.png"});
  c.push_back({"flag given twice", {"bake", "builtin:sphere", "-o", "out.shrf", "--order", "2", "--order", "3"}, none,
               {"--order"}, "out.shrf"});
  c.push_back({"switch given a value", {"info", "x.shrf", "--json=yes"}, none, {"--json"}, ""});
  c.push_back({"unknown enumeration value", {"bake", "builtin:sphere", "-o", "out.shrf", "--layout", "spiral"}, none,
               {"--layout", "spiral"}, "out.shrf"});
  // Developer options (--dev KEY=VALUE, docs/developer-options.md): checked as the flags are.
  c.push_back({"unknown developer option", {"bake", "builtin:sphere", "-o", "out.shrf", "--dev", "bogus=1"}, none,
               {"--dev bogus", "--help-dev"}, "out.shrf", false, 2});
  c.push_back({"developer option without its value", {"bake", "builtin:sphere", "-o", "out.shrf", "--dev", "held-out"},
               none, {"--dev held-out"}, "out.shrf", false, 2});
  c.push_back({"developer option out of range", {"bake", "builtin:sphere", "-o", "out.shrf", "--dev", "held-out=-1"},
               none, {"--dev held-out", "0..1024"}, "out.shrf", false, 2});
  c.push_back({"user flag given as a developer option",
               {"bake", "builtin:sphere", "-o", "out.shrf", "--dev", "samples=50"}, none, {"--dev samples", "--samples"},
               "out.shrf", false, 2});
  c.push_back({"developer option given twice",
               {"render", "builtin:sphere", "-o", "out.png", "--dev", "frames=2", "--dev", "frames=3"}, none,
               {"--dev frames"}, "out.png", false, 2});
  c.push_back({"two scenes", {"bake", "builtin:sphere", "builtin:cube", "-o", "out.shrf"}, none, {"SCENE"}, "out.shrf"});
  // Encodings and path rules (docs/encodings.md).
  const std::vector<std::string> bake{"bake", "builtin:sphere", "-o", "out.shrf"};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> a = bake;
    a.insert(a.end(), extra.begin(), extra.end());
    return a;
  };
  c.push_back({"unknown encoding", with({"--encoding", "wavelet"}), none, {"--encoding", "wavelet"}, "out.shrf"});
  c.push_back({"table size out of range", with({"--encoding", "table", "--table-size", "1"}), none, {"--table-size"},
               "out.shrf"});
  c.push_back({"pca components out of range", with({"--encoding", "pca", "--components", "0"}), none, {"--components"},
               "out.shrf"});
  c.push_back({"clusters out of range", with({"--dev", "clusters=5000"}), none, {"--dev clusters"}, "out.shrf"});
  c.push_back({"clusters with another encoding", with({"--encoding", "sh", "--dev", "clusters=64"}), none,
               {"--dev clusters", "--encoding pca"}, "out.shrf"});
  c.push_back({"byte budget out of range", with({"--max-bytes-per-sample", "0"}), none, {"--max-bytes-per-sample"},
               "out.shrf"});
  c.push_back({"byte budget and error target together",
               with({"--max-bytes-per-sample", "324", "--dev", "max-error=2"}), none,
               {"--max-bytes-per-sample", "--dev max-error"}, "out.shrf"});
  c.push_back({"unknown direction sampling", with({"--dev", "direction-sampling=random"}), none,
               {"--dev direction-sampling", "random"}, "out.shrf"});
  c.push_back({"node sampling of SH", with({"--order", "4", "--dev", "direction-sampling=nodes"}), none,
               {"--dev direction-sampling", "table or pca"}, "out.shrf"});
  c.push_back({"node sampling with a grid size",
               with({"--dev", "direction-sampling=nodes", "--dev", "directions=8x16"}), none,
               {"--dev directions", "--dev direction-sampling"}, "out.shrf"});
  c.push_back({"SH order with another encoding", with({"--encoding", "pca", "--order", "4"}), none, {"--order"},
               "out.shrf"});
  c.push_back({"unknown path rule", with({"--path-rule", "widest"}), none, {"--path-rule", "widest"}, "out.shrf"});
  c.push_back({"unknown SH fit", with({"--order", "4", "--dev", "sh-fit=huber"}), none, {"--dev sh-fit", "huber"},
               "out.shrf"});
  c.push_back({"SH fit with another encoding", with({"--encoding", "pca", "--dev", "sh-fit=robust"}), none,
               {"--dev sh-fit", "--encoding sh"}, "out.shrf"});
  c.push_back({"volume size out of range", with({"--encoding", "volume", "--volume-size", "4"}), none,
               {"--volume-size"}, "out.shrf", false, 2});
  c.push_back({"volume size with another encoding", with({"--encoding", "pca", "--volume-size", "64"}), none,
               {"--volume-size", "--encoding volume"}, "out.shrf", false, 2});
  c.push_back({"volume with a component count", with({"--encoding", "volume", "--components", "8"}), none,
               {"--components", "--encoding volume"}, "out.shrf", false, 2});
  c.push_back({"volume of nested media", {"bake", "builtin:glass-of-water", "-o", "out.shrf", "--encoding", "volume"},
               none, {"builtin:glass-of-water", "volume encoding", "3 media"}, "out.shrf", false, 1});
  c.push_back({"volume in shards",
               {"bake", "builtin:sphere", "-o", "out.shrfpart", "--encoding", "volume", "--shard", "0/2"}, none,
               {"volume encoding", "one process"}, "out.shrfpart", false, 1});

  // Scenes given to render, cameras.
  const std::vector<std::string> sphere{"render", "builtin:sphere", "--tessellation", "1", "--size", "16x12",
                                        "--mode", "exact", "-o", "out.png"};
  auto camera = [&](std::vector<std::string> extra) {
    std::vector<std::string> a = sphere;
    a.insert(a.end(), extra.begin(), extra.end());
    return a;
  };
  c.push_back({".glb cut in half, rendered", {"render", "cut.glb", "-o", "out.png"},
               [](const fs::path& dir) {
                 const std::string glb = tetrahedronGlb();
                 writeBytes(dir / "cut.glb", glb.substr(0, glb.size() / 2));
               },
               {"cut.glb", "glTF"}, "out.png", false, 1});
  c.push_back({"damaged glTF under another extension, rendered", {"render", "scene.bin", "-o", "out.png"},
               text("scene.bin", "{\"asset\": {\"version\": "), {"scene.bin", "glTF"}, "out.png", false, 1});
  c.push_back({"field-only mode on a glTF scene", {"render", "tetra.gltf", "--mode", "sh", "-o", "out.png"},
               gltf("tetra.gltf", [](json&) {}), {"tetra.gltf", "--mode sh"}, "out.png", false, 2});
  c.push_back({"eye equal to target", camera({"--eye", "0,0,3", "--target", "0,0,3"}), none,
               {"--eye 0,0,3", "--target 0,0,3"}, "out.png", false, 2});
  c.push_back({"up parallel to the view", camera({"--eye", "0,0,3", "--up", "0,0,1"}), none, {"--up 0,0,1"},
               "out.png", false, 2});
  c.push_back({"eye too large for a float", camera({"--eye", "1e39,0,0"}), none, {"--eye"}, "out.png", false, 2});
  c.push_back({"exposure not positive", camera({"--exposure", "-1"}), none, {"--exposure"}, "out.png", false, 2});
  c.push_back({"direction grid out of range", with({"--dev", "directions=1000x16"}), none,
               {"--dev directions", "1000x16"}, "out.shrf", false, 2});
  c.push_back({"field scene that moved", {"render", "moved.shrf", "--mode", "exact", "-o", "out.png"},
               [](const fs::path& dir) {
                 Field f = testing::makeSyntheticField({});
                 f.settings.source = "gone.gltf?absolute=/nonexistent/gone.gltf";
                 writeBytes(dir / "moved.shrf", bytesOf(serializeField(f)));
               },
               {"moved.shrf", "--dev scene"}, "out.png", false, 1});
  c.push_back({"report of a missing scene", {"report", "missing.gltf", "--smoke", "-o", "rep"}, none,
               {"missing.gltf"}, "rep", false, 1});
  c.push_back({"view screenshot in a missing directory",
               {"view", "builtin:sphere", "--frames", "1", "--screenshot", "nodir/shot.png"}, none, {"nodir/shot.png"},
               "nodir/shot.png", false, 1});

  // Outputs.
  c.push_back({"bake output without .shrf", quickBake("builtin:sphere", "out.txt"), none, {"out.txt"}, "out.txt"});
  c.push_back({"bake output in a missing directory", quickBake("builtin:sphere", "nodir/out.shrf"), none,
               {"nodir/out.shrf"}, "nodir/out.shrf"});
  c.push_back({"bake output that is a directory", quickBake("builtin:sphere", "taken.shrf"),
               [](const fs::path& dir) { fs::create_directory(dir / "taken.shrf"); }, {"taken.shrf"}, ""});
  c.push_back({"render output with an unknown extension", {"render", "builtin:sphere", "-o", "out.bmp"}, none,
               {"out.bmp"}, "out.bmp"});
  c.push_back({"render output in a missing directory",
               {"render", "builtin:sphere", "--tessellation", "1", "--size", "32x24", "-o", "nodir/out.png"}, none,
               {"nodir/out.png"}, "nodir/out.png", true});
  c.push_back({"render output that is a directory",
               {"render", "builtin:sphere", "--tessellation", "1", "--size", "32x24", "-o", "taken.png"},
               [](const fs::path& dir) { fs::create_directory(dir / "taken.png"); }, {"taken.png"}, "", true});
  if (geteuid() != 0) {
    // Root writes into read-only directories: this case exists only for other users.
    c.push_back({"bake output in a read-only directory", quickBake("builtin:sphere", "ro/out.shrf"),
                 [](const fs::path& dir) {
                   fs::create_directory(dir / "ro");
                   fs::permissions(dir / "ro", fs::perms::owner_read | fs::perms::owner_exec);
                 },
                 {"ro/out.shrf"}, "ro/out.shrf"});
  }
  return c;
}

std::string escapeCell(std::string s) {
  std::string out;
  for (char ch : s) {
    if (ch == '|') out += "\\|";
    else if (ch == '\n') continue;
    else out += ch;
  }
  return out;
}

// A Markdown code span around `s`, with a longer fence when `s` holds a backtick.
std::string codeSpan(const std::string& s) {
  return s.find('`') == std::string::npos ? "`" + s + "`" : "`` " + s + " ``";
}

std::string joinArgs(const std::vector<std::string>& args) {
  std::string s = "shrefract";
  for (const auto& a : args) s += " " + a;
  return s;
}

// Files left in `dir` other than the case's inputs (those present before the run).
std::vector<std::string> newFiles(const fs::path& dir, const std::vector<std::string>& before) {
  std::vector<std::string> found;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    const std::string rel = fs::relative(e.path(), dir).string();
    if (std::find(before.begin(), before.end(), rel) == before.end()) found.push_back(rel);
  }
  return found;
}

std::vector<std::string> listFiles(const fs::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::recursive_directory_iterator(dir)) out.push_back(fs::relative(e.path(), dir).string());
  return out;
}

TEST(BadInput, EveryCaseFailsWithOneLineAndNoOutput) {
  ASSERT_FALSE(tool().empty()) << "SHREFRACT_TOOL is not set (ctest sets it to the shrefract binary)";
  ASSERT_TRUE(fs::exists(tool())) << tool();
  const fs::path root = fs::current_path() / "bad_input_work";
  fs::remove_all(root);
  fs::create_directories(root);
  std::string table =
      "| input | command | exit | message (stderr) |\n"
      "|---|---|---|---|\n";
  int index = 0;
  for (const Case& c : cases()) {
    SCOPED_TRACE(c.name);
    const fs::path dir = root / ("case" + std::to_string(index++));
    fs::create_directories(dir);
    if (c.setup) c.setup(dir);
    const std::vector<std::string> before = listFiles(dir);
    const Outcome o = runTool(dir, c.args);
    std::string line = o.err;
    if (!line.empty() && line.back() == '\n') line.pop_back();
    // The tool's exit status for "no Vulkan device" (samples/cli/commands.h): skipped, unless the
    // build requires a device (CI), where it fails.
    if (c.needsDevice && o.exitCode == 3 && !SHREFRACT_REQUIRE_GPU) {
      std::printf("skipped (no Vulkan device): %s: %s\n", c.name.c_str(), line.c_str());
      continue;
    }
    EXPECT_EQ(o.signal, 0) << "killed by signal " << o.signal << "; stderr: " << o.err;
    EXPECT_NE(o.exitCode, 0) << joinArgs(c.args) << " succeeded; stdout: " << o.out;
    EXPECT_NE(o.exitCode, -1);
    if (c.exit != 0) {
      EXPECT_EQ(o.exitCode, c.exit) << joinArgs(c.args) << ": " << o.err;
    }
    // Exactly one line: one newline, at the end.
    EXPECT_EQ(std::count(o.err.begin(), o.err.end(), '\n'), 1) << "stderr:\n" << o.err;
    EXPECT_TRUE(!o.err.empty() && o.err.back() == '\n') << "stderr:\n" << o.err;
    for (const std::string& name : c.mustName) {
      EXPECT_NE(line.find(name), std::string::npos) << "the message does not name '" << name << "': " << line;
    }
    if (!c.output.empty()) {
      EXPECT_FALSE(fs::exists(dir / c.output)) << c.output << " was written";
    }
    const std::vector<std::string> left = newFiles(dir, before);
    EXPECT_TRUE(left.empty()) << "left behind: " << (left.empty() ? "" : left.front());
    std::printf("| bad-input | %s | %s | %d | %s |\n", c.name.c_str(), joinArgs(c.args).c_str(), o.exitCode,
                line.c_str());
    table += "| " + escapeCell(c.name) + " | " + codeSpan(escapeCell(joinArgs(c.args))) + " | " +
             std::to_string(o.exitCode) + " | " + codeSpan(escapeCell(line)) + " |\n";
  }
  std::fflush(stdout);
  if (const char* path = std::getenv("SHREFRACT_BAD_INPUT_TABLE")) {
    std::ofstream out(path);
    out << table;
  }
  // Leave the inputs for a look when something failed.
  if (!HasFailure()) fs::remove_all(root);
}

// An interrupted report (Ctrl-C, or SIGTERM from a scheduler) removes its stage and leaves an
// earlier report in DIR as it was, as a failed run does (samples/cli/interrupt.h): the report
// runs for hours, and its DIR.partial-PID beside DIR was left behind by every interrupt before.
TEST(BadInput, InterruptedReportLeavesNoPartialOutput) {
  ASSERT_FALSE(tool().empty()) << "SHREFRACT_TOOL is not set (ctest sets it to the shrefract binary)";
  for (const int signal : {SIGINT, SIGTERM}) {
    SCOPED_TRACE(strsignal(signal));
    const fs::path dir = fs::current_path() / "interrupt_work" / std::to_string(signal);
    fs::remove_all(dir);
    fs::create_directories(dir / "rep");
    const std::string earlier = "an earlier report\n";
    writeBytes(dir / "rep" / "report.md", earlier);
    const pid_t pid = startTool(dir, {"report", "--smoke", "--threads", "1", "-o", "rep"});
    ASSERT_GT(pid, 0);
    // Interrupted once the report has written into its stage; polled without reaping the child.
    const fs::path staging = dir / ("rep.partial-" + std::to_string(pid));
    bool ended = false, staged = false;
    for (int i = 0; i < 30000 && !ended && !staged; ++i) {
      siginfo_t info{};
      ended = waitid(P_PID, id_t(pid), &info, WEXITED | WNOHANG | WNOWAIT) == 0 && info.si_pid == pid;
      std::error_code ec;
      staged = fs::is_directory(staging, ec) && !fs::is_empty(staging, ec);
      if (!ended && !staged) usleep(10000);
    }
    kill(pid, staged ? signal : SIGKILL);  // without a stage: ended, or still running after 5 minutes
    const Outcome o = finishTool(dir, pid);
    if (!staged && o.exitCode == 3 && !SHREFRACT_REQUIRE_GPU) {  // kExitNoDevice
      std::printf("skipped (no Vulkan device): %s", o.err.c_str());
      return;
    }
    ASSERT_TRUE(staged) << "the report never wrote into " << staging << "; exit " << o.exitCode << ", stderr:\n"
                        << o.err;
    EXPECT_EQ(o.signal, 0) << "killed by the signal, not exited";
    EXPECT_EQ(o.exitCode, 128 + signal);
    std::string last = o.err.substr(0, o.err.size() - 1);
    last = last.substr(last.find_last_of('\n') + 1);
    EXPECT_NE(last.find("interrupted"), std::string::npos) << last;
    EXPECT_NE(last.find(staging.filename().string()), std::string::npos) << "the line does not name the stage: " << last;
    std::vector<std::string> left = listFiles(dir);
    std::sort(left.begin(), left.end());
    EXPECT_EQ(left, std::vector<std::string>({"rep", "rep/report.md"}));
    EXPECT_EQ(slurp(dir / "rep" / "report.md"), earlier);
  }
  if (!HasFailure()) fs::remove_all(fs::current_path() / "interrupt_work");
}

}  // namespace
}  // namespace shrefract

// What the viewer shows, and how each key changes it. No window system and no GPU: the viewer maps
// GLFW keys (or the characters of --keys, for tests) to Actions and applies them here; what the
// frame loop must then rebuild is read back from the state. Unit-tested in tests/viewer.
#pragma once

#include <shrefract/renderer.h>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace shrefract::viewer {

enum class Action {
  OrderDown,        // [      one SH band fewer (down to 0)
  OrderUp,          // ]      one band more (up to the shown field's baked order)
  AbsorptionDown,   // -      absorption scale halved (0 below kMinAbsorption)
  AbsorptionUp,     // + =    absorption scale doubled (from 0: kMinAbsorption)
  NextEnvironment,  // E      cycle through the environments (each --env, then builtin)
  ToggleMode,       // M      field <-> single-interface (fields only)
  ToggleField,      // F      show the other field (split <-> charts) when two are loaded
  ToggleInstances,  // I      one instance of the shown field <-> kInstances, placed side by side
  NextEnvironmentTaps,  // T  taps per axis of the filtered environment lookups, 1 -> 2 -> ... -> max -> 1
  ToggleVolumeRefinement,  // P  volume fields traced per fragment: 4x4 paths where the 2x2 part, on <-> off
  ResetCamera,      // R
  Help,             // H      print the key list on stdout
  Quit,             // Esc Q
};

// The action a --keys character stands for (the same letters as the keys, lower case), or none.
std::optional<Action> actionForCharacter(char c);
// The key list printed by Help and by `shrefract view --help`.
const char* keyHelp();

struct FieldInfo {
  std::string name;      // file name as given
  uint32_t bakedOrder = 0;
  std::string layout;    // "split" or "charts"
  std::string encoding = "sh";  // "sh" (run-time order applies), "table" or "pca" (with its parameters)
};

struct ViewState {
  std::vector<FieldInfo> fields;  // 0 (a scene), 1 or 2
  size_t field = 0;               // shown field
  uint32_t order = 0;             // SH order used for the shown field (<= its baked order)
  float absorption = 1.0f;        // ObjectShading::absorptionScale
  size_t environment = 0;
  size_t environmentCount = 1;
  ShadingMode mode = ShadingMode::SingleInterface;
  bool quit = false;
  bool resetCamera = false;       // consumed by the frame loop
  uint32_t instances = 1;         // instances of the shown field drawn (Object::createInstance)
  // RendererCreateInfo::environmentTapsPerAxis: the frame loop rebuilds the renderer when it changes.
  uint32_t environmentTaps = RendererCreateInfo{}.environmentTapsPerAxis;
  // RendererCreateInfo::refineVolumePaths: likewise a new renderer when it changes.
  bool refineVolumePaths = RendererCreateInfo{}.refineVolumePaths;

  static constexpr uint32_t kInstances = 3;
  static constexpr float kMinAbsorption = 1.0f / 64.0f;  // smallest non-zero step
  static constexpr float kMaxAbsorption = 1024.0f;       // bounds the doubling

  bool hasFields() const { return !fields.empty(); }
};

// Applies `action`; returns true when something visible changed.
bool apply(ViewState& state, Action action);

// One line for the window title: what is shown and the last frame's timings (negative: unknown).
std::string title(const ViewState& state, const std::vector<std::string>& environmentNames, double frameMs,
                  double decompressionMs, double rasterMs);

}  // namespace shrefract::viewer

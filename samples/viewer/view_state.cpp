#include "viewer/view_state.h"

#include <algorithm>
#include <cstdio>

namespace shrefract::viewer {

std::optional<Action> actionForCharacter(char c) {
  switch (c) {
    case '[': return Action::OrderDown;
    case ']': return Action::OrderUp;
    case '-': return Action::AbsorptionDown;
    case '+':
    case '=': return Action::AbsorptionUp;
    case 'e': return Action::NextEnvironment;
    case 'm': return Action::ToggleMode;
    case 'f': return Action::ToggleField;
    case 'i': return Action::ToggleInstances;
    case 't': return Action::NextEnvironmentTaps;
    case 'p': return Action::ToggleVolumeRefinement;
    case 'r': return Action::ResetCamera;
    case 'h': return Action::Help;
    case 'q': return Action::Quit;
    default: return std::nullopt;
  }
}

const char* keyHelp() {
  return "mouse: left drag orbits, right or middle drag (or shift + left) pans, wheel zooms\n"
         "keys:  [ ]  SH order down / up (SH fields; 0 .. the baked order)\n"
         "       - +  absorption scale halved / doubled\n"
         "       E    next environment (each --env, then builtin)\n"
         "       M    mode: field <-> single-interface (fields only)\n"
         "       F    show the other field (split <-> charts; with two fields)\n"
         "       I    one instance of the field <-> three, placed side by side (fields only)\n"
         "       T    taps per axis of each environment lookup: 1 (one trilinear lookup), 2, 3, 4 (default)\n"
         "       P    volume fields: 4x4 paths where a pixel's 2x2 paths part (default) <-> 2x2 everywhere\n"
         "       R    reset the camera    H  this help    Esc Q  quit\n";
}

bool apply(ViewState& s, Action action) {
  switch (action) {
    case Action::OrderDown:
      if (!s.hasFields() || s.order == 0) return false;
      --s.order;
      return true;
    case Action::OrderUp:
      if (!s.hasFields() || s.order >= s.fields[s.field].bakedOrder) return false;
      ++s.order;
      return true;
    case Action::AbsorptionDown:
      if (s.absorption == 0.0f) return false;
      s.absorption = s.absorption * 0.5f < ViewState::kMinAbsorption ? 0.0f : s.absorption * 0.5f;
      return true;
    case Action::AbsorptionUp:
      if (s.absorption >= ViewState::kMaxAbsorption) return false;
      s.absorption = s.absorption == 0.0f ? ViewState::kMinAbsorption : std::min(s.absorption * 2.0f, ViewState::kMaxAbsorption);
      return true;
    case Action::NextEnvironment:
      if (s.environmentCount < 2) return false;
      s.environment = (s.environment + 1) % s.environmentCount;
      return true;
    case Action::ToggleMode:
      if (!s.hasFields()) return false;  // a scene has no field: single-interface only
      s.mode = s.mode == ShadingMode::Field ? ShadingMode::SingleInterface : ShadingMode::Field;
      return true;
    case Action::ToggleField:
      if (s.fields.size() < 2) return false;
      s.field = (s.field + 1) % s.fields.size();
      // Keep the order the user chose where the other field has it.
      s.order = std::min(s.order, s.fields[s.field].bakedOrder);
      return true;
    case Action::ToggleInstances:
      if (!s.hasFields()) return false;
      s.instances = s.instances == 1 ? ViewState::kInstances : 1;
      return true;
    case Action::NextEnvironmentTaps:
      s.environmentTaps = s.environmentTaps % kMaxEnvironmentTapsPerAxis + 1;
      return true;
    case Action::ToggleVolumeRefinement:
      s.refineVolumePaths = !s.refineVolumePaths;
      return true;
    case Action::ResetCamera:
      s.resetCamera = true;
      return true;
    case Action::Help:
      std::fputs(keyHelp(), stdout);
      std::fflush(stdout);
      return false;
    case Action::Quit:
      s.quit = true;
      return false;
  }
  return false;
}

std::string title(const ViewState& s, const std::vector<std::string>& environmentNames, double frameMs,
                  double decompressionMs, double rasterMs) {
  char buffer[512];
  std::string what;
  if (s.hasFields()) {
    const FieldInfo& f = s.fields[s.field];
    char encoding[64];
    if (f.encoding == "sh") std::snprintf(encoding, sizeof(encoding), "L=%u/%u", s.order, f.bakedOrder);
    else std::snprintf(encoding, sizeof(encoding), "%s", f.encoding.c_str());
    std::snprintf(buffer, sizeof(buffer), "%s [%s%s] | %s %s | k=%.3g%s", f.name.c_str(), f.layout.c_str(),
                  s.fields.size() > 1 ? ", F: other" : "",
                  s.mode == ShadingMode::Field ? "field" : "single-interface", encoding,
                  static_cast<double>(s.absorption), s.instances > 1 ? " | 3 instances" : "");
    what = buffer;
  } else {
    what = "scene | single-interface";
  }
  const std::string env = s.environment < environmentNames.size() ? environmentNames[s.environment] : "?";
  std::string timings;
  if (frameMs >= 0.0) {
    std::snprintf(buffer, sizeof(buffer), " | %.2f ms/frame", frameMs);
    timings += buffer;
  }
  if (rasterMs >= 0.0) {
    if (decompressionMs >= 0.0)
      std::snprintf(buffer, sizeof(buffer), " | GPU decompression %.3f ms, raster %.3f ms", decompressionMs, rasterMs);
    else
      std::snprintf(buffer, sizeof(buffer), " | GPU raster %.3f ms", rasterMs);
    timings += buffer;
  }
  return "shrefract view | " + what + " | env " + env + " | taps " + std::to_string(s.environmentTaps) +
         (s.refineVolumePaths ? "" : " | volume 2x2") + timings;
}

}  // namespace shrefract::viewer

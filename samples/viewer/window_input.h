// The viewer's window input: GLFW's callbacks collect key actions and drag the orbit camera
// between frames. Window-system code, so not in the viewer core that tests build without GLFW.
#pragma once

#include <GLFW/glfw3.h>

#include <vector>

#include "viewer/orbit_camera.h"
#include "viewer/view_state.h"

namespace shrefract::viewer {

// What the GLFW callbacks collect between frames.
struct Input {
  std::vector<Action> actions;
  OrbitCamera* camera = nullptr;
  bool haveCursor = false;
  double lastX = 0.0, lastY = 0.0;
};

// Points the window's character, key, cursor and scroll callbacks at `input`, which must outlive
// them (until the window is destroyed or other callbacks are set).
void listenForInput(GLFWwindow* window, Input& input);

}  // namespace shrefract::viewer

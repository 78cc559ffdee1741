#include "viewer/window_input.h"

#include <cctype>

namespace shrefract::viewer {
namespace {

Input& inputOf(GLFWwindow* window) { return *static_cast<Input*>(glfwGetWindowUserPointer(window)); }

// Characters rather than key codes, so that '[', ']' and '+' work on any keyboard layout.
void onChar(GLFWwindow* window, unsigned int codepoint) {
  if (codepoint >= 128) return;
  const char c = static_cast<char>(std::tolower(static_cast<int>(codepoint)));
  if (auto action = actionForCharacter(c)) inputOf(window).actions.push_back(*action);
}

void onKey(GLFWwindow* window, int key, int /*scancode*/, int action, int /*mods*/) {
  if (key == GLFW_KEY_ESCAPE && action == GLFW_PRESS) inputOf(window).actions.push_back(Action::Quit);
}

void onCursor(GLFWwindow* window, double x, double y) {
  Input& in = inputOf(window);
  const double dx = x - in.lastX, dy = y - in.lastY;
  const bool hadCursor = in.haveCursor;
  in.lastX = x;
  in.lastY = y;
  in.haveCursor = true;
  if (!hadCursor) return;
  int width = 0, height = 0;
  glfwGetWindowSize(window, &width, &height);
  const bool left = glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS;
  const bool right = glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS;
  const bool middle = glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_MIDDLE) == GLFW_PRESS;
  const bool shift =
      glfwGetKey(window, GLFW_KEY_LEFT_SHIFT) == GLFW_PRESS || glfwGetKey(window, GLFW_KEY_RIGHT_SHIFT) == GLFW_PRESS;
  if (right || middle || (left && shift))
    in.camera->pan(static_cast<float>(dx), static_cast<float>(dy), static_cast<float>(height));
  else if (left)
    in.camera->orbit(static_cast<float>(dx), static_cast<float>(dy), static_cast<float>(height));
}

void onScroll(GLFWwindow* window, double /*dx*/, double dy) { inputOf(window).camera->zoom(static_cast<float>(dy)); }

}  // namespace

void listenForInput(GLFWwindow* window, Input& input) {
  glfwSetWindowUserPointer(window, &input);
  glfwSetCharCallback(window, onChar);
  glfwSetKeyCallback(window, onKey);
  glfwSetCursorPosCallback(window, onCursor);
  glfwSetScrollCallback(window, onScroll);
}

}  // namespace shrefract::viewer

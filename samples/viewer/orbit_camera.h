// Orbit camera for the viewer: the eye moves on a sphere around a target point. Mouse deltas in
// pixels turn into yaw/pitch (orbit), a target shift in the view plane (pan) and a distance scale
// (zoom). Pure math, no window system: unit-tested in tests/viewer.
#pragma once

#include <shrefract/renderer.h>

#include <array>

namespace shrefract::viewer {

class OrbitCamera {
 public:
  // Takes eye, target, field of view and clip planes from `initial`; the up vector is +Y.
  // The near and far planes keep their ratio to the eye distance as the camera zooms.
  explicit OrbitCamera(const Camera& initial);

  // Turns the eye around the target: a drag across the whole viewport height turns by 180 degrees.
  // Pitch stays within +-kMaxPitchDegrees so that the view never flips over the pole.
  void orbit(float dxPixels, float dyPixels, float viewportHeight);
  // Moves the target (and the eye with it) in the view plane so that a point at the target's depth
  // follows the cursor.
  void pan(float dxPixels, float dyPixels, float viewportHeight);
  // Scales the eye distance by kZoomStep^-steps (positive steps move closer), within
  // [initial / kZoomRange, initial * kZoomRange].
  void zoom(float steps);
  void reset();

  Camera camera() const;
  float yawDegrees() const;
  float pitchDegrees() const;
  float distance() const { return distance_; }
  std::array<float, 3> target() const { return target_; }

  static constexpr float kMaxPitchDegrees = 89.0f;  // keeps lookAt's up vector well defined
  static constexpr float kZoomStep = 1.1f;          // one wheel notch: 10% closer
  static constexpr float kZoomRange = 50.0f;        // bounds the distance around its initial value

 private:
  Camera initial_;
  std::array<float, 3> target_{};
  float distance_ = 1.0f;
  float yaw_ = 0.0f;    // radians around +Y, 0 looks along -Z (eye on +Z)
  float pitch_ = 0.0f;  // radians above the horizontal plane through the target
  float initialDistance_ = 1.0f;
  float nearRatio_ = 1e-3f;  // nearPlane / distance of the initial camera
  float farRatio_ = 10.0f;   // farPlane / distance
};

}  // namespace shrefract::viewer

#include "viewer/orbit_camera.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace shrefract::viewer {
namespace {

constexpr float kPi = std::numbers::pi_v<float>;
constexpr float kDegrees = 180.0f / kPi;

}  // namespace

OrbitCamera::OrbitCamera(const Camera& initial) : initial_(initial) { reset(); }

void OrbitCamera::reset() {
  target_ = initial_.target;
  const float dx = initial_.eye[0] - target_[0], dy = initial_.eye[1] - target_[1], dz = initial_.eye[2] - target_[2];
  distance_ = std::max(std::sqrt(dx * dx + dy * dy + dz * dz), 1e-6f);
  initialDistance_ = distance_;
  yaw_ = std::atan2(dx, dz);
  pitch_ = std::asin(std::clamp(dy / distance_, -1.0f, 1.0f));
  const float maxPitch = kMaxPitchDegrees / kDegrees;
  pitch_ = std::clamp(pitch_, -maxPitch, maxPitch);
  nearRatio_ = initial_.nearPlane / distance_;
  farRatio_ = initial_.farPlane / distance_;
}

void OrbitCamera::orbit(float dxPixels, float dyPixels, float viewportHeight) {
  const float radiansPerPixel = kPi / std::max(viewportHeight, 1.0f);
  yaw_ -= dxPixels * radiansPerPixel;
  pitch_ += dyPixels * radiansPerPixel;
  const float maxPitch = kMaxPitchDegrees / kDegrees;
  pitch_ = std::clamp(pitch_, -maxPitch, maxPitch);
  yaw_ = std::remainder(yaw_, 2.0f * kPi);
}

void OrbitCamera::pan(float dxPixels, float dyPixels, float viewportHeight) {
  // World units per pixel at the target's depth.
  const float halfHeight = distance_ * std::tan(0.5f * initial_.verticalFovDegrees / kDegrees);
  const float unitsPerPixel = 2.0f * halfHeight / std::max(viewportHeight, 1.0f);
  // Camera axes: forward from eye to target, right = forward x up, up' = right x forward.
  const float cp = std::cos(pitch_), sp = std::sin(pitch_), cy = std::cos(yaw_), sy = std::sin(yaw_);
  const std::array<float, 3> right{cy, 0.0f, -sy};
  const std::array<float, 3> up{-sp * sy, cp, -sp * cy};
  for (int k = 0; k < 3; ++k) {
    const auto i = static_cast<size_t>(k);
    // Dragging right moves the scene right: the target moves left.
    target_[i] += (-dxPixels * right[i] + dyPixels * up[i]) * unitsPerPixel;
  }
}

void OrbitCamera::zoom(float steps) {
  distance_ /= std::pow(kZoomStep, steps);
  distance_ = std::clamp(distance_, initialDistance_ / kZoomRange, initialDistance_ * kZoomRange);
}

Camera OrbitCamera::camera() const {
  Camera c = initial_;
  const float cp = std::cos(pitch_), sp = std::sin(pitch_), cy = std::cos(yaw_), sy = std::sin(yaw_);
  c.eye = {target_[0] + distance_ * cp * sy, target_[1] + distance_ * sp, target_[2] + distance_ * cp * cy};
  c.target = target_;
  c.up = {0.0f, 1.0f, 0.0f};
  c.nearPlane = distance_ * nearRatio_;
  c.farPlane = distance_ * farRatio_;
  return c;
}

float OrbitCamera::yawDegrees() const { return yaw_ * kDegrees; }
float OrbitCamera::pitchDegrees() const { return pitch_ * kDegrees; }

}  // namespace shrefract::viewer

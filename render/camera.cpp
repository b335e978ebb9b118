#include "camera.h"

#include <algorithm>
#include <cmath>
#include <glm/gtc/matrix_transform.hpp>

namespace cvt::render {

void OrbitCamera::fit(const glm::vec3& lo, const glm::vec3& hi, float aspect) {
  target = 0.5f * (lo + hi);
  scene_radius = std::max(0.5f * glm::length(hi - lo), 1e-3f);
  // The narrower of the two fields of view decides. The bounding sphere of the box is loose
  // for rounded organs: 0.85 of the distance at which it would touch that field frames them
  // well (the middles of the box faces stay in view).
  const float half_y = glm::radians(0.5f * fov_y_deg);
  const float half_x = std::atan(std::tan(half_y) * std::max(aspect, 1e-3f));
  distance = 0.85f * scene_radius / std::sin(std::min(half_x, half_y));
}

void OrbitCamera::orbit(float dx_px, float dy_px) {
  yaw_deg -= 0.3f * dx_px;
  yaw_deg = std::fmod(yaw_deg, 360.0f);
  pitch_deg = std::clamp(pitch_deg + 0.3f * dy_px, -89.0f, 89.0f);
}

glm::vec3 OrbitCamera::forward() const {
  const float yaw = glm::radians(yaw_deg), pitch = glm::radians(pitch_deg);
  // The eye sits at target − distance · forward.
  return -glm::vec3(std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw),
                    std::sin(pitch));
}

glm::vec3 OrbitCamera::eye() const {
  return target - distance * forward();
}

void OrbitCamera::pan(float dx_px, float dy_px, float viewport_h_px) {
  const glm::vec3 f = forward();
  const glm::vec3 right = glm::normalize(glm::cross(f, glm::vec3(0, 0, 1)));
  const glm::vec3 up = glm::cross(right, f);
  const float mm_per_px =
      2.0f * distance * std::tan(glm::radians(0.5f * fov_y_deg)) / std::max(viewport_h_px, 1.0f);
  target += mm_per_px * (-dx_px * right + dy_px * up);
}

void OrbitCamera::zoom(float steps) {
  distance *= std::pow(0.88f, steps);
  distance = std::clamp(distance, 1e-3f * scene_radius, 100.0f * scene_radius);
}

glm::mat4 OrbitCamera::view() const {
  return glm::lookAt(eye(), target, glm::vec3(0, 0, 1));
}

glm::mat4 OrbitCamera::projection(float aspect) const {
  // Near/far bracket the scene sphere around the target, wherever the eye is.
  const float near_mm = std::max(distance - 2.0f * scene_radius, 0.002f * distance);
  const float far_mm = distance + 2.0f * scene_radius;
  return glm::perspective(glm::radians(fov_y_deg), std::max(aspect, 1e-3f), near_mm, far_mm);
}

void SliceViewTransform::fit(float width_mm, float height_mm, float viewport_w_px,
                             float viewport_h_px) {
  center_mm = {0.5f * width_mm, 0.5f * height_mm};
  const float sx = viewport_w_px / std::max(width_mm, 1e-6f);
  const float sy = viewport_h_px / std::max(height_mm, 1e-6f);
  pixels_per_mm = 0.95f * std::min(sx, sy);
}

void SliceViewTransform::pan(float dx_px, float dy_px) {
  center_mm -= glm::vec2(dx_px, dy_px) / pixels_per_mm;
}

void SliceViewTransform::zoom_at(float steps, float x_px, float y_px, float viewport_w_px,
                                 float viewport_h_px) {
  const glm::vec2 before = screen_to_slice({x_px, y_px}, viewport_w_px, viewport_h_px);
  pixels_per_mm = std::clamp(pixels_per_mm * std::pow(1.15f, steps), 1e-3f, 1e4f);
  const glm::vec2 after = screen_to_slice({x_px, y_px}, viewport_w_px, viewport_h_px);
  center_mm += before - after;
}

glm::vec2 SliceViewTransform::slice_to_screen(const glm::vec2& mm, float viewport_w_px,
                                              float viewport_h_px) const {
  return (mm - center_mm) * pixels_per_mm + 0.5f * glm::vec2(viewport_w_px, viewport_h_px);
}

glm::vec2 SliceViewTransform::screen_to_slice(const glm::vec2& px, float viewport_w_px,
                                              float viewport_h_px) const {
  return (px - 0.5f * glm::vec2(viewport_w_px, viewport_h_px)) / pixels_per_mm + center_mm;
}

glm::mat4 SliceViewTransform::projection(float viewport_w_px, float viewport_h_px) const {
  const float half_w = 0.5f * viewport_w_px / pixels_per_mm;
  const float half_h = 0.5f * viewport_h_px / pixels_per_mm;
  // v grows downwards on screen: bottom = centre + half height.
  return glm::ortho(center_mm.x - half_w, center_mm.x + half_w, center_mm.y + half_h,
                    center_mm.y - half_h, -1.0f, 1.0f);
}

}  // namespace cvt::render

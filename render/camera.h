// The two view transforms: an orbit camera for the 3D view and a zoom/pan transform for the 2D
// slice view. GL-free (GLM only), so mouse handling and fitting are unit tested.
#pragma once

#include <glm/glm.hpp>

namespace cvt::render {

// Orbits a target point with +z up (the slice axis k of most scans is head–foot).
class OrbitCamera {
 public:
  // Looks at the centre of the box [lo, hi] (world mm) from a distance that shows all of it
  // in a viewport of this aspect (width / height).
  void fit(const glm::vec3& lo, const glm::vec3& hi, float aspect = 1.0f);
  // Mouse drag in pixels: horizontal turns about +z, vertical tilts (clamped short of the poles).
  void orbit(float dx_px, float dy_px);
  // Mouse drag in pixels moves the target in the view plane; viewport_h_px scales it so the
  // point under the cursor follows the cursor at the target's depth.
  void pan(float dx_px, float dy_px, float viewport_h_px);
  // Wheel steps: positive comes closer (each step 12 %).
  void zoom(float steps);

  glm::mat4 view() const;
  glm::mat4 projection(float aspect) const;
  glm::vec3 eye() const;
  glm::vec3 forward() const;  // unit vector from the eye towards the target

  glm::vec3 target{0.0f};
  float distance = 1.0f;    // eye–target (mm)
  float yaw_deg = -70.0f;   // 0 looks along −x; −90 looks along +y (from the front of a scan)
  float pitch_deg = 25.0f;  // above the horizontal plane
  float fov_y_deg = 40.0f;
  float scene_radius = 1.0f;  // half the fitted box diagonal; sets the clipping range
};

// The 2D slice view: slice-plane millimetres (u to the right, v downwards, like image rows) to
// viewport pixels (origin top-left).
class SliceViewTransform {
 public:
  // Centres a width × height (mm) slice and scales it to fill 95 % of the viewport.
  void fit(float width_mm, float height_mm, float viewport_w_px, float viewport_h_px);
  void pan(float dx_px, float dy_px);
  // Wheel steps, keeping the slice point under (x_px, y_px) in place.
  void zoom_at(float steps, float x_px, float y_px, float viewport_w_px, float viewport_h_px);

  glm::vec2 slice_to_screen(const glm::vec2& mm, float viewport_w_px, float viewport_h_px) const;
  glm::vec2 screen_to_slice(const glm::vec2& px, float viewport_w_px, float viewport_h_px) const;
  // Orthographic projection taking slice mm (z = 0) to clip space.
  glm::mat4 projection(float viewport_w_px, float viewport_h_px) const;

  glm::vec2 center_mm{0.0f};
  float pixels_per_mm = 1.0f;
};

}  // namespace cvt::render

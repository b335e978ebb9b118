// A small 3-vector of doubles for positions and offsets in mm (core has no GL/GLM dependency).
#pragma once

#include <array>
#include <cmath>

namespace cvt {

struct Vec3 {
  double x = 0, y = 0, z = 0;

  double& operator[](int a) { return a == 0 ? x : (a == 1 ? y : z); }
  double operator[](int a) const { return a == 0 ? x : (a == 1 ? y : z); }
  Vec3 operator+(const Vec3& o) const { return {x + o.x, y + o.y, z + o.z}; }
  Vec3 operator-(const Vec3& o) const { return {x - o.x, y - o.y, z - o.z}; }
  Vec3 operator*(double s) const { return {x * s, y * s, z * s}; }
  Vec3 operator/(double s) const { return {x / s, y / s, z / s}; }
  Vec3& operator+=(const Vec3& o) { x += o.x; y += o.y; z += o.z; return *this; }
  Vec3& operator-=(const Vec3& o) { x -= o.x; y -= o.y; z -= o.z; return *this; }
  bool operator==(const Vec3& o) const { return x == o.x && y == o.y && z == o.z; }
};

inline Vec3 operator*(double s, const Vec3& v) { return v * s; }
inline double dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double squared_norm(const Vec3& v) { return dot(v, v); }
inline double norm(const Vec3& v) { return std::sqrt(dot(v, v)); }
inline double distance(const Vec3& a, const Vec3& b) { return norm(a - b); }
inline double squared_distance(const Vec3& a, const Vec3& b) { return squared_norm(a - b); }

}  // namespace cvt

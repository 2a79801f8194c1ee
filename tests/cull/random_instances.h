#pragma once
// Instances for the culling properties (tests/cull and tests/gpu): a rotation about Y with a
// per-axis scale, and a RapidCheck-drawn instance near `far` on x (0, 1e4 or 1e7 away, so
// large offsets stay in view when the camera follows).
#include <rapidcheck.h>

#include <cmath>
#include <cstdint>

#include "vgeo/core/math.h"
#include "vgeo/cull/cull.h"

namespace vgeo::test {

inline Mat4d make_transform(double tx, double ty, double tz, double angle, double sx, double sy, double sz) {
  Mat4d m;
  double c = std::cos(angle), s = std::sin(angle);
  // Rotation about Y, then per-axis scale.
  m.at(0, 0) = c * sx; m.at(0, 2) = s * sz;
  m.at(1, 1) = sy;
  m.at(2, 0) = -s * sx; m.at(2, 2) = c * sz;
  m.at(0, 3) = tx; m.at(1, 3) = ty; m.at(2, 3) = tz;
  return m;
}

// Only inside a RapidCheck property (draws with operator*).
inline CullInstance random_cull_instance(uint32_t mesh_count, double far) {
  CullInstance inst;
  inst.mesh = *rc::gen::inRange<uint32_t>(0, mesh_count);
  double scale = *rc::gen::element(1e-4, 0.5, 1.0, 2.0, 1e4);
  inst.object_to_world = make_transform(far + *rc::gen::inRange(-20, 20) * scale, *rc::gen::inRange(-20, 20) * scale,
                                        *rc::gen::inRange(-20, 20) * scale, *rc::gen::inRange(0, 8) * 0.7,
                                        scale, scale * *rc::gen::element(1.0, 0.5, 3.0), scale);
  return inst;
}

}  // namespace vgeo::test

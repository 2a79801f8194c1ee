#include "vgeo/shadow/light.h"

namespace vgeo {

const char* light_type_name(LightType type) {
  switch (type) {
    case LightType::kDirectional: return "directional";
    case LightType::kSpot: return "spot";
    case LightType::kPoint: return "point";
  }
  return "?";
}

bool has_shadowing_light(const std::vector<Light>& lights) {
  for (const Light& l : lights)
    if (l.shadows) return true;
  return false;
}

bool same_light(const Light& a, const Light& b) {
  return a.type == b.type && a.position.x == b.position.x && a.position.y == b.position.y &&
         a.position.z == b.position.z && a.direction.x == b.direction.x && a.direction.y == b.direction.y &&
         a.direction.z == b.direction.z && a.cone_radians == b.cone_radians && a.shadows == b.shadows &&
         a.color == b.color && a.intensity == b.intensity;
}

}  // namespace vgeo

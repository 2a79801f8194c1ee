#pragma once
// A scene light (normative: spec/shadow.md §1): what the shade step sums and what the virtual
// shadow maps are built for. Plain values, double where the spec computes in double.
#include <array>
#include <cstdint>
#include <vector>

#include "vgeo/cull/view.h"

namespace vgeo {

enum class LightType : uint8_t { kDirectional = 0, kSpot = 1, kPoint = 2 };
const char* light_type_name(LightType type);

struct Light {
  LightType type = LightType::kDirectional;
  Vec3d position;                  // spot, point
  Vec3d direction{0, -1, 0};       // directional, spot: where the light travels; unit length
  double cone_radians = 1.0471975511965976;  // spot: full apex angle (60° default)
  bool shadows = true;
  std::array<float, 3> color{1, 1, 1};
  float intensity = 1;
};

// True when some light casts shadows (the shadow steps run; spec/shadow.md §1).
bool has_shadowing_light(const std::vector<Light>& lights);
// Every field equal (bitwise on the doubles): an unchanged light keeps its cached pages.
bool same_light(const Light& a, const Light& b);

}  // namespace vgeo

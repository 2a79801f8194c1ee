// The scene file's lights (spec/shadow.md §1). Every bad field is one coded line; the JSON shape
// codes are those of every other scene field (spec/scene.md §Error codes), read by the scene
// file's field readers (scene_json.h) with SCENE_LIGHT_VALUE as the out-of-range code.
#include "vgeo/render/scene_lights.h"

#include <array>
#include <cmath>

#include "vgeo/core/error.h"
#include "vgeo/render/scene_json.h"

namespace vgeo {

namespace {

using scene_detail::bad;
using scene_detail::Ctx;
using scene_detail::kDegToRad;
using json = nlohmann::json;

// Ranges of spec/shadow.md §1: a cone wider than 179° has no finite perspective projection;
// colours and intensities beyond 1e6 only overflow float sums. Positions and directions keep the
// scene file's bound on every coordinate (get_vector's ±1e12).
constexpr double kMaxConeDegrees = 179.0, kDefaultConeDegrees = 60.0, kMaxColor = 1e6;
// A direction shorter than this cannot be normalized meaningfully.
constexpr double kMinDirectionLength = 1e-12;

LightType read_type(const Ctx& c, const json& obj, const std::string& path) {
  const std::string name = scene_detail::get_string(c, obj, path, "type", "", /*required=*/true);
  for (LightType t : {LightType::kDirectional, LightType::kSpot, LightType::kPoint})
    if (name == light_type_name(t)) return t;
  bad(c, "SCENE_LIGHT_TYPE", path + ".type: unknown light type '" + name + "' (directional, spot, point)");
}

// Whether a light of type t takes field `key` (spec/shadow.md §1's table): direction, position and
// cone_degrees only some types; every other light field all of them.
bool takes(LightType t, const std::string& key) {
  if (key == "direction") return t != LightType::kPoint;
  if (key == "position") return t != LightType::kDirectional;
  if (key == "cone_degrees") return t == LightType::kSpot;
  return true;
}

// A field the light's type does not take is an unknown field of that light.
void check_typed_fields(const Ctx& c, const json& obj, const std::string& path, LightType t) {
  for (auto it = obj.begin(); it != obj.end(); ++it)
    if (!takes(t, it.key()))
      bad(c, "SCENE_UNKNOWN_FIELD", path + "." + it.key() + ": unknown field for a " + light_type_name(t) + " light");
}

// obj[key], a required 3-vector.
std::array<double, 3> read_vec3(const Ctx& c, const json& obj, const std::string& path, const char* key) {
  scene_detail::require(c, obj, path, key);
  std::vector<double> v = scene_detail::get_vector(c, obj, path, key, 3);
  return {v[0], v[1], v[2]};
}

Vec3d read_direction(const Ctx& c, const json& obj, const std::string& path) {
  std::array<double, 3> d = read_vec3(c, obj, path, "direction");
  double len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  if (!(len > kMinDirectionLength)) bad(c, c.value_code, path + ".direction: zero length");
  return {d[0] / len, d[1] / len, d[2] / len};
}

Light read_light(const Ctx& c, const json& obj, const std::string& path) {
  scene_detail::check_keys(c, obj, path,
                           {"type", "direction", "position", "cone_degrees", "shadows", "color", "intensity"});
  Light light;
  light.type = read_type(c, obj, path);
  check_typed_fields(c, obj, path, light.type);
  if (takes(light.type, "direction")) light.direction = read_direction(c, obj, path);
  if (takes(light.type, "position")) {
    std::array<double, 3> p = read_vec3(c, obj, path, "position");
    light.position = {p[0], p[1], p[2]};
  }
  if (takes(light.type, "cone_degrees"))
    light.cone_radians = scene_detail::get_number(c, obj, path, "cone_degrees", kDefaultConeDegrees, 0,
                                                  kMaxConeDegrees, /*required=*/false, /*lo_open=*/true) *
                         kDegToRad;
  light.shadows = scene_detail::get_bool(c, obj, path, "shadows", light.shadows);
  if (obj.contains("color")) {
    std::vector<double> col = scene_detail::get_vector(c, obj, path, "color", 3);
    for (size_t k = 0; k < 3; ++k) {
      if (col[k] < 0 || col[k] > kMaxColor) bad(c, c.value_code, path + ".color: components in [0, 1e6]");
      light.color[k] = float(col[k]);
    }
  }
  light.intensity = float(scene_detail::get_number(c, obj, path, "intensity", light.intensity, 0, kMaxColor));
  return light;
}

}  // namespace

std::vector<Light> parse_scene_lights(const json& lights, const std::string& where) {
  // Lights name no files and take no load options: no base folder, no options.
  const Ctx c{where, "", nullptr, "SCENE_LIGHT_VALUE"};
  scene_detail::expect_array(c, lights, "lights", kMaxSceneLights);
  std::vector<Light> out;
  for (size_t i = 0; i < lights.size(); ++i) out.push_back(read_light(c, lights[i], "lights[" + std::to_string(i) + "]"));
  return out;
}

}  // namespace vgeo

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

// A move's frame: frames are numbered from 0 and a camera path has at most 100000 (spec/scene.md).
constexpr double kMaxMoveFrame = 100000;

SceneMove read_move(const Ctx& c, const json& obj, const std::string& path, const std::vector<Light>& lights,
                    size_t instance_count) {
  scene_detail::check_keys(c, obj, path, {"frame", "light", "instance", "position", "direction", "translation"});
  SceneMove m;
  const double frame = scene_detail::get_number(c, obj, path, "frame", 0, 0, kMaxMoveFrame, /*required=*/true);
  if (frame != std::floor(frame)) bad(c, "SCENE_BAD_MOVE", path + ".frame: an integer");
  m.frame = uint32_t(frame);
  if (obj.contains("light") == obj.contains("instance"))
    bad(c, "SCENE_BAD_MOVE", path + ": exactly one of light, instance");
  m.light = obj.contains("light");
  const size_t count = m.light ? lights.size() : instance_count;
  const char* key = m.light ? "light" : "instance";
  const double index = scene_detail::get_number(c, obj, path, key, 0, 0, 1e9, /*required=*/true);
  if (index != std::floor(index) || index >= double(count))
    bad(c, "SCENE_BAD_MOVE", path + "." + key + ": no " + key + " " + std::to_string(uint64_t(index)));
  m.index = uint32_t(index);
  if (!m.light) {
    for (const char* k : {"position", "direction"})
      if (obj.contains(k)) bad(c, "SCENE_BAD_MOVE", path + "." + k + ": an instance move takes translation only");
    std::array<double, 3> t = read_vec3(c, obj, path, "translation");
    m.translation = Vec3d{t[0], t[1], t[2]};
    return m;
  }
  if (obj.contains("translation")) bad(c, "SCENE_BAD_MOVE", path + ".translation: a light move takes position, direction");
  const LightType type = lights[m.index].type;
  for (const char* k : {"position", "direction"})
    if (obj.contains(k) && !takes(type, k))
      bad(c, "SCENE_BAD_MOVE", path + "." + k + ": not a field of a " + light_type_name(type) + " light");
  if (!obj.contains("position") && !obj.contains("direction"))
    bad(c, "SCENE_BAD_MOVE", path + ": a light move needs position or direction");
  if (obj.contains("position")) {
    std::array<double, 3> p = read_vec3(c, obj, path, "position");
    m.position = Vec3d{p[0], p[1], p[2]};
  }
  if (obj.contains("direction")) m.direction = read_direction(c, obj, path);
  return m;
}

}  // namespace

std::vector<SceneMove> parse_scene_moves(const json& moves, const std::string& where, const std::vector<Light>& lights,
                                         size_t instance_count) {
  // Every out-of-range value of a move (a frame, a zero direction, a coordinate beyond ±1e12)
  // is SCENE_BAD_MOVE, as every other bad move.
  const Ctx c{where, "", nullptr, "SCENE_BAD_MOVE"};
  scene_detail::expect_array(c, moves, "moves", kMaxSceneMoves);
  std::vector<SceneMove> out;
  for (size_t i = 0; i < moves.size(); ++i)
    out.push_back(read_move(c, moves[i], "moves[" + std::to_string(i) + "]", lights, instance_count));
  return out;
}

void apply_scene_moves(const std::vector<SceneMove>& moves, uint32_t frame, std::vector<Light>* lights,
                       std::vector<CullInstance>* instances) {
  for (const SceneMove& m : moves) {
    if (m.frame != frame) continue;
    if (m.light) {
      Light& l = (*lights)[m.index];
      if (m.position) l.position = *m.position;
      if (m.direction) l.direction = *m.direction;
    } else {
      Mat4d& t = (*instances)[m.index].object_to_world;
      t.at(0, 3) = m.translation->x;
      t.at(1, 3) = m.translation->y;
      t.at(2, 3) = m.translation->z;
    }
  }
}

std::vector<Light> parse_scene_lights(const json& lights, const std::string& where) {
  // Lights name no files and take no load options: no base folder, no options.
  const Ctx c{where, "", nullptr, "SCENE_LIGHT_VALUE"};
  scene_detail::expect_array(c, lights, "lights", kMaxSceneLights);
  std::vector<Light> out;
  for (size_t i = 0; i < lights.size(); ++i) out.push_back(read_light(c, lights[i], "lights[" + std::to_string(i) + "]"));
  return out;
}

}  // namespace vgeo

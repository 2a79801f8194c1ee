// The scene file's lights (spec/shadow.md §1). Every bad field is one coded line; the JSON shape
// codes are those of every other scene field (spec/scene.md §Error codes).
#include "vgeo/render/scene_lights.h"

#include <cmath>
#include <set>
#include <sstream>

#include "vgeo/core/error.h"

namespace vgeo {

namespace {

using json = nlohmann::json;
constexpr double kDegToRad = 3.14159265358979323846 / 180.0;
// Ranges of spec/shadow.md §1: a cone wider than 179° has no finite perspective projection;
// colours and intensities beyond 1e6 only overflow float sums; positions beyond 1e12 are the
// scene file's bound on every coordinate.
constexpr double kMaxConeDegrees = 179.0, kMaxColor = 1e6, kMaxCoordinate = 1e12;
// A direction shorter than this cannot be normalized meaningfully.
constexpr double kMinDirectionLength = 1e-12;

struct LightCtx {
  const std::string& where;
  std::string path;
  [[noreturn]] void bad(const std::string& code, const std::string& what) const { fail(code, where, path + what); }
};

void check_light_keys(const LightCtx& c, const json& obj, const std::set<std::string>& allowed) {
  for (auto it = obj.begin(); it != obj.end(); ++it)
    if (!allowed.count(it.key()))
      c.bad("SCENE_UNKNOWN_FIELD", "." + it.key() + ": unknown field for a " + obj["type"].get<std::string>() + " light");
}

const json& required(const LightCtx& c, const json& obj, const char* key) {
  const auto it = obj.find(key);
  if (it == obj.end()) c.bad("SCENE_MISSING_FIELD", std::string(".") + key + ": required");
  return *it;
}

std::array<double, 3> read_vec3(const LightCtx& c, const json& v, const char* key) {
  if (!v.is_array() || v.size() != 3) c.bad("SCENE_FIELD_TYPE", std::string(".") + key + ": expected an array of 3 numbers");
  std::array<double, 3> out{};
  for (size_t k = 0; k < 3; ++k) {
    if (!v[k].is_number()) c.bad("SCENE_FIELD_TYPE", std::string(".") + key + ": expected numbers");
    out[k] = v[k].get<double>();
    if (!std::isfinite(out[k]) || std::abs(out[k]) > kMaxCoordinate)
      c.bad("SCENE_LIGHT_VALUE", std::string(".") + key + ": value not finite or beyond ±1e12");
  }
  return out;
}

double read_number(const LightCtx& c, const json& obj, const char* key, double def, double lo, double hi,
                   bool lo_open) {
  const auto it = obj.find(key);
  if (it == obj.end()) return def;
  if (!it->is_number()) c.bad("SCENE_FIELD_TYPE", std::string(".") + key + ": expected a number");
  double d = it->get<double>();
  if (!std::isfinite(d) || d < lo || (lo_open && d == lo) || d > hi) {
    std::ostringstream s;
    s << "." << key << ": " << d << " outside " << (lo_open ? "(" : "[") << lo << ", " << hi << "]";
    c.bad("SCENE_LIGHT_VALUE", s.str());
  }
  return d;
}

Vec3d read_direction(const LightCtx& c, const json& obj) {
  std::array<double, 3> d = read_vec3(c, required(c, obj, "direction"), "direction");
  double len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  if (!(len > kMinDirectionLength)) c.bad("SCENE_LIGHT_VALUE", ".direction: zero length");
  return {d[0] / len, d[1] / len, d[2] / len};
}

LightType read_type(const LightCtx& c, const json& obj) {
  const json& t = required(c, obj, "type");
  if (!t.is_string()) c.bad("SCENE_FIELD_TYPE", ".type: expected a string");
  const std::string name = t.get<std::string>();
  if (name == "directional") return LightType::kDirectional;
  if (name == "spot") return LightType::kSpot;
  if (name == "point") return LightType::kPoint;
  c.bad("SCENE_LIGHT_TYPE", ".type: unknown light type '" + name + "' (directional, spot, point)");
}

Light read_light(const LightCtx& c, const json& obj) {
  if (!obj.is_object()) c.bad("SCENE_FIELD_TYPE", ": expected an object");
  Light light;
  light.type = read_type(c, obj);
  std::set<std::string> allowed{"type", "shadows", "color", "intensity"};
  if (light.type != LightType::kPoint) allowed.insert("direction");
  if (light.type != LightType::kDirectional) allowed.insert("position");
  if (light.type == LightType::kSpot) allowed.insert("cone_degrees");
  check_light_keys(c, obj, allowed);
  if (light.type != LightType::kPoint) light.direction = read_direction(c, obj);
  if (light.type != LightType::kDirectional) {
    std::array<double, 3> p = read_vec3(c, required(c, obj, "position"), "position");
    light.position = {p[0], p[1], p[2]};
  }
  if (light.type == LightType::kSpot)
    light.cone_radians = read_number(c, obj, "cone_degrees", 60, 0, kMaxConeDegrees, true) * kDegToRad;
  if (const auto it = obj.find("shadows"); it != obj.end()) {
    if (!it->is_boolean()) c.bad("SCENE_FIELD_TYPE", ".shadows: expected true/false");
    light.shadows = it->get<bool>();
  }
  if (const auto it = obj.find("color"); it != obj.end()) {
    std::array<double, 3> col = read_vec3(c, *it, "color");
    for (size_t k = 0; k < 3; ++k) {
      if (col[k] < 0 || col[k] > kMaxColor) c.bad("SCENE_LIGHT_VALUE", ".color: components in [0, 1e6]");
      light.color[k] = float(col[k]);
    }
  }
  light.intensity = float(read_number(c, obj, "intensity", 1, 0, kMaxColor, false));
  return light;
}

}  // namespace

std::vector<Light> parse_scene_lights(const json& lights, const std::string& where) {
  if (!lights.is_array()) fail("SCENE_FIELD_TYPE", where, "lights: expected an array");
  if (lights.size() > kMaxSceneLights)
    fail("SCENE_TOO_LARGE", where, "lights: more than " + std::to_string(kMaxSceneLights) + " entries");
  std::vector<Light> out;
  for (size_t i = 0; i < lights.size(); ++i)
    out.push_back(read_light(LightCtx{where, "lights[" + std::to_string(i) + "]"}, lights[i]));
  return out;
}

}  // namespace vgeo

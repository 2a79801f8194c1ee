// Scene lights (spec/shadow.md §1): every field read as specified; every bad field one coded error.
#include <gtest/gtest.h>

#include <cmath>

#include "vgeo/core/error.h"
#include "vgeo/render/scene_lights.h"

namespace vgeo {
namespace {

std::string code_of(const std::string& lights) {
  try {
    parse_scene_lights(nlohmann::json::parse(lights), "<test>");
  } catch (const VgeoError& e) {
    EXPECT_EQ(e.error().line().find('\n'), std::string::npos);
    return e.error().code;
  }
  return "";
}

TEST(SceneLights, FieldsAreReadNormalizedAndDefaulted) {
  auto lights = parse_scene_lights(nlohmann::json::parse(R"([
      {"type": "directional", "direction": [0, -2, 0]},
      {"type": "spot", "position": [1, 2, 3], "direction": [1, 0, 0], "cone_degrees": 90, "shadows": false,
       "color": [1, 0.5, 0], "intensity": 3},
      {"type": "point", "position": [0, 1, 0]}])"), "<test>");
  ASSERT_EQ(lights.size(), 3u);
  EXPECT_EQ(lights[0].type, LightType::kDirectional);
  EXPECT_EQ(lights[0].direction.y, -1.0);
  EXPECT_TRUE(lights[0].shadows);
  EXPECT_EQ(lights[0].intensity, 1.0f);
  EXPECT_EQ(lights[1].type, LightType::kSpot);
  EXPECT_NEAR(lights[1].cone_radians, M_PI / 2, 1e-15);
  EXPECT_FALSE(lights[1].shadows);
  EXPECT_EQ(lights[1].color[1], 0.5f);
  EXPECT_EQ(lights[1].intensity, 3.0f);
  EXPECT_EQ(lights[2].type, LightType::kPoint);
  EXPECT_EQ(lights[2].position.y, 1.0);
  EXPECT_TRUE(has_shadowing_light(lights));
  EXPECT_FALSE(has_shadowing_light({lights[1]}));
}

TEST(SceneLights, BadFieldsFailWithStableCodes) {
  struct Case {
    const char* lights;
    const char* code;
  };
  const Case cases[] = {
      {R"({})", "SCENE_FIELD_TYPE"},
      {R"([1])", "SCENE_FIELD_TYPE"},
      {R"([{}])", "SCENE_MISSING_FIELD"},
      {R"([{"type": 1}])", "SCENE_FIELD_TYPE"},
      {R"([{"type": "area"}])", "SCENE_LIGHT_TYPE"},
      {R"([{"type": "directional"}])", "SCENE_MISSING_FIELD"},
      {R"([{"type": "directional", "direction": [0, 0, 0]}])", "SCENE_LIGHT_VALUE"},
      {R"([{"type": "directional", "direction": [0, -1]}])", "SCENE_FIELD_TYPE"},
      {R"([{"type": "directional", "direction": [0, "a", 1]}])", "SCENE_FIELD_TYPE"},
      {R"([{"type": "directional", "direction": [0, 1e300, 1]}])", "SCENE_LIGHT_VALUE"},
      {R"([{"type": "directional", "direction": [0, -1, 0], "position": [0, 0, 0]}])", "SCENE_UNKNOWN_FIELD"},
      {R"([{"type": "directional", "direction": [0, -1, 0], "colour": [1, 1, 1]}])", "SCENE_UNKNOWN_FIELD"},
      {R"([{"type": "directional", "direction": [0, -1, 0], "cone_degrees": 30}])", "SCENE_UNKNOWN_FIELD"},
      {R"([{"type": "directional", "direction": [0, -1, 0], "shadows": 1}])", "SCENE_FIELD_TYPE"},
      {R"([{"type": "directional", "direction": [0, -1, 0], "color": [1, -1, 1]}])", "SCENE_LIGHT_VALUE"},
      {R"([{"type": "directional", "direction": [0, -1, 0], "intensity": -1}])", "SCENE_LIGHT_VALUE"},
      {R"([{"type": "directional", "direction": [0, -1, 0], "intensity": "1"}])", "SCENE_FIELD_TYPE"},
      {R"([{"type": "point"}])", "SCENE_MISSING_FIELD"},
      {R"([{"type": "point", "position": [0, 0, 0], "direction": [0, -1, 0]}])", "SCENE_UNKNOWN_FIELD"},
      {R"([{"type": "point", "position": [0, 0, 2e12]}])", "SCENE_LIGHT_VALUE"},
      {R"([{"type": "spot", "position": [0, 0, 0]}])", "SCENE_MISSING_FIELD"},
      {R"([{"type": "spot", "direction": [0, -1, 0]}])", "SCENE_MISSING_FIELD"},
      {R"([{"type": "spot", "position": [0, 0, 0], "direction": [0, -1, 0], "cone_degrees": 0}])", "SCENE_LIGHT_VALUE"},
      {R"([{"type": "spot", "position": [0, 0, 0], "direction": [0, -1, 0], "cone_degrees": 180}])", "SCENE_LIGHT_VALUE"},
      // Every other field and range of spec/shadow.md §1, one case each side of each bound.
      {R"(["directional"])", "SCENE_FIELD_TYPE"},
      {R"([{"type": "Directional", "direction": [0, -1, 0]}])", "SCENE_LIGHT_TYPE"},
      {R"([{"type": "", "direction": [0, -1, 0]}])", "SCENE_LIGHT_TYPE"},
      {R"([{"type": "directional", "direction": [1e-13, 0, 0]}])", "SCENE_LIGHT_VALUE"},
      {R"([{"type": "directional", "direction": [1e-6, 0, 0]}])", ""},
      {R"([{"type": "directional", "direction": "down"}])", "SCENE_FIELD_TYPE"},
      {R"([{"type": "directional", "direction": [0, -1, 0, 0]}])", "SCENE_FIELD_TYPE"},
      {R"([{"type": "directional", "direction": [0, -1, 0], "shadows": "yes"}])", "SCENE_FIELD_TYPE"},
      {R"([{"type": "directional", "direction": [0, -1, 0], "color": [1, 1]}])", "SCENE_FIELD_TYPE"},
      {R"([{"type": "directional", "direction": [0, -1, 0], "color": 1}])", "SCENE_FIELD_TYPE"},
      {R"([{"type": "directional", "direction": [0, -1, 0], "color": [1, 2e6, 1]}])", "SCENE_LIGHT_VALUE"},
      {R"([{"type": "directional", "direction": [0, -1, 0], "color": [0, 1e6, 0]}])", ""},
      {R"([{"type": "directional", "direction": [0, -1, 0], "intensity": 2e6}])", "SCENE_LIGHT_VALUE"},
      {R"([{"type": "directional", "direction": [0, -1, 0], "intensity": 0}])", ""},
      {R"([{"type": "point", "position": "origin"}])", "SCENE_FIELD_TYPE"},
      {R"([{"type": "point", "position": [0, 0]}])", "SCENE_FIELD_TYPE"},
      {R"([{"type": "point", "position": [0, -1e300, 0]}])", "SCENE_LIGHT_VALUE"},
      {R"([{"type": "point", "position": [1e12, -1e12, 0]}])", ""},
      {R"([{"type": "point", "position": [0, 0, 0], "cone_degrees": 60}])", "SCENE_UNKNOWN_FIELD"},
      {R"([{"type": "spot", "position": [0, 0, 0], "direction": [0, -1, 0], "cone_degrees": 179.5}])", "SCENE_LIGHT_VALUE"},
      {R"([{"type": "spot", "position": [0, 0, 0], "direction": [0, -1, 0], "cone_degrees": 179}])", ""},
      {R"([{"type": "spot", "position": [0, 0, 0], "direction": [0, -1, 0], "cone_degrees": -10}])", "SCENE_LIGHT_VALUE"},
      {R"([{"type": "spot", "position": [0, 0, 0], "direction": [0, -1, 0], "cone_degrees": "60"}])", "SCENE_FIELD_TYPE"},
      {R"([{"type": "spot", "position": [0, 0, 0], "direction": [0, 0, 0]}])", "SCENE_LIGHT_VALUE"},
  };
  for (const Case& c : cases) EXPECT_EQ(code_of(c.lights), c.code) << c.lights;
  std::string many = "[";
  for (size_t i = 0; i <= kMaxSceneLights; ++i)
    many += std::string(i ? "," : "") + R"({"type": "directional", "direction": [0, -1, 0]})";
  EXPECT_EQ(code_of(many + "]"), "SCENE_TOO_LARGE");
  EXPECT_EQ(code_of("[]"), "");
}

// spec/scene.md §Moves: a light's or an instance's new fields at a frame, applied in file order
// and kept; every bad move one coded error.
std::string move_code(const std::string& moves) {
  const auto lights = parse_scene_lights(nlohmann::json::parse(R"([
      {"type": "directional", "direction": [0, -1, 0]}, {"type": "point", "position": [0, 1, 0]}])"), "<test>");
  try {
    parse_scene_moves(nlohmann::json::parse(moves), "<test>", lights, 2);
  } catch (const VgeoError& e) {
    EXPECT_EQ(e.error().line().find('\n'), std::string::npos);
    return e.error().code;
  }
  return "";
}

TEST(SceneMoves, MovesApplyAtTheirFrameAndStay) {
  std::vector<Light> lights = parse_scene_lights(nlohmann::json::parse(R"([
      {"type": "directional", "direction": [0, -1, 0]}, {"type": "point", "position": [0, 1, 0]}])"), "<test>");
  std::vector<CullInstance> instances(2);
  const auto moves = parse_scene_moves(nlohmann::json::parse(R"([
      {"frame": 2, "light": 0, "direction": [0, 0, -3]}, {"frame": 2, "light": 1, "position": [1, 2, 3]},
      {"frame": 1, "instance": 1, "translation": [4, 5, 6]}])"), "<test>", lights, 2);
  apply_scene_moves(moves, 0, &lights, &instances);
  EXPECT_EQ(lights[0].direction.y, -1.0);
  EXPECT_EQ(instances[1].object_to_world.at(0, 3), 0.0);
  apply_scene_moves(moves, 1, &lights, &instances);
  EXPECT_EQ(instances[1].object_to_world.at(0, 3), 4.0);
  EXPECT_EQ(instances[1].object_to_world.at(2, 3), 6.0);
  EXPECT_EQ(instances[1].object_to_world.at(0, 0), 1.0);  // only the translation changes
  apply_scene_moves(moves, 2, &lights, &instances);
  EXPECT_EQ(lights[0].direction.z, -1.0);  // normalized
  EXPECT_EQ(lights[1].position.z, 3.0);
  EXPECT_EQ(instances[1].object_to_world.at(1, 3), 5.0);  // kept
}

TEST(SceneMoves, BadMovesFailWithStableCodes) {
  struct Case {
    const char* moves;
    const char* code;
  };
  const Case cases[] = {
      {R"({})", "SCENE_FIELD_TYPE"},
      {R"([{"light": 0, "direction": [0, -1, 0]}])", "SCENE_MISSING_FIELD"},
      {R"([{"frame": 1.5, "light": 0, "direction": [0, -1, 0]}])", "SCENE_BAD_MOVE"},
      {R"([{"frame": -1, "light": 0, "direction": [0, -1, 0]}])", "SCENE_BAD_MOVE"},
      {R"([{"frame": 100001, "light": 0, "direction": [0, -1, 0]}])", "SCENE_BAD_MOVE"},
      {R"([{"frame": 1, "direction": [0, -1, 0]}])", "SCENE_BAD_MOVE"},
      {R"([{"frame": 1, "light": 0, "instance": 0, "direction": [0, -1, 0]}])", "SCENE_BAD_MOVE"},
      {R"([{"frame": 1, "light": 2, "direction": [0, -1, 0]}])", "SCENE_BAD_MOVE"},
      {R"([{"frame": 1, "instance": 2, "translation": [0, 0, 0]}])", "SCENE_BAD_MOVE"},
      {R"([{"frame": 1, "light": 0, "position": [0, 0, 0]}])", "SCENE_BAD_MOVE"},
      {R"([{"frame": 1, "light": 1, "direction": [0, -1, 0]}])", "SCENE_BAD_MOVE"},
      {R"([{"frame": 1, "light": 0}])", "SCENE_BAD_MOVE"},
      {R"([{"frame": 1, "light": 0, "direction": [0, 0, 0]}])", "SCENE_BAD_MOVE"},
      {R"([{"frame": 1, "instance": 0, "translation": [0, 0, 2e12]}])", "SCENE_BAD_MOVE"},
      {R"([{"frame": 1, "light": 0, "translation": [0, 0, 0]}])", "SCENE_BAD_MOVE"},
      {R"([{"frame": 1, "instance": 0}])", "SCENE_MISSING_FIELD"},
      {R"([{"frame": 1, "instance": 0, "position": [0, 0, 0], "translation": [0, 0, 0]}])", "SCENE_BAD_MOVE"},
      {R"([{"frame": 1, "instance": 0, "translation": [0, 0]}])", "SCENE_FIELD_TYPE"},
      {R"([{"frame": 1, "instance": 0, "translation": [0, 0, 0], "speed": 1}])", "SCENE_UNKNOWN_FIELD"},
  };
  for (const Case& c : cases) EXPECT_EQ(move_code(c.moves), c.code) << c.moves;
  EXPECT_EQ(move_code("[]"), "");
}

}  // namespace
}  // namespace vgeo

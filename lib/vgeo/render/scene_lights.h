#pragma once
// The scene file's "lights" array (normative: spec/shadow.md §1, error codes spec/errors.md):
// read and validated here, apart from the rest of the scene file, so the JSON reader stays small.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "vgeo/cull/cull.h"
#include "vgeo/shadow/light.h"

namespace vgeo {

// Bound on the lights of one scene (each shadowing point light is six shadow maps).
inline constexpr size_t kMaxSceneLights = 256;

// Parses `lights` (the value of the scene's "lights" member). Throws VgeoError with
// SCENE_FIELD_TYPE, SCENE_UNKNOWN_FIELD, SCENE_MISSING_FIELD, SCENE_TOO_LARGE, SCENE_LIGHT_TYPE or
// SCENE_LIGHT_VALUE; `where` is the scene file named in the error line.
std::vector<Light> parse_scene_lights(const nlohmann::json& lights, const std::string& where);

// The scene file's "moves" (spec/scene.md §Moves): a light or an instance changed at the start
// of a frame and kept so afterwards, so that one scene file shows a moving light or a moving
// caster (the shadow cache's invalidation, spec/shadow.md §5) on every backend alike.
inline constexpr size_t kMaxSceneMoves = 4096;
struct SceneMove {
  uint32_t frame = 0;
  bool light = false;    // true: lights[index]; false: instances[index]
  uint32_t index = 0;
  std::optional<Vec3d> position, direction;  // a light's new fields (direction normalized)
  std::optional<Vec3d> translation;          // an instance's new translation (its matrix's column 3)
};
// Parses `moves` against the scene's lights and instance count. Throws VgeoError with the scene
// field codes or SCENE_BAD_MOVE (a missing light or instance, not exactly one of light/instance,
// a field the move's kind or light type does not take, a light move without a field, a value
// out of range: a frame outside [0, 100000] or not an integer, a zero direction).
std::vector<SceneMove> parse_scene_moves(const nlohmann::json& moves, const std::string& where,
                                         const std::vector<Light>& lights, size_t instance_count);
// Applies the moves of `frame` (in file order) to `scene`.
void apply_scene_moves(const std::vector<SceneMove>& moves, uint32_t frame, std::vector<Light>* lights,
                       std::vector<CullInstance>* instances);

}  // namespace vgeo

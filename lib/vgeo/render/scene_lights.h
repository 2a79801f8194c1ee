#pragma once
// The scene file's "lights" array (normative: spec/shadow.md §1, error codes spec/errors.md):
// read and validated here, apart from the rest of the scene file, so the JSON reader stays small.
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "vgeo/shadow/light.h"

namespace vgeo {

// Bound on the lights of one scene (each shadowing point light is six shadow maps).
inline constexpr size_t kMaxSceneLights = 256;

// Parses `lights` (the value of the scene's "lights" member). Throws VgeoError with
// SCENE_FIELD_TYPE, SCENE_UNKNOWN_FIELD, SCENE_MISSING_FIELD, SCENE_TOO_LARGE, SCENE_LIGHT_TYPE or
// SCENE_LIGHT_VALUE; `where` is the scene file named in the error line.
std::vector<Light> parse_scene_lights(const nlohmann::json& lights, const std::string& where);

}  // namespace vgeo

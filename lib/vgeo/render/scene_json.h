#pragma once
// The scene file's JSON field readers (spec/scene.md): each reads one field, checks its type and
// range and fails with the SCENE_* code of spec/errors.md. Internal to lib/vgeo/render: shared by
// the scene reader (scene_file.cpp), the mesh loader (scene_meshes.cpp) and the lights
// (scene_lights.cpp); not a public API.
#include <cstddef>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "vgeo/render/scene_file.h"

namespace vgeo::scene_detail {

using json = nlohmann::json;

// Limits on untrusted list sizes (memory bound before anything is generated).
inline constexpr size_t kMaxSceneMeshes = 4096, kMaxSceneInstances = 1u << 20, kMaxSceneMaterials = 1u << 16,
                        kMaxSceneCameras = 1024, kMaxKeyframes = 10000;
// The scene file gives angles (a camera's fov_y_degrees, a spot light's cone_degrees) in degrees.
inline constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

// Where a scene is read from: the file (error location), the folder its relative paths start
// at, the load's options, and the code of a value out of its range in the part being read
// (SCENE_BAD_VALUE; a light's fields are SCENE_LIGHT_VALUE, spec/errors.md).
struct Ctx {
  std::string where;
  std::string base_dir;
  const SceneLoadOptions* options;
  const char* value_code = "SCENE_BAD_VALUE";
};

// Throws VgeoError `code` at c.where.
[[noreturn]] void bad(const Ctx& c, const std::string& code, const std::string& what);
// `obj` is an object whose keys are all in `allowed`.
void check_keys(const Ctx& c, const json& obj, const std::string& path, std::initializer_list<const char*> allowed);
// obj has `key` (SCENE_MISSING_FIELD otherwise).
void require(const Ctx& c, const json& obj, const std::string& path, const char* key);
// obj[key], a finite number in [lo, hi] (in (lo, hi] when `lo_open`); `def` when absent (unless
// required). Out of range: c.value_code.
double get_number(const Ctx& c, const json& obj, const std::string& path, const char* key, double def,
                  double lo, double hi, bool required = false, bool lo_open = false);
bool get_bool(const Ctx& c, const json& obj, const std::string& path, const char* key, bool def);
std::string get_string(const Ctx& c, const json& obj, const std::string& path, const char* key,
                       const std::string& def, bool required = false);
// obj[key], an array of exactly n numbers (SCENE_FIELD_TYPE otherwise, also when absent), each
// finite and of magnitude at most `limit` (c.value_code otherwise).
std::vector<double> get_vector(const Ctx& c, const json& obj, const std::string& path, const char* key, size_t n,
                               double limit = 1e12);
// obj[key], an array of at most `max` entries.
const json& get_array(const Ctx& c, const json& obj, const std::string& path, const char* key, size_t max);
// `v` (named `name` in errors), an array of at most `max` entries.
const json& expect_array(const Ctx& c, const json& v, const std::string& name, size_t max);

}  // namespace vgeo::scene_detail

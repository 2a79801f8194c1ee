// Reading render scenes: the JSON scene file (spec/scene.md) — materials, settings, cameras and
// the camera path, instances — and the embedded default scene. The `meshes` list is loaded by
// scene_meshes.cpp; the field readers are scene_json.cpp's.
#include "vgeo/render/scene_file.h"
#include "vgeo/render/scene_lights.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>

#include "vgeo/core/file_io.h"
#include "vgeo/mesh/generate.h"
#include "vgeo/render/scene_json.h"
#include "vgeo/render/scene_meshes.h"

namespace vgeo {

namespace {

using namespace scene_detail;

// Default scene sizes: ~130k triangles per mesh builds in about a second and still shows
// several LOD levels across the view; the ground's scale is 20 x 1.6 x 20 of the [-1,1]^2 terrain.
constexpr uint64_t kDefaultSceneSphereTriangles = 131072, kDefaultSceneGroundTriangles = 131072;
constexpr double kDefaultGroundHalfSize = 20.0, kDefaultGroundHeightScale = 1.6;
// Terrain seed whose holes all lie far behind the spheres (seeds 1, 2 put one in the foreground).
constexpr uint64_t kDefaultGroundSeed = 3;

// ---- transforms and cameras ----

Mat4d instance_matrix(const Ctx& c, const json& inst, const std::string& path) {
  Mat4d m;
  if (inst.contains("matrix")) {
    if (inst.contains("translation") || inst.contains("rotation") || inst.contains("scale"))
      bad(c, "SCENE_BAD_TRANSFORM", path + ": matrix excludes translation/rotation/scale");
    std::vector<double> v = get_vector(c, inst, path, "matrix", 16);
    for (int i = 0; i < 16; ++i) m.m[i] = v[i];
    if (m.at(3, 0) != 0 || m.at(3, 1) != 0 || m.at(3, 2) != 0 || m.at(3, 3) != 1)
      bad(c, "SCENE_BAD_TRANSFORM", path + ".matrix: not affine (last row must be 0 0 0 1)");
  } else {
    std::vector<double> t = inst.contains("translation") ? get_vector(c, inst, path, "translation", 3) : std::vector<double>{0, 0, 0};
    std::vector<double> q = inst.contains("rotation") ? get_vector(c, inst, path, "rotation", 4) : std::vector<double>{0, 0, 0, 1};
    std::vector<double> s{1, 1, 1};
    if (inst.contains("scale")) {
      if (inst["scale"].is_number()) s.assign(3, get_number(c, inst, path, "scale", 1, -1e12, 1e12));
      else s = get_vector(c, inst, path, "scale", 3);
    }
    double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (!(n > 1e-12)) bad(c, "SCENE_BAD_TRANSFORM", path + ".rotation: zero quaternion");
    double x = q[0] / n, y = q[1] / n, z = q[2] / n, w = q[3] / n;
    double r[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
                      {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
                      {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)}};
    for (int row = 0; row < 3; ++row) {
      for (int col = 0; col < 3; ++col) m.at(row, col) = r[row][col] * s[col];
      m.at(row, 3) = t[row];
    }
  }
  double det = m.at(0, 0) * (m.at(1, 1) * m.at(2, 2) - m.at(1, 2) * m.at(2, 1)) -
               m.at(0, 1) * (m.at(1, 0) * m.at(2, 2) - m.at(1, 2) * m.at(2, 0)) +
               m.at(0, 2) * (m.at(1, 0) * m.at(2, 1) - m.at(1, 1) * m.at(2, 0));
  double s = max_axis_scale(m);
  // A (near-)singular matrix flattens the mesh: its normals and LOD bounds are meaningless.
  if (!(s > 0) || !(std::abs(det) > 1e-12 * s * s * s) || !std::isfinite(det))
    bad(c, "SCENE_BAD_TRANSFORM", path + ": singular transform");
  return m;
}

struct Pose {
  Vec3d position;
  std::array<double, 4> orientation{0, 0, 0, 1};
};

Pose read_pose(const Ctx& c, const json& j, const std::string& path) {
  Pose p;
  require(c, j, path, "position");
  auto pos = get_vector(c, j, path, "position", 3);
  p.position = {pos[0], pos[1], pos[2]};
  if (j.contains("look_at") == j.contains("orientation"))
    bad(c, "SCENE_BAD_CAMERA", path + ": exactly one of look_at, orientation");
  if (j.contains("look_at")) {
    auto t = get_vector(c, j, path, "look_at", 3);
    std::vector<double> up = j.contains("up") ? get_vector(c, j, path, "up", 3) : std::vector<double>{0, 1, 0};
    if (!look_at_orientation(p.position, {t[0], t[1], t[2]}, {up[0], up[1], up[2]}, &p.orientation))
      bad(c, "SCENE_BAD_CAMERA", path + ": look_at equals position or is parallel to up");
  } else {
    auto q = get_vector(c, j, path, "orientation", 4);
    double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (!(n > 1e-12)) bad(c, "SCENE_BAD_CAMERA", path + ".orientation: zero quaternion");
    p.orientation = {q[0] / n, q[1] / n, q[2] / n, q[3] / n};
  }
  return p;
}

Camera read_camera(const Ctx& c, const json& j, const std::string& path) {
  check_keys(c, j, path, {"name", "position", "look_at", "up", "orientation", "fov_y_degrees", "resolution", "z_near"});
  Camera cam;
  Pose p = read_pose(c, j, path);
  cam.position = p.position;
  cam.orientation = p.orientation;
  cam.fov_y = get_number(c, j, path, "fov_y_degrees", 60, 1e-3, 179) * kDegToRad;
  if (j.contains("resolution")) {
    auto r = get_vector(c, j, path, "resolution", 2);
    if (r[0] < 1 || r[1] < 1 || r[0] > kMaxResolution || r[1] > kMaxResolution || r[0] != std::floor(r[0]) ||
        r[1] != std::floor(r[1]))
      bad(c, "SCENE_BAD_CAMERA", path + ".resolution: integers in [1, " + std::to_string(kMaxResolution) + "]");
    cam.width = uint32_t(r[0]);
    cam.height = uint32_t(r[1]);
  }
  cam.z_near = get_number(c, j, path, "z_near", 0.01, 1e-9, 1e9);
  return cam;
}

std::vector<Camera> expand_path(const Ctx& c, const json& j, const Camera& base) {
  const std::string path = "camera_path";
  check_keys(c, j, path, {"frames", "keyframes"});
  uint32_t frames = uint32_t(get_number(c, j, path, "frames", 0, 1, kMaxPathFrames, true));
  const json& keys = get_array(c, j, path + ".", "keyframes", kMaxKeyframes);
  if (keys.empty()) bad(c, "SCENE_BAD_CAMERA", path + ".keyframes: at least one keyframe");
  std::vector<Pose> poses;
  for (size_t i = 0; i < keys.size(); ++i) {
    std::string kp = path + ".keyframes[" + std::to_string(i) + "]";
    check_keys(c, keys[i], kp, {"position", "look_at", "up", "orientation"});
    poses.push_back(read_pose(c, keys[i], kp));
  }
  std::vector<Camera> out;
  for (uint32_t f = 0; f < frames; ++f) {
    // Keyframes evenly spaced over the frames; position lerp, orientation nlerp (shortest arc).
    double t = frames > 1 ? double(f) / (frames - 1) * double(poses.size() - 1) : 0.0;
    size_t k = std::min(size_t(t), poses.size() - 1);
    size_t k1 = std::min(k + 1, poses.size() - 1);
    double a = t - double(k);
    const Pose &p0 = poses[k], &p1 = poses[k1];
    Camera cam = base;
    cam.position = {p0.position.x + (p1.position.x - p0.position.x) * a, p0.position.y + (p1.position.y - p0.position.y) * a,
                    p0.position.z + (p1.position.z - p0.position.z) * a};
    double d = 0;
    for (int i = 0; i < 4; ++i) d += p0.orientation[i] * p1.orientation[i];
    double sign = d < 0 ? -1 : 1, n = 0;
    std::array<double, 4> q;
    for (int i = 0; i < 4; ++i) {
      q[i] = p0.orientation[i] * (1 - a) + sign * p1.orientation[i] * a;
      n += q[i] * q[i];
    }
    n = std::sqrt(n);
    for (int i = 0; i < 4; ++i) q[i] = n > 0 ? q[i] / n : p0.orientation[i];
    cam.orientation = q;
    out.push_back(cam);
  }
  return out;
}

}  // namespace

std::string SceneFile::stream_note() const {
  return std::string("streaming: ") + (streaming ? "on" : "off") + " (" + stream_reason + ")";
}

SceneFile parse_scene_json(const std::string& text, const std::string& where, const std::string& base_dir,
                           const SceneLoadOptions& options) {
  Ctx c{where, base_dir, &options};
  json doc = json::parse(text, nullptr, false);
  if (doc.is_discarded()) bad(c, "SCENE_JSON_PARSE", "not valid JSON");
  check_keys(c, doc, "scene", {"version", "materials", "meshes", "instances", "cameras", "camera_path", "settings", "lights",
                                 "moves"});
  int version = int(get_number(c, doc, "scene", "version", 0, -1e9, 1e9, true));
  if (version != kSceneFileVersion)
    bad(c, "SCENE_VERSION", "version " + std::to_string(version) + " unsupported (expected " + std::to_string(kSceneFileVersion) + ")");
  for (const char* key : {"meshes", "instances", "cameras"})
    require(c, doc, "scene", key);

  SceneFile out;
  if (doc.contains("materials")) {
    const json& mats = get_array(c, doc, "", "materials", kMaxSceneMaterials);
    for (size_t i = 0; i < mats.size(); ++i) {
      std::string path = "materials[" + std::to_string(i) + "]";
      check_keys(c, mats[i], path, {"name", "base_color"});
      Material m;
      m.name = get_string(c, mats[i], path, "name", "");
      if (mats[i].contains("base_color")) {
        auto col = get_vector(c, mats[i], path, "base_color", 4);
        for (int k = 0; k < 4; ++k) {
          if (col[k] < 0 || col[k] > 1) bad(c, "SCENE_BAD_VALUE", path + ".base_color: components in [0, 1]");
          m.base_color[k] = float(col[k]);
        }
      }
      out.scene.materials.push_back(m);
    }
  }
  if (out.scene.materials.empty()) out.scene.materials.push_back(Material{"default", {0.8f, 0.8f, 0.8f, 1.0f}});

  // Settings and cameras first: cheap, so malformed files fail before any mesh is built.
  if (doc.contains("settings")) {
    const json& s = doc["settings"];
    check_keys(c, s, "settings", {"tau_px", "occlusion", "hzb_mip_policy"});
    out.settings.threshold_px = float(get_number(c, s, "settings", "tau_px", 1, 1e-3, 1e6));
    out.settings.occlusion = get_bool(c, s, "settings", "occlusion", true);
    std::string policy = get_string(c, s, "settings", "hzb_mip_policy", "4x4");
    if (policy == "4x4") out.settings.hzb_policy = HzbMipPolicy::k4x4;
    else if (policy == "2x2") out.settings.hzb_policy = HzbMipPolicy::k2x2;
    else if (policy == "finest") out.settings.hzb_policy = HzbMipPolicy::kFinest;
    else bad(c, "SCENE_BAD_VALUE", "settings.hzb_mip_policy: one of 4x4, 2x2, finest");
  }
  const json& cams = get_array(c, doc, "", "cameras", kMaxSceneCameras);
  if (cams.empty()) bad(c, "SCENE_NO_CAMERA", "cameras: at least one camera");
  for (size_t i = 0; i < cams.size(); ++i) out.cameras.push_back(read_camera(c, cams[i], "cameras[" + std::to_string(i) + "]"));
  if (doc.contains("camera_path")) out.path = expand_path(c, doc["camera_path"], out.cameras[0]);
  if (doc.contains("lights")) out.scene.lights = parse_scene_lights(doc["lights"], c.where);

  const json& insts = get_array(c, doc, "", "instances", kMaxSceneInstances);
  const json& meshes = get_array(c, doc, "", "meshes", kMaxSceneMeshes);
  for (size_t i = 0; i < insts.size(); ++i) {
    std::string path = "instances[" + std::to_string(i) + "]";
    check_keys(c, insts[i], path, {"name", "mesh", "matrix", "translation", "rotation", "scale"});
    CullInstance inst;
    double mesh = get_number(c, insts[i], path, "mesh", 0, 0, 1e9, true);
    if (mesh >= double(meshes.size()) || mesh != std::floor(mesh))
      bad(c, "SCENE_MESH_INDEX", path + ".mesh: no mesh " + std::to_string(mesh));
    inst.mesh = uint32_t(mesh);
    inst.object_to_world = instance_matrix(c, insts[i], path);
    out.scene.instances.push_back(inst);
  }
  if (doc.contains("moves"))
    out.moves = parse_scene_moves(doc["moves"], c.where, out.scene.lights, out.scene.instances.size());
  load_scene_meshes(c, doc, &out);
  for (const ClusterDag& dag : out.scene.meshes)
    for (uint32_t t : dag.triangle_materials)
      if (t >= out.scene.materials.size()) bad(c, "SCENE_BAD_VALUE", "a mesh refers to material " + std::to_string(t) + " which does not exist");
  analyze_render_scene(&out.scene);
  return out;
}

std::vector<Camera> load_camera_path_file(const std::string& path, const Camera& base) {
  // A path of kMaxKeyframes keyframes is well below 4 MB of JSON.
  constexpr uint64_t kMaxPathBytes = 4 << 20;
  std::string text = read_text_file(path, kMaxPathBytes);
  SceneLoadOptions options;
  Ctx c{path, "", &options};
  json doc = json::parse(text, nullptr, false);
  if (doc.is_discarded()) bad(c, "SCENE_JSON_PARSE", "not valid JSON");
  return expand_path(c, doc, base);
}

SceneFile load_scene_file(const std::string& path, const SceneLoadOptions& options) {
  // Scene files are small descriptions; 64 MB is far beyond any hand-written or generated one.
  constexpr uint64_t kMaxSceneBytes = 64 << 20;
  std::string text = read_text_file(path, kMaxSceneBytes);
  std::string base = std::filesystem::path(path).parent_path().string();
  return parse_scene_json(text, path, base.empty() ? "." : base, options);
}

SceneFile make_default_scene(uint32_t width, uint32_t height, uint32_t frames, const SceneLoadOptions& options) {
  Ctx c{"<default scene>", ".", &options};
  SceneFile out;
  out.scene.materials = {Material{"ground", {0.35f, 0.42f, 0.30f, 1}}, Material{"clay", {0.80f, 0.45f, 0.30f, 1}},
                         Material{"stone", {0.55f, 0.57f, 0.62f, 1}}, Material{"sky", {0.30f, 0.50f, 0.85f, 1}}};
  // Mesh 0: a displaced sphere; mesh 1: the terrain (holes included) flattened into a ground.
  GenerateOptions gen;
  gen.threads = options.build.threads;
  gen.shape = GenShape::kSphere;
  gen.target_triangles = kDefaultSceneSphereTriangles;
  Mesh sphere = generate_mesh(gen);
  // The generator's two materials (lowlands 0, highlands 1) become clay and stone.
  for (uint32_t& m : sphere.materials) m = m ? 2 : 1;
  gen.shape = GenShape::kTerrain;
  gen.target_triangles = kDefaultSceneGroundTriangles;
  gen.seed = kDefaultGroundSeed;
  Mesh ground = generate_mesh(gen);
  ground.materials.assign(ground.triangle_count(), 0);
  add_built_scene_mesh(c, sphere, "default.sphere", &out);
  add_built_scene_mesh(c, ground, "default.ground", &out);
  auto place = [&](uint32_t mesh, double x, double y, double z, double s) {
    CullInstance inst;
    inst.mesh = mesh;
    inst.object_to_world.at(0, 0) = inst.object_to_world.at(1, 1) = inst.object_to_world.at(2, 2) = s;
    inst.object_to_world.at(0, 3) = x;
    inst.object_to_world.at(1, 3) = y;
    inst.object_to_world.at(2, 3) = z;
    out.scene.instances.push_back(inst);
  };
  {
    // The terrain spans [-1,1]^2 with heights within about ±kTerrainHeight (0.25): scaled to a
    // 40 x 40 ground whose bumps stay below the spheres (±0.4, as the old grid's amplitude).
    CullInstance g;
    g.mesh = 1;
    g.object_to_world.at(0, 0) = g.object_to_world.at(2, 2) = kDefaultGroundHalfSize;
    g.object_to_world.at(1, 1) = kDefaultGroundHeightScale;
    out.scene.instances.push_back(g);
  }
  place(0, 0, 1.6, 0, 1.5);  // hero sphere
  // A ring of smaller spheres, some behind the hero (occluded from the default camera).
  for (int k = 0; k < 8; ++k) {
    double a = k * 3.14159265358979323846 / 4;
    place(0, 4.5 * std::cos(a), 0.8, 4.5 * std::sin(a), 0.7);
  }
  place(0, 0, 1.0, -9, 1.0);  // far sphere, straight behind the hero
  Camera cam;
  cam.width = width;
  cam.height = height;
  cam.position = {0, 3.0, 9.0};
  look_at_orientation(cam.position, {0, 1.2, 0}, {0, 1, 0}, &cam.orientation);
  out.cameras.push_back(cam);
  for (uint32_t f = 0; f < frames && frames > 1; ++f) {
    // Orbit a quarter turn around the hero sphere.
    double a = 0.5 * 3.14159265358979323846 * f / (frames - 1);
    Camera p = cam;
    p.position = {9.0 * std::sin(a), 3.0, 9.0 * std::cos(a)};
    look_at_orientation(p.position, {0, 1.2, 0}, {0, 1, 0}, &p.orientation);
    out.path.push_back(p);
  }
  analyze_render_scene(&out.scene);
  return out;
}

}  // namespace vgeo

#include "vgeo/render/scene_file.h"
#include "vgeo/render/scene_lights.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <sstream>

#include "vgeo/format/asset_file.h"
#include "vgeo/core/error.h"
#include "vgeo/core/file_io.h"
#include "vgeo/core/hash.h"
#include "vgeo/mesh/generate.h"
#include "vgeo/mesh/import.h"
#include "vgeo/render/run.h"
#include "vgeo/stream/stream.h"

namespace vgeo {

namespace {

using json = nlohmann::json;
constexpr double kDegToRad = 3.14159265358979323846 / 180.0;
// Identity of the cached memory form's producer (builder + page encoder) in cache keys: bump
// when either's output changes meaning.
constexpr const char* kCacheKeyVersion = "vgeo-memory-form-cache-2";  // 2: stored errors measured against the leaves
// Limits on untrusted list sizes (memory bound before anything is generated).
constexpr size_t kMaxSceneMeshes = 4096, kMaxSceneInstances = 1u << 20, kMaxSceneMaterials = 1u << 16,
                 kMaxSceneCameras = 1024, kMaxKeyframes = 10000;

// Default scene sizes: ~130k triangles per mesh builds in about a second and still shows
// several LOD levels across the view; the ground's scale is 20 x 1.6 x 20 of the [-1,1]^2 terrain.
constexpr uint64_t kDefaultSceneSphereTriangles = 131072, kDefaultSceneGroundTriangles = 131072;
constexpr double kDefaultGroundHalfSize = 20.0, kDefaultGroundHeightScale = 1.6;
// Terrain seed whose holes all lie far behind the spheres (seeds 1, 2 put one in the foreground).
constexpr uint64_t kDefaultGroundSeed = 3;

struct Ctx {
  std::string where;
  std::string base_dir;
  const SceneLoadOptions* options;
};

[[noreturn]] void bad(const Ctx& c, const std::string& code, const std::string& what) { fail(code, c.where, what); }

void check_keys(const Ctx& c, const json& obj, const std::string& path, std::initializer_list<const char*> allowed) {
  if (!obj.is_object()) bad(c, "SCENE_FIELD_TYPE", path + ": expected an object");
  std::set<std::string> ok(allowed.begin(), allowed.end());
  for (auto it = obj.begin(); it != obj.end(); ++it)
    if (!ok.count(it.key())) bad(c, "SCENE_UNKNOWN_FIELD", path + "." + it.key() + ": unknown field");
}

double get_number(const Ctx& c, const json& obj, const std::string& path, const char* key, double def,
                  double lo, double hi, bool required = false) {
  if (!obj.contains(key)) {
    if (required) bad(c, "SCENE_MISSING_FIELD", path + "." + key + ": required");
    return def;
  }
  const json& v = obj[key];
  if (!v.is_number()) bad(c, "SCENE_FIELD_TYPE", path + "." + key + ": expected a number");
  double d = v.get<double>();
  if (!std::isfinite(d) || d < lo || d > hi) {
    std::ostringstream s;
    s << path << "." << key << ": " << d << " outside [" << lo << ", " << hi << "]";
    bad(c, "SCENE_BAD_VALUE", s.str());
  }
  return d;
}

bool get_bool(const Ctx& c, const json& obj, const std::string& path, const char* key, bool def) {
  if (!obj.contains(key)) return def;
  if (!obj[key].is_boolean()) bad(c, "SCENE_FIELD_TYPE", path + "." + key + ": expected true/false");
  return obj[key].get<bool>();
}

std::string get_string(const Ctx& c, const json& obj, const std::string& path, const char* key,
                       const std::string& def, bool required = false) {
  if (!obj.contains(key)) {
    if (required) bad(c, "SCENE_MISSING_FIELD", path + "." + key + ": required");
    return def;
  }
  if (!obj[key].is_string()) bad(c, "SCENE_FIELD_TYPE", path + "." + key + ": expected a string");
  return obj[key].get<std::string>();
}

std::vector<double> get_vector(const Ctx& c, const json& obj, const std::string& path, const char* key, size_t n,
                               double limit = 1e12) {
  std::string p = path + "." + key;
  const auto it = obj.find(key);  // not const operator[]: undefined on a missing key
  if (it == obj.end() || !it->is_array() || it->size() != n) bad(c, "SCENE_FIELD_TYPE", p + ": expected an array of " + std::to_string(n) + " numbers");
  std::vector<double> out;
  for (const json& e : *it) {
    if (!e.is_number()) bad(c, "SCENE_FIELD_TYPE", p + ": expected numbers");
    double d = e.get<double>();
    if (!std::isfinite(d) || std::abs(d) > limit) bad(c, "SCENE_BAD_VALUE", p + ": value not finite or beyond ±1e12");
    out.push_back(d);
  }
  return out;
}

const json& get_array(const Ctx& c, const json& obj, const std::string& path, const char* key, size_t max) {
  // find, not operator[]: a const json's operator[] on a missing key is undefined behaviour
  // (fuzz_camera_path: heap overflow on a path with "frames" but no "keyframes").
  const auto it = obj.find(key);
  if (it == obj.end() || !it->is_array()) bad(c, "SCENE_FIELD_TYPE", path + key + ": expected an array");
  const json& v = *it;
  if (v.size() > max) bad(c, "SCENE_TOO_LARGE", path + key + ": more than " + std::to_string(max) + " entries");
  return v;
}

// ---- meshes ----

// A page-format byte buffer as a scene encoding. Throws the container's FORMAT_* codes.
SceneEncoding scene_encoding(const std::string& where, std::vector<uint8_t> bytes) {
  SceneEncoding e;
  e.where = where;
  e.bytes = std::move(bytes);
  e.container = parse_container(e.bytes.data(), e.bytes.size(), where);
  return e;
}

// A built mesh as the scene draws it: its one encoding and the decode of those bytes.
struct EncodedMesh {
  SceneEncoding encoding;
  ClusterDag decoded;
};

// Adds a built mesh's memory form to the scene (material offset 0: it stores the scene's ids).
void add_built_mesh(SceneFile* out, EncodedMesh mesh) {
  out->mesh_forms.push_back({uint32_t(out->encodings.size()), 0, 0});
  out->encodings.push_back(std::move(mesh.encoding));
  out->scene.meshes.push_back(std::move(mesh.decoded));
}

// What both backends draw of a built (float) DAG: its page-format memory form (spec/raster.md
// §Geometry): quantized positions and normals, canonical cluster order and the conservative
// metadata of spec/format.md §2.1, exactly as if read from a page file written with
// memory_form_options().
EncodedMesh encoded_memory_form(const Ctx& c, ClusterDag dag, const std::string& path) {
  BuiltScene one;
  one.meshes.push_back(std::move(dag));
  try {
    BuiltScene decoded;
    EncodedMesh out;
    out.encoding = encode_memory_form(one, path, &decoded);
    out.decoded = std::move(decoded.meshes[0]);
    return out;
  } catch (const VgeoError& e) {
    bad(c, "SCENE_MESH_BUILD", path + ": memory form: " + e.error().line());
  }
}

// A mesh's DAG in its memory form. The cache holds that encoding as a page file (the page
// encoder costs more than decoding: measured ~3 s per 131k-triangle mesh on the loaded 2 cores).
EncodedMesh build_cached(const Ctx& c, const Mesh& mesh, const std::string& path) {
  const SceneLoadOptions& o = *c.options;
  std::string cache_file;
  if (!o.cache_dir.empty()) {
    char name[32];
    std::snprintf(name, sizeof name, "%016llx.vgeo", (unsigned long long)mesh_content_hash(mesh, o.build));
    cache_file = (std::filesystem::path(o.cache_dir) / name).string();
    std::error_code ec;
    if (std::filesystem::exists(cache_file, ec)) {
      try {
        EncodedMesh cached;
        cached.encoding = scene_encoding(path, read_file(cache_file, kAnyFileSize));
        const std::vector<uint8_t>& bytes = cached.encoding.bytes;
        BuiltScene decoded = decode_format(bytes.data(), bytes.size(), cache_file);
        if (decoded.meshes.size() == 1) {
          cached.decoded = std::move(decoded.meshes[0]);
          return cached;
        }
      } catch (const VgeoError&) {
        // A corrupt or foreign cache entry is rebuilt and overwritten below.
      }
    }
  }
  ClusterDag dag;
  try {
    dag = build_dag(mesh, o.build);
  } catch (const VgeoError& e) {
    bad(c, "SCENE_MESH_BUILD", path + ": " + e.error().line());
  }
  EncodedMesh built = encoded_memory_form(c, std::move(dag), path);
  if (!cache_file.empty()) {
    try {
      std::error_code ec;
      std::filesystem::create_directories(o.cache_dir, ec);
      write_file_atomic(cache_file, built.encoding.bytes.data(), built.encoding.bytes.size());
    } catch (const VgeoError&) {
      // The cache is an optimization: a failed write leaves the scene usable.
    }
  }
  return built;
}

// The page files a load reads in full, each once: its bytes become one of the scene's
// encodings (the GPU's pages are the file's own), its decode what the CPU reference draws. A
// decoded mesh is moved into the first scene mesh drawing it and copied from there for others.
struct PageFileReads {
  std::vector<std::string> paths;  // canonical
  std::vector<uint32_t> encoding;  // index into SceneFile::encodings
  std::vector<BuiltScene> decoded;
  std::vector<std::vector<uint32_t>> holder;  // per file, per mesh: the scene mesh holding it, kNone
};

std::string canonical_path(const std::filesystem::path& p) {
  std::error_code ec;
  std::filesystem::path c = std::filesystem::weakly_canonical(p, ec);
  return ec ? p.string() : c.string();
}

// Page file `file`, read and decoded once per load: its index in `reads`.
uint32_t read_page_file(const Ctx& c, const std::string& file, const std::string& path, SceneFile* out,
                        PageFileReads* reads) {
  const std::string canonical = canonical_path(file);
  const size_t k = std::find(reads->paths.begin(), reads->paths.end(), canonical) - reads->paths.begin();
  if (k < reads->paths.size()) return uint32_t(k);
  SceneEncoding e;
  BuiltScene decoded;
  try {
    e = scene_encoding(file, read_file(file, kAnyFileSize));  // page files may exceed 4 GiB
    decoded = decode_format(e.bytes.data(), e.bytes.size(), file);
  } catch (const VgeoError& err) {
    bad(c, "SCENE_MESH_SOURCE", path + ".dag: " + err.error().line());
  }
  reads->paths.push_back(canonical);
  reads->encoding.push_back(uint32_t(out->encodings.size()));
  reads->holder.emplace_back(decoded.meshes.size(), kNone);
  reads->decoded.push_back(std::move(decoded));
  out->encodings.push_back(std::move(e));
  return uint32_t(k);
}

// Scene mesh `scene_mesh` (`path`) as mesh `index` of the page file reads->decoded[k]: its
// decode with the file's materials appended to the scene's at `material_offset`, drawn from the
// file's encoding.
void add_page_file_mesh(const Ctx& c, const std::string& file, PageFileReads* reads, uint32_t k, uint32_t index,
                        uint32_t material_offset, const std::string& path, uint32_t scene_mesh, SceneFile* out) {
  BuiltScene& built = reads->decoded[k];
  if (index >= built.meshes.size()) bad(c, "SCENE_BAD_VALUE", path + ".index: no such mesh in " + file);
  ClusterDag& mesh = out->scene.meshes[scene_mesh];
  uint32_t& holder = reads->holder[k][index];
  if (holder == kNone) {
    mesh = std::move(built.meshes[index]);
    if (!bvh_is_tree(mesh)) bad(c, "SCENE_MESH_SOURCE", path + ".dag: BVH node reached twice (cycle or shared subtree)");
    for (uint32_t& t : mesh.triangle_materials) t += material_offset;
    holder = scene_mesh;
  } else {
    mesh = out->scene.meshes[holder];
    const uint32_t held_offset = out->mesh_forms[holder].material_offset;
    for (uint32_t& t : mesh.triangle_materials) t = t - held_offset + material_offset;
  }
  out->mesh_forms[scene_mesh] = {reads->encoding[k], index, material_offset};
}

// A generated mesh (lib/vgeo/mesh/generate.h): the scene's `shape`, `triangles` and `seed` are
// GenerateOptions' shape, target_triangles and seed, so `vgeo gen SHAPE --triangles N --seed S`
// writes the same mesh.
Mesh make_procedural(const Ctx& c, const json& p, const std::string& path) {
  check_keys(c, p, path, {"shape", "triangles", "seed"});
  std::string name = get_string(c, p, path, "shape", "", true);
  std::optional<GenShape> shape = parse_gen_shape(name);
  if (!shape) {
    std::string known;
    for (GenShape g : kAllGenShapes) known += (known.empty() ? "" : ", ") + std::string(gen_shape_name(g));
    bad(c, "SCENE_BAD_VALUE", path + ".shape: unknown shape '" + name + "' (" + known + ")");
  }
  GenerateOptions o;
  o.shape = *shape;
  // Bounds checked in double before any conversion, so huge values cannot wrap.
  double triangles = get_number(c, p, path, "triangles", double(kDefaultProceduralTriangles), 1, 1e300);
  if (triangles > double(kMaxProceduralTriangles))
    bad(c, "SCENE_TOO_LARGE", path + ".triangles: more than " + std::to_string(kMaxProceduralTriangles));
  if (triangles != std::floor(triangles)) bad(c, "SCENE_BAD_VALUE", path + ".triangles: not an integer");
  o.target_triangles = uint64_t(triangles);
  if (p.contains("seed")) {
    // Any uint64 (as `vgeo gen --seed`): read as an integer, never through double.
    const json& v = p["seed"];
    if (!v.is_number()) bad(c, "SCENE_FIELD_TYPE", path + ".seed: expected a number");
    if (!v.is_number_unsigned()) bad(c, "SCENE_BAD_VALUE", path + ".seed: not a non-negative integer");
    o.seed = v.get<uint64_t>();
  }
  o.threads = c.options->build.threads;  // output is identical for any thread count
  return generate_mesh(o);
}

void load_meshes(const Ctx& c, const json& doc, SceneFile* out, PageFileReads* reads) {
  const json& meshes = get_array(c, doc, "", "meshes", kMaxSceneMeshes);
  for (size_t i = 0; i < meshes.size(); ++i) {
    std::string path = "meshes[" + std::to_string(i) + "]";
    const json& m = meshes[i];
    check_keys(c, m, path, {"name", "procedural", "dag", "index", "source", "material"});
    int sources = int(m.contains("procedural")) + int(m.contains("dag")) + int(m.contains("source"));
    if (sources != 1) bad(c, "SCENE_MESH_SOURCE", path + ": exactly one of procedural, dag, source");
    if (m.contains("dag")) {
      std::string file = get_string(c, m, path, "dag", "");
      std::filesystem::path fp(file);
      if (fp.is_relative()) fp = std::filesystem::path(c.base_dir) / fp;
      if (c.options->stream && is_page_file(fp.string())) {
        // Metadata only (header + metadata read once per file; no page): decided after all meshes.
        const std::string canonical = std::filesystem::weakly_canonical(fp).string();
        ScenePageMesh pm;
        pm.file = 0;
        while (pm.file < out->page_files.size() && out->page_files[pm.file].path != canonical) ++pm.file;
        if (pm.file == out->page_files.size()) {
          ScenePageFile pf;
          pf.path = canonical;
          try {
            pf.metadata = read_container_metadata(canonical);
          } catch (const VgeoError& e) {
            bad(c, "SCENE_MESH_SOURCE", path + ".dag: " + e.error().line());
          }
          out->page_files.push_back(std::move(pf));
        }
        const FormatContainer& fc = out->page_files[pm.file].metadata;
        double index = get_number(c, m, path, "index", 0, 0, 1e9);
        if (index >= double(fc.meshes.size())) bad(c, "SCENE_BAD_VALUE", path + ".index: no such mesh in " + file);
        pm.index = uint32_t(index);
        pm.material_offset = uint32_t(out->scene.materials.size());
        if (out->scene.materials.size() + fc.materials.size() > kMaxSceneMaterials)
          bad(c, "SCENE_TOO_LARGE", path + ": too many materials");
        out->scene.materials.insert(out->scene.materials.end(), fc.materials.begin(), fc.materials.end());
        const MeshMetadata& mm = fc.meshes[pm.index];
        for (uint32_t p = mm.first_page; p < mm.first_page + mm.page_count; ++p) pm.page_bytes += fc.pages[p].memory_size;
        if (!bvh_is_tree(mm.dag)) bad(c, "SCENE_MESH_SOURCE", path + ".dag: BVH node reached twice (cycle or shared subtree)");
        out->page_meshes.resize(out->scene.meshes.size());
        out->page_meshes.push_back(pm);
        out->scene.meshes.push_back(mm.dag);
        out->mesh_forms.push_back({kNone, pm.index, pm.material_offset});  // streamed, unless resolved in memory
        continue;
      }
      // A page file is already the memory form: drawn from its own bytes. A VGEODAG1 file holds
      // float positions: encoded once into its memory form.
      const bool page_file = is_page_file(fp.string());
      BuiltScene dag_file;
      try {
        if (!page_file) dag_file = read_asset_file(fp.string());  // VGEODAG1 (lib/vgeo/format/asset_file.h)
      } catch (const VgeoError& e) {
        bad(c, "SCENE_MESH_SOURCE", path + ".dag: " + e.error().line());
      }
      const uint32_t read = page_file ? read_page_file(c, fp.string(), path, out, reads) : kNone;
      const BuiltScene& built = page_file ? reads->decoded[read] : dag_file;
      double index = get_number(c, m, path, "index", 0, 0, 1e9);
      if (index >= double(built.meshes.size())) bad(c, "SCENE_BAD_VALUE", path + ".index: no such mesh in " + file);
      // The file's materials are appended; its triangle materials are offset to match.
      uint32_t offset = uint32_t(out->scene.materials.size());
      if (out->scene.materials.size() + built.materials.size() > kMaxSceneMaterials)
        bad(c, "SCENE_TOO_LARGE", path + ": too many materials");
      out->scene.materials.insert(out->scene.materials.end(), built.materials.begin(), built.materials.end());
      if (page_file) {
        out->scene.meshes.emplace_back();
        out->mesh_forms.emplace_back();
        add_page_file_mesh(c, file, reads, read, uint32_t(index), offset, path, uint32_t(i), out);
        continue;
      }
      ClusterDag dag = std::move(dag_file.meshes[size_t(index)]);
      if (!bvh_is_tree(dag)) bad(c, "SCENE_MESH_SOURCE", path + ".dag: BVH node reached twice (cycle or shared subtree)");
      // Encoded with the file's material ids, offset after the decode (as a page file's).
      EncodedMesh encoded = encoded_memory_form(c, std::move(dag), path);
      for (uint32_t& t : encoded.decoded.triangle_materials) t += offset;
      out->mesh_forms.push_back({uint32_t(out->encodings.size()), 0, offset});
      out->encodings.push_back(std::move(encoded.encoding));
      out->scene.meshes.push_back(std::move(encoded.decoded));
      continue;
    }
    Mesh mesh;
    if (m.contains("procedural")) {
      mesh = make_procedural(c, m["procedural"], path + ".procedural");
      double material = get_number(c, m, path, "material", 0, 0, double(kMaxSceneMaterials));
      if (material >= double(out->scene.materials.size()) || material != std::floor(material))
        bad(c, "SCENE_BAD_VALUE", path + ".material: no material " + std::to_string(material));
      mesh.materials.assign(mesh.triangle_count(), uint32_t(material));
    } else {
      // A mesh file (glTF/OBJ/PLY/OFF/STL via lib/vgeo/mesh): mesh `index` of the file; the file's
      // materials are appended (or `material` overrides every triangle's).
      std::string file = get_string(c, m, path, "source", "");
      std::filesystem::path fp(file);
      if (fp.is_relative()) fp = std::filesystem::path(c.base_dir) / fp;
      ImportResult imported;
      try {
        imported = import_scene(fp.string());
      } catch (const VgeoError& e) {
        bad(c, "SCENE_MESH_SOURCE", path + ".source: " + e.error().line());
      }
      double index = get_number(c, m, path, "index", 0, 0, 1e9);
      if (index >= double(imported.scene.meshes.size())) bad(c, "SCENE_BAD_VALUE", path + ".index: no such mesh in " + file);
      mesh = std::move(imported.scene.meshes[size_t(index)]);
      if (m.contains("material")) {
        double material = get_number(c, m, path, "material", 0, 0, double(kMaxSceneMaterials));
        if (material >= double(out->scene.materials.size()) || material != std::floor(material))
          bad(c, "SCENE_BAD_VALUE", path + ".material: no material " + std::to_string(material));
        mesh.materials.assign(mesh.triangle_count(), uint32_t(material));
      } else {
        uint32_t offset = uint32_t(out->scene.materials.size());
        if (out->scene.materials.size() + imported.scene.materials.size() > kMaxSceneMaterials)
          bad(c, "SCENE_TOO_LARGE", path + ": too many materials");
        out->scene.materials.insert(out->scene.materials.end(), imported.scene.materials.begin(),
                                    imported.scene.materials.end());
        if (mesh.materials.empty()) mesh.materials.assign(mesh.triangle_count(), 0);
        for (uint32_t& t : mesh.materials) t += offset;
      }
    }
    add_built_mesh(out, build_cached(c, mesh, path));
  }
}

// With a stream budget: the one decision whether the scene streams (spec/stream.md §Renderer).
// Page-file meshes stay metadata-only when their pages exceed the budget, else they are read and
// decoded exactly as without a budget (each file read once, kept as the scene's encoding).
void resolve_page_meshes(const Ctx& c, SceneFile* out, PageFileReads* reads) {
  if (!c.options->stream) return;
  out->stream = c.options->stream;
  const uint64_t budget = out->stream->budget_bytes;
  out->page_meshes.resize(out->scene.meshes.size());
  std::set<std::pair<uint32_t, uint32_t>> counted;
  for (const ScenePageMesh& pm : out->page_meshes)
    if (pm.file != kNone && counted.insert({pm.file, pm.index}).second) out->page_bytes += pm.page_bytes;
  if (counted.empty()) {
    out->stream_reason = "no mesh of the scene comes from a page file";
    return;
  }
  out->streaming = out->page_bytes > budget;
  if (out->streaming) {
    size_t in_memory = out->page_meshes.size() - std::count_if(out->page_meshes.begin(), out->page_meshes.end(),
                                                               [](const ScenePageMesh& pm) { return pm.file != kNone; });
    out->stream_reason = "data " + format_bytes(out->page_bytes) + " > budget " + format_bytes(budget) + ", " +
                         std::to_string(out->page_files.size()) + " page file(s)" +
                         (in_memory ? ", " + std::to_string(in_memory) + " mesh(es) not from page files stay in memory" : "");
    return;
  }
  out->stream_reason = "data " + format_bytes(out->page_bytes) + " <= budget " + format_bytes(budget);
  for (size_t i = 0; i < out->page_meshes.size(); ++i) {
    ScenePageMesh& pm = out->page_meshes[i];
    if (pm.file == kNone) continue;
    const std::string path = "meshes[" + std::to_string(i) + "]";
    const std::string& file = out->page_files[pm.file].path;
    add_page_file_mesh(c, file, reads, read_page_file(c, file, path, out, reads), pm.index, pm.material_offset, path,
                       uint32_t(i), out);
    pm.file = kNone;
  }
  out->page_files.clear();  // nothing streams
}

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
  if (!j.contains("position")) bad(c, "SCENE_MISSING_FIELD", path + ".position: required");
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

FormatOptions memory_form_options() {
  FormatOptions o;  // the defaults of `vgeo build`: the same grid, so the same memory form
  // The disk form's compression does not change the memory form; none is the fastest.
  o.compression = Compression::kNone;
  return o;
}

SceneEncoding encode_memory_form(const BuiltScene& built, const std::string& where, BuiltScene* decoded) {
  SceneEncoding e = scene_encoding(where, encode_format(built, memory_form_options()));
  if (decoded) *decoded = decode_format(e.bytes.data(), e.bytes.size(), where);
  return e;
}

uint64_t mesh_content_hash(const Mesh& mesh, const BuildOptions& options) {
  uint64_t h = fnv1a64(kCacheKeyVersion);
  auto add = [&](const auto& v) {
    uint64_t n = v.size();
    h = fnv1a64(&n, sizeof n, h);
    if (n) h = fnv1a64(v.data(), n * sizeof(v[0]), h);
  };
  add(mesh.positions);
  add(mesh.normals);
  add(mesh.uvs);
  add(mesh.indices);
  add(mesh.materials);
  uint8_t simplifier = uint8_t(options.simplifier);
  return fnv1a64(&simplifier, 1, h);
}

SceneFile parse_scene_json(const std::string& text, const std::string& where, const std::string& base_dir,
                           const SceneLoadOptions& options) {
  Ctx c{where, base_dir, &options};
  json doc = json::parse(text, nullptr, false);
  if (doc.is_discarded()) bad(c, "SCENE_JSON_PARSE", "not valid JSON");
  check_keys(c, doc, "scene", {"version", "materials", "meshes", "instances", "cameras", "camera_path", "settings", "lights"});
  int version = int(get_number(c, doc, "scene", "version", 0, -1e9, 1e9, true));
  if (version != kSceneFileVersion)
    bad(c, "SCENE_VERSION", "version " + std::to_string(version) + " unsupported (expected " + std::to_string(kSceneFileVersion) + ")");
  for (const char* key : {"meshes", "instances", "cameras"})
    if (!doc.contains(key)) bad(c, "SCENE_MISSING_FIELD", std::string("scene.") + key + ": required");

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
  PageFileReads reads;
  load_meshes(c, doc, &out, &reads);
  resolve_page_meshes(c, &out, &reads);
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
  add_built_mesh(&out, build_cached(c, sphere, "default.sphere"));
  add_built_mesh(&out, build_cached(c, ground, "default.ground"));
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

// Mesh loading of render scenes: the scene file's `meshes` list (spec/scene.md §meshes) built,
// read or streamed into their memory form (spec/raster.md §Geometry), with the DAG cache.
#include "vgeo/render/scene_meshes.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <optional>
#include <set>

#include "vgeo/core/error.h"
#include "vgeo/core/file_io.h"
#include "vgeo/core/hash.h"
#include "vgeo/format/asset_file.h"
#include "vgeo/mesh/generate.h"
#include "vgeo/mesh/import.h"
#include "vgeo/render/run.h"
#include "vgeo/stream/stream.h"

namespace vgeo {

namespace {

using namespace scene_detail;

// Identity of the cached memory form's producer (builder + page encoder) in cache keys: bump
// when either's output changes meaning.
constexpr const char* kCacheKeyVersion = "vgeo-memory-form-cache-2";  // 2: stored errors measured against the leaves

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
    std::snprintf(name, sizeof name, "%016llx.vgp", (unsigned long long)mesh_content_hash(mesh, o.build));
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

}  // namespace

namespace scene_detail {

void load_scene_meshes(const Ctx& c, const json& doc, SceneFile* out) {
  PageFileReads reads;
  load_meshes(c, doc, out, &reads);
  resolve_page_meshes(c, out, &reads);
}

void add_built_scene_mesh(const Ctx& c, const Mesh& mesh, const std::string& path, SceneFile* out) {
  add_built_mesh(out, build_cached(c, mesh, path));
}

}  // namespace scene_detail

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

}  // namespace vgeo

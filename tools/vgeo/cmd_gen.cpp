// `vgeo gen SHAPE --triangles N --seed S -o out.glb|.obj|.ply|.off [--islands K]
//   [--subdivide K] [--threads T]`  or  `vgeo gen --input FILE [--subdivide K] -o out`:
// writes a deterministic procedural mesh (lib/vgeo/mesh/generate.h), optionally densified by
// Loop subdivision (lib/vgeo/mesh/subdivide.h). Same arguments -> byte-identical file.
//
// --input goes through import_scene (lib/vgeo/mesh/import.h: glTF + OBJ/PLY/OFF/STL by vgeo's
// own readers, validated, welded), like every other command reading a mesh.
#include <chrono>
#include <cstdio>
#include <string>

#include "commands.h"
#include "vgeo/core/error.h"
#include "vgeo/mesh/export.h"
#include "vgeo/mesh/generate.h"
#include "vgeo/mesh/import.h"
#include "vgeo/mesh/subdivide.h"

namespace vgeo::cli {
namespace {

struct GenArgs {
  std::string shape;
  uint64_t triangles = 100'000;
  uint64_t seed = 1;
  uint32_t islands = 0;
  uint32_t subdivide = 0;
  unsigned threads = 1;
  std::string input;
  std::string output;
};

std::string shape_list() {
  std::string s;
  for (GenShape shape : kAllGenShapes) s += (s.empty() ? "" : ", ") + std::string(gen_shape_name(shape));
  return s;
}

void run_gen(const GenArgs& a) {
  const auto t0 = std::chrono::steady_clock::now();
  if (!mesh_format_from_path(a.output))
    fail("EXPORT_UNKNOWN_FORMAT", a.output, "unknown output extension (expected .glb, .obj, .ply or .off)", kExitUsage);
  Scene scene;
  std::string what;
  if (!a.input.empty()) {
    if (!a.shape.empty()) fail("GEN_SHAPE_AND_INPUT", "vgeo gen", "give either SHAPE or --input, not both", kExitUsage);
    ImportOptions import_options;
    import_options.weld = true;  // Loop needs shared vertices, not per-corner copies
    scene = import_scene(a.input, import_options).scene;
    what = "input=" + a.input;
  } else {
    if (a.shape.empty()) fail("GEN_NO_SHAPE", "vgeo gen", "missing SHAPE (one of " + shape_list() + ") or --input", kExitUsage);
    std::optional<GenShape> shape = parse_gen_shape(a.shape);
    if (!shape) fail("GEN_UNKNOWN_SHAPE", "vgeo gen", "unknown shape '" + a.shape + "' (one of " + shape_list() + ")", kExitUsage);
    GenerateOptions opt;
    opt.shape = *shape;
    opt.target_triangles = a.triangles;
    opt.seed = a.seed;
    opt.islands = a.islands;
    opt.threads = a.threads;
    scene = generate_scene(opt);
    what = "shape=" + a.shape + " seed=" + std::to_string(a.seed);
  }
  if (a.subdivide > 0) {
    SubdivideOptions sub;
    sub.iterations = a.subdivide;
    for (Mesh& mesh : scene.meshes) mesh = subdivide_loop(mesh, sub);
  }
  write_scene_file(scene, a.output);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  size_t triangles = 0, vertices = 0;
  for (const Mesh& mesh : scene.meshes) triangles += mesh.triangle_count(), vertices += mesh.vertex_count();
  std::printf("gen: %s subdivide=%u triangles=%zu vertices=%zu -> %s (%.2f s)\n", what.c_str(), a.subdivide,
              triangles, vertices, a.output.c_str(), seconds);
}

}  // namespace

void add_gen_command(CLI::App& app, Context& ctx) {
  auto args = std::make_shared<GenArgs>();
  auto* cmd = app.add_subcommand("gen", "Write a deterministic procedural mesh (or densify --input) as GLB/OBJ/PLY/OFF");
  cmd->add_option("shape", args->shape, "sphere | terrain | islands | thin | torus");
  cmd->add_option("--triangles,-n", args->triangles, "target triangle count (reached within 2% for >= 32000)")
      ->capture_default_str();
  cmd->add_option("--seed,-s", args->seed, "seed (same seed -> byte-identical output)")->capture_default_str();
  cmd->add_option("--islands", args->islands, "islands: number of components (0 = one per ~768 triangles)");
  cmd->add_option("--subdivide", args->subdivide, "Loop subdivision iterations after generation (x4 triangles each)")
      ->check(CLI::Range(0u, 8u));
  cmd->add_option("--threads,-j", args->threads, "threads for generation (0 = all cores; output is identical)")
      ->capture_default_str();
  cmd->add_option("--input,-i", args->input, "densify this mesh file (glTF/GLB/OBJ/PLY/OFF/STL) instead of generating");
  cmd->add_option("-o,--output", args->output, "output file: .glb, .obj, .ply or .off")->required();
  cmd->callback([args, &ctx] {
    run_gen(*args);
    ctx.exit_code = kExitOk;
  });
}

}  // namespace vgeo::cli

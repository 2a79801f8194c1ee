// `vgeo demo`: the README's main job on the embedded default asset, no files needed.
//   1. generate the default asset (a seeded, displaced closed sphere) and validate it;
//   2. build its cluster DAG and print the per-level report;
//   3. check the DAG against every invariant (lib/vgeo/verify) and print the verdict;
//   4. render the embedded default scene (the same kind of asset, instanced, on a ground)
//      through the CPU reference pipeline (or, with --backend vulkan, the Vulkan executor on the
//      decoded memory form), write the PNG and print the pass table.
// Exit 0 only when every invariant holds and the frame rendered.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "commands.h"
#include "vgeo/core/file_io.h"
#include "vgeo/dag/build.h"
#include "vgeo/core/error.h"
#include "vgeo/core/progress.h"
#include "vgeo/mesh/generate.h"
#include "vgeo/mesh/validate.h"
#include "vgeo/gpu/backend_run.h"
#include "vgeo/render/run.h"
#include "vgeo/verify/verify.h"

namespace vgeo::cli {
namespace {

// Big enough for a DAG of ~12 levels, small enough for the demo to run in seconds on 2 cores.
constexpr uint64_t kDefaultAssetTriangles = 400'000;
constexpr uint64_t kDefaultAssetSeed = 1;

struct DemoArgs {
  std::string out_dir = "out/demo";
  uint32_t width = 1280, height = 720;
  unsigned threads = 0;
  uint64_t triangles = kDefaultAssetTriangles;
  std::string backend = "cpu";
};

}  // namespace

void add_demo_command(CLI::App& app, Context& ctx) {
  auto args = std::make_shared<DemoArgs>();
  auto* cmd = app.add_subcommand("demo", "Generate, build, verify and render the embedded default asset");
  cmd->add_option("--out", args->out_dir, "output folder (frame.png, build and verify reports)");
  cmd->add_option("--width", args->width, "image width")->check(CLI::Range(16u, 8192u));
  cmd->add_option("--height", args->height, "image height")->check(CLI::Range(16u, 8192u));
  cmd->add_option("--threads", args->threads, "worker threads (0 = all cores)");
  cmd->add_option("--triangles", args->triangles, "triangles of the default asset")
      ->check(CLI::Range(uint64_t(1000), uint64_t(20'000'000)));
  cmd->add_option("--backend", args->backend, "cpu|vulkan: renderer of step 4 (vulkan: the decoded memory form, spec/gpu.md)");
  cmd->callback([args, &ctx] {
    Backend backend = Backend::kCpu;
    if (!parse_backend(args->backend, &backend))
      fail("RENDER_BAD_OPTION", "vgeo demo", "--backend must be cpu or vulkan", kExitUsage);
    create_output_directory(args->out_dir);

    // 1. The default asset.
    GenerateOptions gen;
    gen.shape = GenShape::kSphere;
    gen.target_triangles = args->triangles;
    gen.seed = kDefaultAssetSeed;
    Mesh mesh = generate_mesh(gen);
    check_mesh_attributes(mesh, "<default asset>");
    check_mesh_indices(mesh, "<default asset>");
    MeshStats stats = mesh_stats(mesh);
    std::printf("== 1. default asset: %s, seed %llu\n", std::string(gen_shape_name(gen.shape)).c_str(),
                (unsigned long long)gen.seed);
    std::printf("  %zu triangles, %zu vertices, bounds [%.3f %.3f %.3f] .. [%.3f %.3f %.3f], valid\n",
                stats.triangles, stats.vertices, stats.bounds.min.x, stats.bounds.min.y, stats.bounds.min.z,
                stats.bounds.max.x, stats.bounds.max.y, stats.bounds.max.z);

    // 2. The DAG.
    BuildOptions build;
    build.threads = args->threads;
    build.progress = progress_wanted();
    BuildReport report;
    ClusterDag dag = build_dag(mesh, build, &report);
    std::printf("\n== 2. cluster DAG (meshopt simplifier)\n%s", build_report_summary("default", report).c_str());

    // 3. The invariants.
    VerifyOptions verify;
    verify.threads = args->threads;
    VerifyReport verdict = verify_dag(dag, verify);
    std::printf("\n== 3. invariants (spec/invariants.md)\n%s", verify_report_summary(verdict).c_str());
    write_file_atomic((std::filesystem::path(args->out_dir) / "verify.json").string(),
                      verify_report_json(verdict, "default") + "\n");

    // 4. A frame of the default scene.
    RenderRequest request;
    request.output_png = (std::filesystem::path(args->out_dir) / "frame.png").string();
    request.threads = args->threads;
    request.backend = backend;
    RenderReport frame = run_backend(load_default_scene(request, args->width, args->height), request);
    std::printf("\n== 4. frame %ux%u -> %s\n%s", frame.width, frame.height, request.output_png.c_str(),
                frame.table().c_str());
    std::printf("\ndemo: %s\n", verdict.ok() ? "all invariants hold" : "INVARIANT VIOLATIONS (see verify.json)");
    ctx.exit_code = verdict.ok() ? kExitOk : kExitInvariantViolation;
  });
}

}  // namespace vgeo::cli

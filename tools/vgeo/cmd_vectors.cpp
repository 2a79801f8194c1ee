// `vgeo vectors raster [-o DIR]`: writes the raster conformance vectors (spec/raster.md §14,
// lib/vgeo/gpu/raster_vectors.h) as DIR/NAME.txt plus DIR/manifest.txt. Deterministic: the
// committed spec/vectors/raster/ is this command's output.
#include <cstdio>
#include <filesystem>

#include "commands.h"
#include "vgeo/core/file_io.h"
#include "vgeo/gpu/raster_vectors.h"

namespace vgeo::cli {

void add_vectors_command(CLI::App& app, Context& ctx) {
  auto* cmd = app.add_subcommand("vectors", "write vgeo's generated conformance vectors");
  cmd->require_subcommand(1);
  auto out = std::make_shared<std::string>("spec/vectors/raster");
  auto* raster = cmd->add_subcommand("raster", "raster vectors: triangles, expected key per pixel, ambiguity mask");
  raster->add_option("-o,--out", *out, "output folder (default spec/vectors/raster)");
  raster->callback([out, &ctx] {
    std::filesystem::create_directories(*out);
    std::string manifest = "# Raster conformance vectors (spec/raster.md §14); written by `vgeo vectors raster`.\n";
    for (const RasterVector& v : make_raster_vectors()) {
      const std::string text = write_raster_vector(v);
      write_file_atomic(*out + "/" + v.name + ".txt", std::string_view(text));
      manifest += v.name + ".txt\n";
      std::printf("%-14s %2zu cluster(s) %5zu bytes\n", v.name.c_str(), v.clusters.size(), text.size());
    }
    write_file_atomic(*out + "/manifest.txt", std::string_view(manifest));
    ctx.exit_code = 0;
  });
}

}  // namespace vgeo::cli

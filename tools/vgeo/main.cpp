// vgeo: build, verify, render and benchmark Nanite-style virtual geometry.
#include <cstdio>
#include <exception>
#include <new>

#include "commands.h"
#include "vgeo/core/error.h"

int main(int argc, char** argv) {
  CLI::App app{"vgeo: verification-focused reference implementation of virtual geometry"};
  app.require_subcommand(1);
  vgeo::cli::Context ctx;
  vgeo::cli::add_info_command(app, ctx);
  vgeo::cli::add_gen_command(app, ctx);
  vgeo::cli::add_build_command(app, ctx);
  vgeo::cli::add_verify_command(app, ctx);
  vgeo::cli::add_render_command(app, ctx);
  vgeo::cli::add_bench_command(app, ctx);
  vgeo::cli::add_demo_command(app, ctx);
  vgeo::cli::add_compare_command(app, ctx);
  vgeo::cli::add_conform_command(app, ctx);
  vgeo::cli::add_vectors_command(app, ctx);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    int rc = app.exit(e);
    return rc == 0 ? vgeo::kExitOk : vgeo::kExitUsage;
  } catch (const vgeo::VgeoError& e) {
    std::fprintf(stderr, "%s\n", e.error().line().c_str());
    return e.error().exit_code;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "error[OUT_OF_MEMORY]: vgeo: allocation failed\n");
    return vgeo::kExitInternal;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error[INTERNAL]: vgeo: %s\n", e.what());
    return vgeo::kExitInternal;
  }
  return ctx.exit_code;
}

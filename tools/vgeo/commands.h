#pragma once
// Each `vgeo` subcommand lives in its own cmd_*.cpp and registers itself here.
// A command's callback sets ctx.exit_code; VgeoError escaping a callback is printed as
// one line and mapped to its exit code by main().
#include <CLI/CLI.hpp>

namespace vgeo::cli {

struct Context {
  int exit_code = 0;
};

void add_info_command(CLI::App& app, Context& ctx);
void add_gen_command(CLI::App& app, Context& ctx);
void add_build_command(CLI::App& app, Context& ctx);
void add_verify_command(CLI::App& app, Context& ctx);
void add_render_command(CLI::App& app, Context& ctx);
void add_bench_command(CLI::App& app, Context& ctx);
void add_demo_command(CLI::App& app, Context& ctx);
void add_compare_command(CLI::App& app, Context& ctx);
void add_conform_command(CLI::App& app, Context& ctx);
void add_vectors_command(CLI::App& app, Context& ctx);

}  // namespace vgeo::cli

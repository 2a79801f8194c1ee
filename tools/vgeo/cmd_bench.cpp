// Placeholder until the issue that owns `vgeo bench` lands.
#include "commands.h"
#include "vgeo/core/error.h"

namespace vgeo::cli {

void add_bench_command(CLI::App& app, Context& ctx) {
  auto* cmd = app.add_subcommand("bench", "(not implemented yet)");
  cmd->allow_extras();
  cmd->callback([&ctx] { fail("NOT_IMPLEMENTED", "vgeo bench", "this command is not implemented yet", kExitInternal); (void)ctx; });
}

}  // namespace vgeo::cli

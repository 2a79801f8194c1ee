// Placeholder until the issue that owns `vgeo gen` lands.
#include "commands.h"
#include "vgeo/core/error.h"

namespace vgeo::cli {

void add_gen_command(CLI::App& app, Context& ctx) {
  auto* cmd = app.add_subcommand("gen", "(not implemented yet)");
  cmd->allow_extras();
  cmd->callback([&ctx] { fail("NOT_IMPLEMENTED", "vgeo gen", "this command is not implemented yet", kExitInternal); (void)ctx; });
}

}  // namespace vgeo::cli

// Placeholder until the issue that owns `vgeo verify` lands.
#include "commands.h"
#include "vgeo/core/error.h"

namespace vgeo::cli {

void add_verify_command(CLI::App& app, Context& ctx) {
  auto* cmd = app.add_subcommand("verify", "(not implemented yet)");
  cmd->allow_extras();
  cmd->callback([&ctx] { fail("NOT_IMPLEMENTED", "vgeo verify", "this command is not implemented yet", kExitInternal); (void)ctx; });
}

}  // namespace vgeo::cli

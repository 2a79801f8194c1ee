// Placeholder until the issue that owns `vgeo info` lands.
#include "commands.h"
#include "vgeo/core/error.h"

namespace vgeo::cli {

void add_info_command(CLI::App& app, Context& ctx) {
  auto* cmd = app.add_subcommand("info", "(not implemented yet)");
  cmd->allow_extras();
  cmd->callback([&ctx] { fail("NOT_IMPLEMENTED", "vgeo info", "this command is not implemented yet", kExitInternal); (void)ctx; });
}

}  // namespace vgeo::cli

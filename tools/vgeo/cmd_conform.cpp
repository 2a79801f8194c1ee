// `vgeo conform lod|decoder ...`: conformance runs of another implementation against vgeo's
// vectors (spec/conform.md). Each subcommand lives in its own conform_*.cpp.
#include "commands.h"

namespace vgeo::cli {

void add_conform_command(CLI::App& app, Context& ctx) {
  auto* cmd = app.add_subcommand("conform", "check another implementation against vgeo's conformance vectors");
  cmd->require_subcommand(1);
  (void)ctx;
}

}  // namespace vgeo::cli

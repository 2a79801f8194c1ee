// `vgeo conform lod|decoder|hash ...`: conformance runs of another implementation against vgeo's vectors
// (spec/conform.md). Each subcommand lives in its own cmd_conform_*.cpp.
#include "conform.h"

namespace vgeo::cli {

void add_conform_command(CLI::App& app, Context& ctx) {
  auto* cmd = app.add_subcommand("conform", "check another implementation against vgeo's conformance vectors");
  cmd->require_subcommand(1);
  add_conform_lod_command(*cmd, ctx);
  add_conform_decoder_command(*cmd, ctx);
}

}  // namespace vgeo::cli

#pragma once
// `vgeo conform` subcommands (spec/conform.md), registered by cmd_conform.cpp.
#include "commands.h"

namespace vgeo::cli {

void add_conform_lod_command(CLI::App& conform, Context& ctx);
void add_conform_decoder_command(CLI::App& conform, Context& ctx);  // also `conform hash`

}  // namespace vgeo::cli

#pragma once
// `vgeo conform` subcommands (spec/conform.md), registered by cmd_conform.cpp.
#include <cstdint>
#include <string>
#include <vector>

#include "commands.h"

namespace vgeo::cli {

void add_conform_lod_command(CLI::App& conform, Context& ctx);
void add_conform_decoder_command(CLI::App& conform, Context& ctx);  // also `conform hash`

// Caps of the files the conform commands read (lib/vgeo/core/file_io.h read_file checks them
// before allocating): manifests and selections files are text of a few KB to MBs (64 MB, as
// scene files); vectors and decoder inputs are page files (no cap beyond their own size).
inline constexpr uint64_t kMaxConformTextBytes = 64ull << 20;
// The whole file through read_file; any FILE_* failure becomes CONFORM_IO (exit 4, or 3 for a
// file over its cap) with the cause in the message (spec/errors.md §Conformance).
std::vector<uint8_t> read_conform_file(const std::string& path, uint64_t max_bytes, const std::string& what);
std::string read_conform_text(const std::string& path, const std::string& what);

// The vector folder of a conform command: `given` when --vectors was set; otherwise
// `relative` (e.g. "spec/vectors") holding `marker` (its manifest), looked up in the working
// directory, then in each folder above the running vgeo binary (a build tree inside the
// repository: build/release/bin/vgeo). Neither: CONFORM_USAGE naming --vectors (exit 2).
std::string resolve_vectors_dir(const std::string& given, const std::string& relative, const std::string& marker);

}  // namespace vgeo::cli

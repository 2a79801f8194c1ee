#pragma once
// Runs a shell command (stderr merged into stdout) and returns its exit code and output:
// the one CLI runner of the test suites.
#include <sys/wait.h>

#include <cstdio>
#include <string>

#include "support/paths.h"

namespace vgeo::test {

struct CliResult {
  int exit_code = -1;  // -1: could not start, or killed by a signal
  std::string output;
};

inline CliResult run_command(const std::string& command) {
  CliResult r;
  FILE* p = popen((command + " 2>&1").c_str(), "r");
  if (p == nullptr) return r;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) r.output.append(buf, n);
  int status = pclose(p);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

// `vgeo ARGS` with the built CLI (arguments are passed to the shell as written).
inline CliResult run_cli(const std::string& args) { return run_command("'" + cli_path() + "' " + args); }

}  // namespace vgeo::test

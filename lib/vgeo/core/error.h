#pragma once
// Errors for untrusted input (files, pages, scenes): a stable code, where it happened,
// and what went wrong, printed as one line `error[CODE]: where: what`.
// Programming errors are asserts, not Errors (see DEVELOPERS.md).
// Every code is listed in spec/errors.md; codes never change meaning once published.
#include <stdexcept>
#include <string>

namespace vgeo {

// Process exit codes of the `vgeo` tool (stable; spec/errors.md).
enum ExitCode : int {
  kExitOk = 0,
  kExitInvariantViolation = 1,  // `vgeo verify` found violations
  kExitUsage = 2,               // bad command line
  kExitBadInput = 3,            // input file rejected (validation, decode)
  kExitIo = 4,                  // cannot read/write a file
  kExitInternal = 5,            // a bug: an assertion-like condition in release
};

struct Error {
  std::string code;   // stable, e.g. "GLTF_PARSE_ERROR" (spec/errors.md)
  std::string where;  // file path (or "<memory>")
  std::string what;   // one-line human explanation
  int exit_code = kExitBadInput;

  std::string line() const { return "error[" + code + "]: " + where + ": " + what; }
};

class VgeoError : public std::runtime_error {
 public:
  explicit VgeoError(Error e) : std::runtime_error(e.line()), error_(std::move(e)) {}
  const Error& error() const { return error_; }

 private:
  Error error_;
};

[[noreturn]] inline void fail(std::string code, std::string where, std::string what,
                              int exit_code = kExitBadInput) {
  throw VgeoError(Error{std::move(code), std::move(where), std::move(what), exit_code});
}

// Warnings never stop an import; they are counted and reported.
struct Warning {
  std::string code;
  std::string what;
};

}  // namespace vgeo

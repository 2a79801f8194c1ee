#pragma once
// Progress for long work: shown on an interactive terminal, silent in CI or when piped.
#include <cstddef>
#include <string>

namespace vgeo {

class Progress {
 public:
  // enabled == false forces silence (library default; the CLI enables it).
  Progress(std::string label, size_t total, bool enabled);
  ~Progress();
  void advance(size_t delta = 1);
  void set(size_t done);

 private:
  void draw(bool final);
  std::string label_;
  size_t total_, done_ = 0;
  bool enabled_;
  double last_draw_ = 0;
};

// Seconds on the monotonic clock (phase timings and progress pacing; differences only).
double steady_seconds();

// True when stderr is a terminal and the CI environment variable is not set.
bool progress_wanted();

}  // namespace vgeo

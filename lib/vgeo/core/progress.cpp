#include "vgeo/core/progress.h"

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>

namespace vgeo {

double steady_seconds() {
  using namespace std::chrono;
  return duration<double>(steady_clock::now().time_since_epoch()).count();
}

bool progress_wanted() { return isatty(STDERR_FILENO) && std::getenv("CI") == nullptr; }

Progress::Progress(std::string label, size_t total, bool enabled)
    : label_(std::move(label)), total_(total), enabled_(enabled) {}

Progress::~Progress() {
  if (enabled_ && last_draw_ > 0) draw(true);
}

void Progress::advance(size_t delta) { set(done_ + delta); }

void Progress::set(size_t done) {
  done_ = done;
  if (!enabled_) return;
  double t = steady_seconds();
  // Redraw at most 10 times a second: terminal output must not cost measurable time.
  if (t - last_draw_ >= 0.1) {
    last_draw_ = t;
    draw(false);
  }
}

void Progress::draw(bool final) {
  double pct = total_ ? 100.0 * double(done_) / double(total_) : 100.0;
  std::fprintf(stderr, "\r%s: %zu/%zu (%.0f%%)%s", label_.c_str(), done_, total_, pct,
               final ? "\n" : "");
  std::fflush(stderr);
}

}  // namespace vgeo

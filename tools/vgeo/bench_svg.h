#pragma once
// A small self-contained SVG plot writer for benchmark curves: line/scatter series,
// optional error bars, linear or log axes with "nice" ticks, a legend. No dependencies.
#include <string>
#include <vector>

namespace vgeo::bench {

struct Series {
  std::string name;
  std::vector<double> x, y;
  std::vector<double> y_low, y_high;  // optional error bars (same size as y), e.g. min/max
  bool line = true;                   // connect points in x order
  bool markers = true;
  bool dashed = false;                // e.g. the second variant of a pair
  int color = -1;                     // palette index; -1: the series' position
};

inline Series named_series(std::string name) {
  Series s;
  s.name = std::move(name);
  return s;
}

struct Plot {
  std::string title, x_label, y_label;
  bool log_x = false, log_y = false;
  std::vector<Series> series;
  int width = 640, height = 420;
};

// Renders the plot to SVG text. Non-finite points and (on log axes) non-positive values
// are skipped; an empty plot renders axes with a "no data" note.
std::string render_svg(const Plot& plot);

}  // namespace vgeo::bench

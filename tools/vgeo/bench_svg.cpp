#include "bench_svg.h"

#include <algorithm>
#include <cstdint>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

namespace vgeo::bench {
namespace {

// Colour-blind-friendly palette (Okabe–Ito), cycled by series index.
constexpr const char* kPalette[] = {"#0072B2", "#D55E00", "#009E73", "#CC79A7",
                                    "#E69F00", "#56B4E9", "#000000", "#F0E442"};
constexpr int kPaletteSize = 8;
// Plot-area margins in px: room for tick labels, axis titles and the title line.
constexpr int kMarginLeft = 78, kMarginRight = 18, kMarginTop = 34, kMarginBottom = 52;
// Aim for about this many labelled ticks on a linear axis.
constexpr int kTargetTicks = 6;

std::string esc(const std::string& s) {
  std::string o;
  for (char c : s) {
    switch (c) {
      case '&': o += "&amp;"; break;
      case '<': o += "&lt;"; break;
      case '>': o += "&gt;"; break;
      case '"': o += "&quot;"; break;
      default: o += c;
    }
  }
  return o;
}

std::string num(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.2f", v);
  return b;
}

std::string tick_label(double v) {
  if (v == 0) return "0";
  double a = std::fabs(v);
  char b[32];
  if (a >= 1e5 || a < 1e-3) {
    int e = int(std::floor(std::log10(a) + 1e-9));
    double m = v / std::pow(10.0, e);
    if (std::fabs(m - std::round(m)) < 1e-6) std::snprintf(b, sizeof b, "%.0fe%d", m, e);
    else std::snprintf(b, sizeof b, "%.3ge%d", m, e);
  } else {
    std::snprintf(b, sizeof b, "%.4g", v);
  }
  return b;
}

struct Axis {
  bool log = false;
  double lo = 0, hi = 1;  // in data units (log axes: positive)
  std::vector<double> ticks;
  double map(double v, double p0, double p1) const {
    double t = log ? (std::log10(v) - std::log10(lo)) / (std::log10(hi) - std::log10(lo))
                   : (v - lo) / (hi - lo);
    return p0 + t * (p1 - p0);
  }
};

double nice_step(double raw) {
  double e = std::pow(10.0, std::floor(std::log10(raw)));
  double f = raw / e;
  double n = f <= 1 ? 1 : f <= 2 ? 2 : f <= 5 ? 5 : 10;
  return n * e;
}

Axis make_axis(std::vector<double> values, bool log) {
  Axis a;
  a.log = log;
  std::vector<double> ok;
  for (double v : values)
    if (std::isfinite(v) && (!log || v > 0)) ok.push_back(v);
  if (ok.empty()) {
    a.lo = log ? 1 : 0;
    a.hi = log ? 10 : 1;
  } else {
    a.lo = *std::min_element(ok.begin(), ok.end());
    a.hi = *std::max_element(ok.begin(), ok.end());
  }
  if (log) {
    double l0 = std::floor(std::log10(a.lo) + 1e-9), l1 = std::ceil(std::log10(a.hi) - 1e-9);
    if (l1 <= l0) l1 = l0 + 1;
    a.lo = std::pow(10.0, l0);
    a.hi = std::pow(10.0, l1);
    int decades = int(l1 - l0);
    int every = decades > 8 ? 2 : 1;  // keep labels from colliding on very wide ranges
    for (int e = int(l0); e <= int(l1); e += every) {
      double d = std::pow(10.0, e);
      a.ticks.push_back(d);
      if (decades <= 2 && e < int(l1)) {
        a.ticks.push_back(2 * d);
        a.ticks.push_back(5 * d);
      }
    }
    std::sort(a.ticks.begin(), a.ticks.end());
  } else {
    if (a.hi - a.lo <= 0) {
      double pad = a.lo == 0 ? 1 : std::fabs(a.lo) * 0.1;
      a.lo -= pad;
      a.hi += pad;
    }
    double step = nice_step((a.hi - a.lo) / kTargetTicks);
    a.lo = std::floor(a.lo / step + 1e-9) * step;
    a.hi = std::ceil(a.hi / step - 1e-9) * step;
    for (double t = a.lo; t <= a.hi + step * 1e-6; t += step)
      a.ticks.push_back(std::fabs(t) < step * 1e-9 ? 0.0 : t);
  }
  return a;
}

bool usable(double v, bool log) { return std::isfinite(v) && (!log || v > 0); }

void marker(std::ostringstream& o, int shape, double x, double y, const char* color) {
  const double r = 3.5;
  switch (shape % 4) {
    case 0: o << "<circle cx=\"" << num(x) << "\" cy=\"" << num(y) << "\" r=\"" << r << "\" fill=\"" << color << "\"/>"; break;
    case 1: o << "<rect x=\"" << num(x - r) << "\" y=\"" << num(y - r) << "\" width=\"" << 2 * r << "\" height=\"" << 2 * r << "\" fill=\"" << color << "\"/>"; break;
    case 2: o << "<polygon points=\"" << num(x) << "," << num(y - r - 1) << " " << num(x - r - 1) << "," << num(y + r) << " " << num(x + r + 1) << "," << num(y + r) << "\" fill=\"" << color << "\"/>"; break;
    default: o << "<polygon points=\"" << num(x) << "," << num(y - r - 1) << " " << num(x + r + 1) << "," << num(y) << " " << num(x) << "," << num(y + r + 1) << " " << num(x - r - 1) << "," << num(y) << "\" fill=\"" << color << "\"/>";
  }
  o << "\n";
}

}  // namespace

std::string render_svg(const Plot& plot) {
  std::vector<double> xs, ys;
  for (const Series& s : plot.series) {
    for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (!usable(s.x[i], plot.log_x) || !usable(s.y[i], plot.log_y)) continue;
      xs.push_back(s.x[i]);
      ys.push_back(s.y[i]);
      if (i < s.y_low.size() && usable(s.y_low[i], plot.log_y)) ys.push_back(s.y_low[i]);
      if (i < s.y_high.size() && usable(s.y_high[i], plot.log_y)) ys.push_back(s.y_high[i]);
    }
  }
  Axis ax = make_axis(xs, plot.log_x), ay = make_axis(ys, plot.log_y);
  const double W = plot.width, H = plot.height;
  const double x0 = kMarginLeft, x1 = W - kMarginRight, y0 = H - kMarginBottom, y1 = kMarginTop;

  std::ostringstream o;
  o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << plot.width << "\" height=\"" << plot.height
    << "\" viewBox=\"0 0 " << plot.width << " " << plot.height << "\" font-family=\"sans-serif\" font-size=\"11\">\n";
  o << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  o << "<text x=\"" << num(W / 2) << "\" y=\"18\" text-anchor=\"middle\" font-size=\"13\" font-weight=\"bold\">"
    << esc(plot.title) << "</text>\n";
  // Grid + ticks.
  for (double t : ax.ticks) {
    double px = ax.map(t, x0, x1);
    o << "<line x1=\"" << num(px) << "\" y1=\"" << num(y0) << "\" x2=\"" << num(px) << "\" y2=\"" << num(y1)
      << "\" stroke=\"#e4e4e4\"/>\n";
    o << "<line x1=\"" << num(px) << "\" y1=\"" << num(y0) << "\" x2=\"" << num(px) << "\" y2=\"" << num(y0 + 4)
      << "\" stroke=\"black\"/>\n";
    o << "<text x=\"" << num(px) << "\" y=\"" << num(y0 + 16) << "\" text-anchor=\"middle\">" << esc(tick_label(t))
      << "</text>\n";
  }
  for (double t : ay.ticks) {
    double py = ay.map(t, y0, y1);
    o << "<line x1=\"" << num(x0) << "\" y1=\"" << num(py) << "\" x2=\"" << num(x1) << "\" y2=\"" << num(py)
      << "\" stroke=\"#e4e4e4\"/>\n";
    o << "<line x1=\"" << num(x0 - 4) << "\" y1=\"" << num(py) << "\" x2=\"" << num(x0) << "\" y2=\"" << num(py)
      << "\" stroke=\"black\"/>\n";
    o << "<text x=\"" << num(x0 - 7) << "\" y=\"" << num(py + 4) << "\" text-anchor=\"end\">" << esc(tick_label(t))
      << "</text>\n";
  }
  o << "<rect x=\"" << num(x0) << "\" y=\"" << num(y1) << "\" width=\"" << num(x1 - x0) << "\" height=\""
    << num(y0 - y1) << "\" fill=\"none\" stroke=\"black\"/>\n";
  o << "<text x=\"" << num((x0 + x1) / 2) << "\" y=\"" << num(H - 12) << "\" text-anchor=\"middle\">"
    << esc(plot.x_label + (plot.log_x ? " (log)" : "")) << "</text>\n";
  o << "<text transform=\"translate(16," << num((y0 + y1) / 2) << ") rotate(-90)\" text-anchor=\"middle\">"
    << esc(plot.y_label + (plot.log_y ? " (log)" : "")) << "</text>\n";
  if (xs.empty())
    o << "<text x=\"" << num((x0 + x1) / 2) << "\" y=\"" << num((y0 + y1) / 2)
      << "\" text-anchor=\"middle\" fill=\"#888\">no data</text>\n";

  // Series.
  for (size_t si = 0; si < plot.series.size(); ++si) {
    const Series& s = plot.series[si];
    const char* color = kPalette[size_t(s.color >= 0 ? s.color : int(si)) % kPaletteSize];
    std::vector<size_t> order;
    for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i)
      if (usable(s.x[i], plot.log_x) && usable(s.y[i], plot.log_y)) order.push_back(i);
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return s.x[a] < s.x[b]; });
    for (size_t i : order) {
      if (i < s.y_low.size() && i < s.y_high.size() && usable(s.y_low[i], plot.log_y) &&
          usable(s.y_high[i], plot.log_y)) {
        double px = ax.map(s.x[i], x0, x1);
        o << "<line x1=\"" << num(px) << "\" y1=\"" << num(ay.map(s.y_low[i], y0, y1)) << "\" x2=\"" << num(px)
          << "\" y2=\"" << num(ay.map(s.y_high[i], y0, y1)) << "\" stroke=\"" << color
          << "\" stroke-opacity=\"0.6\"/>\n";
      }
    }
    if (s.line && order.size() > 1) {
      o << "<polyline fill=\"none\" stroke=\"" << color << "\" stroke-width=\"1.6\""
        << (s.dashed ? " stroke-dasharray=\"6,3\"" : "") << " points=\"";
      for (size_t i : order) o << num(ax.map(s.x[i], x0, x1)) << "," << num(ay.map(s.y[i], y0, y1)) << " ";
      o << "\"/>\n";
    }
    if (s.markers)
      for (size_t i : order) marker(o, int(si), ax.map(s.x[i], x0, x1), ay.map(s.y[i], y0, y1), color);
  }

  // Legend (top-left inside the plot area, on a translucent box).
  if (!plot.series.empty()) {
    size_t longest = 0;
    for (const Series& s : plot.series) longest = std::max(longest, s.name.size());
    double lw = 34 + 6.2 * double(longest), lh = 8 + 15 * double(plot.series.size());
    // Place the legend in the plot-area corner that hides the fewest data points (points and
    // samples along the lines), so it never sits on the curves when a free corner exists.
    std::vector<std::pair<double, double>> pts;
    for (const Series& s : plot.series) {
      std::vector<size_t> order;
      for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i)
        if (usable(s.x[i], plot.log_x) && usable(s.y[i], plot.log_y)) order.push_back(i);
      std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return s.x[a] < s.x[b]; });
      for (size_t k = 0; k < order.size(); ++k) {
        double px = ax.map(s.x[order[k]], x0, x1), py = ay.map(s.y[order[k]], y0, y1);
        pts.emplace_back(px, py);
        if (k + 1 < order.size() && s.line) {
          double qx = ax.map(s.x[order[k + 1]], x0, x1), qy = ay.map(s.y[order[k + 1]], y0, y1);
          constexpr int kLineSamples = 16;
          for (int j = 1; j < kLineSamples; ++j)
            pts.emplace_back(px + (qx - px) * j / kLineSamples, py + (qy - py) * j / kLineSamples);
        }
      }
    }
    const double cand[4][2] = {{x0 + 8, y1 + 8}, {x1 - 8 - lw, y1 + 8}, {x0 + 8, y0 - 8 - lh}, {x1 - 8 - lw, y0 - 8 - lh}};
    size_t best = 0, best_hits = SIZE_MAX;
    for (size_t c = 0; c < 4; ++c) {
      size_t hits = 0;
      for (const auto& p : pts)
        hits += p.first >= cand[c][0] - 4 && p.first <= cand[c][0] + lw + 4 && p.second >= cand[c][1] - 4 &&
                p.second <= cand[c][1] + lh + 4;
      if (hits < best_hits) {
        best_hits = hits;
        best = c;
      }
    }
    double lx = cand[best][0], ly = cand[best][1];
    o << "<rect x=\"" << num(lx) << "\" y=\"" << num(ly) << "\" width=\"" << num(lw) << "\" height=\"" << num(lh)
      << "\" fill=\"white\" fill-opacity=\"0.85\" stroke=\"#bbb\"/>\n";
    for (size_t si = 0; si < plot.series.size(); ++si) {
      const int ci = plot.series[si].color >= 0 ? plot.series[si].color : int(si);
      const char* color = kPalette[size_t(ci) % kPaletteSize];
      double yy = ly + 12 + 15 * double(si);
      o << "<line x1=\"" << num(lx + 5) << "\" y1=\"" << num(yy) << "\" x2=\"" << num(lx + 25) << "\" y2=\""
        << num(yy) << "\" stroke=\"" << color << "\" stroke-width=\"1.6\""
        << (plot.series[si].dashed ? " stroke-dasharray=\"6,3\"" : "") << "/>\n";
      marker(o, int(si), lx + 15, yy, color);
      o << "<text x=\"" << num(lx + 30) << "\" y=\"" << num(yy + 4) << "\">" << esc(plot.series[si].name)
        << "</text>\n";
    }
  }
  o << "</svg>\n";
  return o.str();
}

}  // namespace vgeo::bench

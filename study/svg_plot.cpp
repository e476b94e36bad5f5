#include "study/svg_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>

namespace kgd::study {
namespace {

constexpr double kWidth = 720, kHeight = 440, kLeft = 80, kRight = 190, kTop = 40, kBottom = 60;
const char* kColours[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f"};

std::string Escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '<') out += "&lt;";
    else if (c == '>') out += "&gt;";
    else if (c == '&') out += "&amp;";
    else out += c;
  }
  return out;
}

struct Axis {
  bool log = false;
  double lo = 0, hi = 1;
  double Map(double v) const { return log ? (std::log10(v) - lo) / (hi - lo) : (v - lo) / (hi - lo); }
  std::vector<double> Ticks() const {
    std::vector<double> t;
    if (log) {
      for (double e = std::floor(lo); e <= std::ceil(hi) + 1e-9; e += 1.0)
        if (e >= lo - 1e-9 && e <= hi + 1e-9) t.push_back(std::pow(10.0, e));
      return t;
    }
    const double span = hi - lo, raw = span / 5, mag = std::pow(10.0, std::floor(std::log10(raw)));
    const double step = raw / mag < 2 ? 2 * mag : raw / mag < 5 ? 5 * mag : 10 * mag;
    for (double v = std::ceil(lo / step) * step; v <= hi + 1e-9 * span; v += step) t.push_back(v);
    return t;
  }
};

bool Shown(const Axis& a, double v) { return std::isfinite(v) && (!a.log || v > 0); }

Axis MakeAxis(bool log, const std::vector<double>& values) {
  Axis a;
  a.log = log;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (double v : values) {
    if (!std::isfinite(v) || (log && v <= 0)) continue;
    const double w = log ? std::log10(v) : v;
    lo = std::min(lo, w);
    hi = std::max(hi, w);
  }
  if (!std::isfinite(lo)) lo = 0, hi = 1;
  if (log) {
    lo = std::floor(lo);
    hi = std::ceil(hi);
    if (hi <= lo) hi = lo + 1;
  } else {
    const double pad = hi > lo ? 0.05 * (hi - lo) : std::max(1e-12, 0.1 * std::abs(hi));
    lo -= pad;
    hi += pad;
  }
  a.lo = lo;
  a.hi = hi;
  return a;
}

std::string Number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

}  // namespace

Status WriteSvgPlot(const std::string& path, const Plot& plot) {
  std::vector<double> xs, ys;
  for (const PlotSeries& s : plot.series)
    for (const auto& [x, y] : s.points) {
      xs.push_back(x);
      ys.push_back(y);
    }
  const Axis ax = MakeAxis(plot.log_x, xs), ay = MakeAxis(plot.log_y, ys);
  const double pw = kWidth - kLeft - kRight, ph = kHeight - kTop - kBottom;
  auto X = [&](double x) { return kLeft + pw * ax.Map(x); };
  auto Y = [&](double y) { return kTop + ph * (1 - ay.Map(y)); };
  std::ostringstream svg;
  svg << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << kWidth << "\" height=\"" << kHeight << "\" viewBox=\"0 0 " << kWidth
      << " " << kHeight << "\" font-family=\"sans-serif\" font-size=\"12\">\n";
  svg << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  svg << "<text x=\"" << kWidth / 2 << "\" y=\"22\" text-anchor=\"middle\" font-size=\"14\">" << Escape(plot.title) << "</text>\n";
  svg << "<rect x=\"" << kLeft << "\" y=\"" << kTop << "\" width=\"" << pw << "\" height=\"" << ph << "\" fill=\"none\" stroke=\"#333\"/>\n";
  for (double t : ax.Ticks()) {
    const double x = X(t);
    svg << "<line x1=\"" << x << "\" y1=\"" << kTop << "\" x2=\"" << x << "\" y2=\"" << kTop + ph << "\" stroke=\"#ddd\"/>\n";
    svg << "<text x=\"" << x << "\" y=\"" << kTop + ph + 16 << "\" text-anchor=\"middle\">" << Number(t) << "</text>\n";
  }
  for (double t : ay.Ticks()) {
    const double y = Y(t);
    svg << "<line x1=\"" << kLeft << "\" y1=\"" << y << "\" x2=\"" << kLeft + pw << "\" y2=\"" << y << "\" stroke=\"#ddd\"/>\n";
    svg << "<text x=\"" << kLeft - 6 << "\" y=\"" << y + 4 << "\" text-anchor=\"end\">" << Number(t) << "</text>\n";
  }
  svg << "<text x=\"" << kLeft + pw / 2 << "\" y=\"" << kHeight - 18 << "\" text-anchor=\"middle\">" << Escape(plot.x_label) << "</text>\n";
  svg << "<text transform=\"translate(18," << kTop + ph / 2 << ") rotate(-90)\" text-anchor=\"middle\">" << Escape(plot.y_label)
      << "</text>\n";
  for (size_t k = 0; k < plot.series.size(); ++k) {
    const PlotSeries& s = plot.series[k];
    const char* colour = kColours[k % (sizeof kColours / sizeof kColours[0])];
    std::ostringstream line;
    int shown = 0;
    for (const auto& [x, y] : s.points) {
      if (!Shown(ax, x) || !Shown(ay, y)) continue;
      line << (shown++ ? " " : "") << X(x) << "," << Y(y);
      if (!s.lines || s.points.size() < 40)
        svg << "<circle cx=\"" << X(x) << "\" cy=\"" << Y(y) << "\" r=\"3\" fill=\"" << colour << "\"/>\n";
    }
    if (s.lines && shown > 1)
      svg << "<polyline points=\"" << line.str() << "\" fill=\"none\" stroke=\"" << colour << "\" stroke-width=\"1.5\"/>\n";
    const double ly = kTop + 10 + 18 * k;
    svg << "<rect x=\"" << kLeft + pw + 12 << "\" y=\"" << ly - 8 << "\" width=\"12\" height=\"12\" fill=\"" << colour << "\"/>\n";
    svg << "<text x=\"" << kLeft + pw + 30 << "\" y=\"" << ly + 2 << "\">" << Escape(s.name) << "</text>\n";
  }
  svg << "</svg>\n";
  const std::string tmp = path + ".tmp";
  {
    std::ofstream f(tmp);
    f << svg.str();
    if (!f) return Status::Error(path + ": cannot write");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) return Status::Error(path + ": cannot write");
  return Status::Ok();
}

}  // namespace kgd::study

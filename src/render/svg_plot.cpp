#include <gshell/render/svg_plot.h>

#include <gshell/render/color_map.h>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace gshell {
namespace {

std::string fixed(double v) {
  std::ostringstream out;
  out.setf(std::ios::fixed);
  out.precision(1);
  out << v;
  return out.str();
}

// About `count` round tick values covering [lo, hi].
std::vector<double> linear_ticks(double lo, double hi, int count) {
  if (!(hi > lo)) return {lo};
  const double step = round_up_nice((hi - lo) / count);
  std::vector<double> ticks;
  for (double t = std::ceil(lo / step - 1e-9) * step; t <= hi + 1e-9 * step; t += step)
    ticks.push_back(std::abs(t) < 1e-12 * step ? 0.0 : t);
  return ticks;
}

} // namespace

std::string svg_line_plot(const std::vector<double>& y, const PlotOptions& options) {
  return svg_line_plot(std::vector<PlotSeries>{{"", y}}, options);
}

std::string svg_line_plot(const std::vector<PlotSeries>& series, const PlotOptions& options) {
  static const char* palette[] = {"#1f5fbf", "#d9480f", "#2b8a3e", "#7048e8", "#c2255c"};
  const double W = options.width, H = options.height;
  const bool legend = series.size() > 1;
  const double left = 70, right = 16, top = (options.title.empty() ? 12 : 30) + (legend ? 16 : 0), bottom = 44;
  std::vector<std::vector<std::pair<double, double>>> lines;
  size_t longest = 0;
  for (const auto& s : series) {
    lines.emplace_back();
    longest = std::max(longest, s.y.size());
    for (size_t i = 0; i < s.y.size(); ++i)
      if (std::isfinite(s.y[i])) lines.back().emplace_back(options.x_start + static_cast<double>(i), s.y[i]);
  }
  std::vector<std::pair<double, double>> points; // all of them, for the axes
  for (const auto& line : lines) points.insert(points.end(), line.begin(), line.end());
  bool log_y = options.log_y && !points.empty() &&
               std::all_of(points.begin(), points.end(), [](const auto& p) { return p.second > 0; });

  double x_lo = options.x_start, x_hi = options.x_start + std::max<double>(1, static_cast<double>(longest) - 1);
  double y_lo = 0, y_hi = 1;
  if (!points.empty()) {
    y_lo = y_hi = log_y ? std::log10(points[0].second) : points[0].second;
    for (const auto& p : points) {
      const double v = log_y ? std::log10(p.second) : p.second;
      y_lo = std::min(y_lo, v);
      y_hi = std::max(y_hi, v);
    }
  }
  if (log_y) {
    y_lo = std::floor(y_lo);
    y_hi = std::max(std::ceil(y_hi), y_lo + 1);
  } else {
    if (y_lo > 0 && y_lo < 0.5 * y_hi) y_lo = 0; // start at zero unless the data sits far from it
    if (!(y_hi > y_lo)) {
      // A constant series (counts that stay 0) is padded, but not below zero when it is not
      // negative: an axis from -1 suggested negative counts were possible.
      const double pad = std::abs(y_hi) > 0 ? 0.1 * std::abs(y_hi) : 1;
      y_lo = y_lo >= 0 ? std::max(0.0, y_lo - pad) : y_lo - pad;
      y_hi += pad;
    }
    const std::vector<double> t = linear_ticks(y_lo, y_hi, 5);
    const double step = t.size() > 1 ? t[1] - t[0] : 1;
    y_lo = std::floor(y_lo / step + 1e-9) * step;
    y_hi = std::ceil(y_hi / step - 1e-9) * step;
  }
  auto sx = [&](double x) { return left + (x - x_lo) / (x_hi - x_lo) * (W - left - right); };
  auto sy = [&](double v) { return H - bottom - (v - y_lo) / (y_hi - y_lo) * (H - top - bottom); };

  std::ostringstream svg;
  svg << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << W << "\" height=\"" << H << "\" viewBox=\"0 0 " << W
      << ' ' << H << "\" font-family=\"sans-serif\" font-size=\"11\">\n";
  svg << "<rect x=\"0\" y=\"0\" width=\"" << W << "\" height=\"" << H << "\" fill=\"#ffffff\"/>\n";
  if (!options.title.empty())
    svg << "<text x=\"" << W / 2 << "\" y=\"18\" text-anchor=\"middle\" font-size=\"13\" font-weight=\"bold\">"
        << xml_escape(options.title) << "</text>\n";
  // Grid and y ticks.
  std::vector<double> y_ticks;
  if (log_y)
    for (double d = y_lo; d <= y_hi + 1e-9; d += std::max(1.0, std::ceil((y_hi - y_lo) / 6))) y_ticks.push_back(d);
  else
    y_ticks = linear_ticks(y_lo, y_hi, 5);
  for (double t : y_ticks) {
    const double py = sy(t);
    svg << "<line x1=\"" << fixed(left) << "\" y1=\"" << fixed(py) << "\" x2=\"" << fixed(W - right) << "\" y2=\"" << fixed(py)
        << "\" stroke=\"#e4e4e4\"/>\n";
    svg << "<text x=\"" << fixed(left - 6) << "\" y=\"" << fixed(py + 4) << "\" text-anchor=\"end\">"
        << xml_escape(format_number(log_y ? std::pow(10.0, t) : t, 3)) << "</text>\n";
  }
  for (double t : linear_ticks(x_lo, x_hi, 8)) {
    if (std::abs(t - std::round(t)) > 1e-9) continue; // integer steps only
    const double px = sx(t);
    svg << "<line x1=\"" << fixed(px) << "\" y1=\"" << fixed(H - bottom) << "\" x2=\"" << fixed(px) << "\" y2=\""
        << fixed(H - bottom + 4) << "\" stroke=\"#444444\"/>\n";
    svg << "<text x=\"" << fixed(px) << "\" y=\"" << fixed(H - bottom + 16) << "\" text-anchor=\"middle\">"
        << format_number(t, 6) << "</text>\n";
  }
  svg << "<rect x=\"" << fixed(left) << "\" y=\"" << fixed(top) << "\" width=\"" << fixed(W - left - right) << "\" height=\""
      << fixed(H - top - bottom) << "\" fill=\"none\" stroke=\"#444444\"/>\n";
  if (!options.x_label.empty())
    svg << "<text x=\"" << fixed(left + (W - left - right) / 2) << "\" y=\"" << fixed(H - 8) << "\" text-anchor=\"middle\">"
        << xml_escape(options.x_label) << "</text>\n";
  if (!options.y_label.empty())
    svg << "<text transform=\"translate(14 " << fixed(top + (H - top - bottom) / 2) << ") rotate(-90)\" text-anchor=\"middle\">"
        << xml_escape(options.y_label + (log_y ? " (log)" : "")) << "</text>\n";
  for (size_t k = 0; k < lines.size(); ++k) {
    if (lines[k].empty()) continue;
    const char* color = palette[k % 5];
    svg << "<polyline fill=\"none\" stroke=\"" << color << "\" stroke-width=\"2\" points=\"";
    for (const auto& p : lines[k]) svg << fixed(sx(p.first)) << ',' << fixed(sy(log_y ? std::log10(p.second) : p.second)) << ' ';
    svg << "\"/>\n";
    if (lines[k].size() <= 60)
      for (const auto& p : lines[k])
        svg << "<circle cx=\"" << fixed(sx(p.first)) << "\" cy=\"" << fixed(sy(log_y ? std::log10(p.second) : p.second))
            << "\" r=\"2.5\" fill=\"" << color << "\"/>\n";
  }
  if (legend) { // one row between the title and the frame
    double lx = left;
    for (size_t k = 0; k < series.size(); ++k) {
      const double ly = top - 8;
      svg << "<line x1=\"" << fixed(lx) << "\" y1=\"" << fixed(ly - 4) << "\" x2=\"" << fixed(lx + 20) << "\" y2=\""
          << fixed(ly - 4) << "\" stroke=\"" << palette[k % 5] << "\" stroke-width=\"2\"/>\n";
      svg << "<text x=\"" << fixed(lx + 25) << "\" y=\"" << fixed(ly) << "\">" << xml_escape(series[k].name) << "</text>\n";
      lx += 40 + 7.0 * static_cast<double>(series[k].name.size());
    }
  }
  svg << "</svg>\n";
  return svg.str();
}

} // namespace gshell

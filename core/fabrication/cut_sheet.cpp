#include "core/fabrication/cut_sheet.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <sstream>

namespace kgd {
namespace {

using Point = Eigen::Vector2d;

// A piece's placement on the pattern sheet: mm = rotation * (m - centre) * 1000 + offset.
struct Placement {
  Eigen::Matrix2d rotation = Eigen::Matrix2d::Identity();
  Point centre = Point::Zero(), offset = Point::Zero();
  Point operator()(const Point& m) const { return rotation * (m - centre) * 1000 + offset; }
};

std::vector<Point> Points(const FlatPositions& p) {
  std::vector<Point> out(p.rows());
  for (Eigen::Index i = 0; i < p.rows(); ++i) out[i] = p.row(i).transpose();
  return out;
}

// Where the segments ab and cd cross (strictly inside both), if they do.
std::optional<Point> Crossing(const Point& a, const Point& b, const Point& c, const Point& d) {
  const Point r = b - a, s = d - c;
  const double denominator = r.x() * s.y() - r.y() * s.x();
  if (std::abs(denominator) < 1e-300) return std::nullopt;
  const Point ac = c - a;
  const double t = (ac.x() * s.y() - ac.y() * s.x()) / denominator, u = (ac.x() * r.y() - ac.y() * r.x()) / denominator;
  if (t <= 0 || t >= 1 || u <= 0 || u >= 1) return std::nullopt;
  return a + t * r;
}

// The closed polygon `p` (counter-clockwise) moved outward by d (mitred, a mitre at most 3 d long).
// Where the line bends inward more tightly than d, the moved points cross over one another: each such
// loop is cut off at the crossing (the segments within 4 d of arc length are searched).
std::vector<Point> Offset(const std::vector<Point>& p, double d) {
  const size_t n = p.size();
  std::vector<Point> moved(n);
  double perimeter = 0;
  for (size_t i = 0; i < n; ++i) {
    const Point a = (p[i] - p[(i + n - 1) % n]).normalized(), b = (p[(i + 1) % n] - p[i]).normalized();
    const Point na(a.y(), -a.x()), nb(b.y(), -b.x());  // outward for counter-clockwise
    Point m = na + nb;
    const double len = m.norm();
    if (len < 1e-9) m = na;
    else m /= len;
    const double c = std::max(m.dot(na), 1.0 / 3);
    moved[i] = p[i] + m * (d / c);
    perimeter += (p[(i + 1) % n] - p[i]).norm();
  }
  if (n < 4 || !(d > 0)) return moved;
  // Start at the point farthest out (on the convex hull, so on no loop); a window of segments.
  size_t start = 0;
  for (size_t i = 1; i < n; ++i)
    if (moved[i].x() > moved[start].x()) start = i;
  const size_t window = std::min(n / 2, static_cast<size_t>(std::ceil(4 * d / (perimeter / n))) + 4);
  std::vector<Point> ring(n);
  for (size_t i = 0; i < n; ++i) ring[i] = moved[(start + i) % n];
  std::vector<Point> out = {ring[0]};
  for (size_t i = 0; i < n;) {
    const Point a = out.back(), b = ring[(i + 1) % n];
    size_t skip_to = 0;
    Point at;
    // The farthest crossing within the window cuts the largest loop.
    for (size_t j = i + 2; j <= std::min(i + window, n - 1); ++j)
      if (std::optional<Point> x = Crossing(a, b, ring[j], ring[(j + 1) % n])) skip_to = j, at = *x;
    if (skip_to) {
      out.push_back(at);
      i = skip_to;  // on from the crossing along segment (skip_to, skip_to + 1)
    } else {
      if (i + 1 < n) out.push_back(b);
      ++i;
    }
  }
  return out;
}

// A piece's sew line (its outline, if it has none) and the sew line point of outline vertex k.
std::vector<Point> SewLine(const PatternPiece& piece) {
  if (piece.sew_line.rows() == 0) {
    std::vector<Point> out;
    for (int v : piece.outline) out.push_back(piece.flat.row(v).transpose());
    return out;
  }
  return Points(piece.sew_line);
}
size_t SewIndex(const PatternPiece& piece, size_t k) { return piece.sew_line.rows() == 0 ? k : static_cast<size_t>(piece.sew_at[k]); }

std::pair<Point, Point> Bounds(const std::vector<Point>& p) {
  Point lo = Point::Constant(1e300), hi = Point::Constant(-1e300);
  for (const Point& q : p) lo = lo.cwiseMin(q), hi = hi.cwiseMax(q);
  return {lo, hi};
}

void Cross(Sheet* s, const std::string& layer, const Point& c, double r) {
  s->paths.push_back({layer, {c - Point(r, 0), c + Point(r, 0)}, false});
  s->paths.push_back({layer, {c - Point(0, r), c + Point(0, r)}, false});
}

std::string Number(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.4f", v);
  std::string s = b;
  while (!s.empty() && s.back() == '0') s.pop_back();
  if (!s.empty() && s.back() == '.') s.pop_back();
  return s == "-0" ? "0" : s;
}

std::string Escape(const std::string& t) {
  std::string o;
  for (char c : t) o += c == '<' ? "&lt;" : c == '>' ? "&gt;" : c == '&' ? "&amp;" : std::string(1, c);
  return o;
}

}  // namespace

std::vector<SeamSides> SeamLengths(const Pattern& pattern) {
  // Every outline edge by its garment vertices (both orders), with the length in mm of the sew line
  // along it (from the point of its first vertex to that of its second).
  std::multimap<std::pair<int, int>, double> edges;
  for (const PatternPiece& p : pattern.pieces) {
    const std::vector<Point> sew = SewLine(p);
    const size_t m = sew.size();
    for (size_t k = 0; k < p.outline.size(); ++k) {
      const size_t next = (k + 1) % p.outline.size();
      const int ga = p.garment_vertex[p.outline[k]], gb = p.garment_vertex[p.outline[next]];
      const size_t from = SewIndex(p, k), to = SewIndex(p, next);
      double length = 0;
      for (size_t i = from; i != to; i = (i + 1) % m) length += (sew[(i + 1) % m] - sew[i]).norm();
      edges.insert({{std::min(ga, gb), std::max(ga, gb)}, 1000 * length});
    }
  }
  std::vector<SeamSides> out;
  for (const Seam& seam : pattern.seams) {
    SeamSides s;
    for (size_t i = 0; i + 1 < seam.vertices.size(); ++i) {
      const int a = seam.vertices[i], b = seam.vertices[i + 1];
      const auto [lo, hi] = edges.equal_range({std::min(a, b), std::max(a, b)});
      std::vector<double> sides;
      for (auto it = lo; it != hi; ++it) sides.push_back(it->second);
      if (sides.size() >= 1) s.a_mm += sides[0];
      if (sides.size() >= 2) s.b_mm += sides[1];
    }
    out.push_back(s);
  }
  return out;
}

Sheet PatternSheet(const Pattern& pattern, const std::vector<Patch>& patches, const SheetOptions& o) {
  Sheet sheet;
  sheet.title = "pattern pieces";
  const double margin = o.seam_allowance_mm + 10;
  double x = 0, height = 0;
  std::vector<Placement> placement(pattern.pieces.size());
  for (size_t i = 0; i < pattern.pieces.size(); ++i) {
    const PatternPiece& piece = pattern.pieces[i];
    Placement& pl = placement[i];
    // Long axis vertical: the grain runs along it.
    pl.centre = piece.flat.colwise().mean().transpose();
    Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
    for (Eigen::Index v = 0; v < piece.flat.rows(); ++v) {
      const Point d = piece.flat.row(v).transpose() - pl.centre;
      cov += d * d.transpose();
    }
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(cov);
    const Point axis = eig.eigenvectors().col(1);  // the larger eigenvalue's
    const double angle = std::atan2(axis.x(), axis.y());  // turns `axis` onto +y
    pl.rotation << std::cos(angle), -std::sin(angle), std::sin(angle), std::cos(angle);
    const std::vector<Point> sew = SewLine(piece);
    std::vector<Point> outline;
    for (const Point& q : sew) outline.push_back(pl(q));
    const auto [lo, hi] = Bounds(outline);
    pl.offset = Point(x + margin - lo.x(), margin - lo.y());
    outline.clear();
    for (const Point& q : sew) outline.push_back(pl(q));
    sheet.paths.push_back({"14", outline, true});
    sheet.paths.push_back({"1", Offset(outline, o.seam_allowance_mm), true});
    const auto [blo, bhi] = Bounds(outline);
    const Point c = 0.5 * (blo + bhi);
    const double h = bhi.y() - blo.y();
    // Grain line with arrowheads.
    const Point top(c.x(), c.y() + 0.3 * h), bottom(c.x(), c.y() - 0.3 * h);
    sheet.paths.push_back({"7", {bottom, top}, false});
    sheet.paths.push_back({"7", {top + Point(-3, -6), top, top + Point(3, -6)}, false});
    sheet.paths.push_back({"7", {bottom + Point(-3, 6), bottom, bottom + Point(3, 6)}, false});
    sheet.texts.push_back({"15", Point(c.x() + 3, c.y()), 5, "piece " + std::to_string(i + 1) + " of " + std::to_string(pattern.pieces.size())});
    if (!o.label.empty()) sheet.texts.push_back({"15", Point(c.x() + 3, c.y() - 7), 3.5, o.label});
    sheet.texts.push_back({"15", Point(c.x() + 3, c.y() - 12), 3.5, "grain; seam allowance " + Number(o.seam_allowance_mm) + " mm"});
    x = bhi.x() + o.seam_allowance_mm + margin - 10;
    height = std::max(height, bhi.y() + margin);
  }
  // Notches: where a seam's middle vertex lies on a piece's sew line, across the allowance.
  for (const Seam& seam : pattern.seams) {
    const int g = seam.vertices[seam.vertices.size() / 2];
    for (size_t i = 0; i < pattern.pieces.size(); ++i) {
      const PatternPiece& piece = pattern.pieces[i];
      const std::vector<Point> sew = SewLine(piece);
      const size_t n = piece.outline.size(), m = sew.size();
      for (size_t k = 0; k < n; ++k) {
        if (piece.garment_vertex[piece.outline[k]] != g) continue;
        const size_t at = SewIndex(piece, k);
        const Point p = placement[i](sew[at]);
        const Point a = placement[i](sew[(at + m - 1) % m]);
        const Point b = placement[i](sew[(at + 1) % m]);
        const Point t = (b - a).normalized(), out(t.y(), -t.x());
        sheet.paths.push_back({"4", {p, p + out * o.seam_allowance_mm * 0.6}, false});
      }
    }
  }
  // Placement guides: every patch on its piece, with a registration cross at its centre.
  for (const Patch& patch : patches) {
    const Placement& pl = placement[patch.piece];
    std::vector<Point> outline;
    for (const Point& q : Points(patch.outline)) outline.push_back(pl(q));
    sheet.paths.push_back({"8", outline, true});
    for (const FlatPositions& h : patch.holes) {
      std::vector<Point> hole;
      for (const Point& q : Points(h)) hole.push_back(pl(q));
      sheet.paths.push_back({"8", hole, true});
    }
    const auto [lo, hi] = Bounds(outline);
    Cross(&sheet, "8", 0.5 * (lo + hi), 3);
  }
  sheet.width_mm = std::max(x + 10, 40.0);
  sheet.height_mm = std::max(height, 40.0);
  return sheet;
}

Result<Sheet> PatchSheet(const std::vector<Patch>& patches, const SheetOptions& o, double* usage) {
  Sheet sheet;
  sheet.title = "reinforcement patches";
  sheet.width_mm = o.sheet_width_mm;
  struct Item {
    size_t index;
    std::vector<std::vector<Point>> loops;  // outline, holes (mm, at the origin)
    Point size;
  };
  std::vector<Item> items;
  double patch_area = 0;
  for (size_t i = 0; i < patches.size(); ++i) {
    Item it{i, {}, {}};
    std::vector<std::vector<Point>> loops = {Points(patches[i].outline)};
    for (const FlatPositions& h : patches[i].holes) loops.push_back(Points(h));
    for (auto& loop : loops)
      for (Point& q : loop) q *= 1000;
    auto [lo, hi] = Bounds(loops[0]);
    Point size = hi - lo;
    // Turn by 90 degrees when that makes the patch lower on the roll and it still fits across.
    const bool turn = (size.x() > o.sheet_width_mm - 2 * o.gap_mm) || (size.y() < size.x() && size.y() <= o.sheet_width_mm - 2 * o.gap_mm);
    if (turn)
      for (auto& loop : loops)
        for (Point& q : loop) q = Point(-q.y(), q.x());
    if (o.mirror)
      for (auto& loop : loops)
        for (Point& q : loop) q.x() = -q.x();
    std::tie(lo, hi) = Bounds(loops[0]);
    for (auto& loop : loops)
      for (Point& q : loop) q -= lo;
    it.size = hi - lo;
    if (it.size.x() > o.sheet_width_mm - 2 * o.gap_mm)
      return Status::Error("patch " + std::to_string(i + 1) + " is " + Number(std::min(it.size.x(), it.size.y())) + " mm across at its narrowest, wider than the " +
                           Number(o.sheet_width_mm) + " mm sheet (--sheet-width-mm)");
    it.loops = std::move(loops);
    patch_area += 1e6 * std::abs(patches[i].outline_area_m2);
    items.push_back(std::move(it));
  }
  std::sort(items.begin(), items.end(), [](const Item& a, const Item& b) { return a.size.y() > b.size.y(); });
  // Shelves: left to right, a new shelf when the roll's width is used.
  double x = o.gap_mm, y = o.gap_mm, shelf = 0;
  for (const Item& it : items) {
    if (x + it.size.x() > o.sheet_width_mm - o.gap_mm) x = o.gap_mm, y += shelf + o.gap_mm, shelf = 0;
    const Point at(x, y);
    for (size_t k = 0; k < it.loops.size(); ++k) {
      std::vector<Point> loop = it.loops[k];
      for (Point& q : loop) q += at;
      sheet.paths.push_back({"1", loop, true});
    }
    sheet.texts.push_back({"15", at + Point(1, -0.5 * o.gap_mm + 1), 2, std::to_string(it.index + 1)});
    x += it.size.x() + o.gap_mm;
    shelf = std::max(shelf, it.size.y());
  }
  sheet.height_mm = y + shelf + o.gap_mm;
  if (usage) *usage = sheet.height_mm > 0 ? patch_area / (sheet.width_mm * sheet.height_mm) : 0;
  return sheet;
}

uint32_t LayerColour(const std::string& layer) {
  if (layer == "1" || layer == "4") return 0xff0000;
  if (layer == "8") return 0x0050ff;
  if (layer == "14") return 0x808080;
  return 0x000000;
}

std::string SvgText(const Sheet& s) {
  // A margin on top for the calibration square.
  const double w = s.width_mm, h = s.height_mm + 20;
  std::ostringstream o;
  o << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
    << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << Number(w) << "mm\" height=\"" << Number(h) << "mm\" viewBox=\"0 0 " << Number(w)
    << " " << Number(h) << "\">\n<title>" << Escape(s.title) << "</title>\n";
  auto hex = [](const std::string& layer) {
    char buf[8];
    std::snprintf(buf, sizeof(buf), "#%06x", LayerColour(layer));
    return std::string(buf);
  };
  const std::map<std::string, std::pair<std::string, std::string>> style = {
      {"1", {"cut", "stroke=\"" + hex("1") + "\" stroke-width=\"0.01\" fill=\"none\""}},
      {"4", {"notches", "stroke=\"" + hex("4") + "\" stroke-width=\"0.01\" fill=\"none\""}},
      {"7", {"grain", "stroke=\"" + hex("7") + "\" stroke-width=\"0.3\" fill=\"none\""}},
      {"8", {"guides", "stroke=\"" + hex("8") + "\" stroke-width=\"0.3\" fill=\"none\" stroke-dasharray=\"2 1\""}},
      {"14", {"sew", "stroke=\"" + hex("14") + "\" stroke-width=\"0.3\" fill=\"none\" stroke-dasharray=\"4 2\""}},
      {"15", {"labels", "fill=\"" + hex("15") + "\" font-family=\"sans-serif\""}}};
  auto y = [&](double v) { return Number(h - v); };  // y up in the sheet, down in SVG
  for (const auto& [layer, st] : style) {
    bool any = false;
    for (const SheetPath& p : s.paths) any |= p.layer == layer;
    for (const SheetText& t : s.texts) any |= t.layer == layer;
    if (!any) continue;
    o << "<g id=\"" << st.first << "\" data-layer=\"" << layer << "\" " << st.second << ">\n";
    for (const SheetPath& p : s.paths) {
      if (p.layer != layer) continue;
      o << (p.closed ? "<polygon" : "<polyline") << " points=\"";
      for (size_t i = 0; i < p.points.size(); ++i) o << (i ? " " : "") << Number(p.points[i].x()) << "," << y(p.points[i].y());
      o << "\"/>\n";
    }
    for (const SheetText& t : s.texts)
      if (t.layer == layer)
        o << "<text x=\"" << Number(t.at.x()) << "\" y=\"" << y(t.at.y()) << "\" font-size=\"" << Number(t.height_mm) << "\">" << Escape(t.text) << "</text>\n";
    o << "</g>\n";
  }
  o << "<g id=\"calibration\" stroke=\"#000000\" stroke-width=\"0.2\" fill=\"none\">\n<rect x=\"5\" y=\"5\" width=\"10\" height=\"10\"/>\n"
    << "<text x=\"17\" y=\"13\" font-size=\"3.5\" fill=\"#000000\" stroke=\"none\">10 mm: check the print scale</text>\n</g>\n</svg>\n";
  return o.str();
}

std::string DxfText(const Sheet& s) {
  std::ostringstream o;
  auto pair = [&](int code, const std::string& value) { o << code << "\n" << value << "\n"; };
  pair(0, "SECTION");
  pair(2, "HEADER");
  pair(9, "$ACADVER");
  pair(1, "AC1009");
  pair(9, "$INSUNITS");
  pair(70, "4");
  pair(9, "$EXTMIN");
  pair(10, "0");
  pair(20, "0");
  pair(9, "$EXTMAX");
  pair(10, Number(s.width_mm));
  pair(20, Number(s.height_mm));
  pair(0, "ENDSEC");
  const std::vector<std::pair<std::string, int>> layers = {{"1", 1}, {"4", 1}, {"7", 7}, {"8", 5}, {"14", 8}, {"15", 7}};
  pair(0, "SECTION");
  pair(2, "TABLES");
  pair(0, "TABLE");
  pair(2, "LAYER");
  pair(70, std::to_string(layers.size()));
  for (const auto& [name, colour] : layers) {
    pair(0, "LAYER");
    pair(2, name);
    pair(70, "0");
    pair(62, std::to_string(colour));
    pair(6, "CONTINUOUS");
  }
  pair(0, "ENDTAB");
  pair(0, "ENDSEC");
  pair(0, "SECTION");
  pair(2, "ENTITIES");
  for (const SheetPath& p : s.paths) {
    pair(0, "POLYLINE");
    pair(8, p.layer);
    pair(66, "1");
    pair(70, p.closed ? "1" : "0");
    pair(10, "0");
    pair(20, "0");
    pair(30, "0");
    for (const Point& q : p.points) {
      pair(0, "VERTEX");
      pair(8, p.layer);
      pair(10, Number(q.x()));
      pair(20, Number(q.y()));
      pair(30, "0");
    }
    pair(0, "SEQEND");
    pair(8, p.layer);
  }
  for (const SheetText& t : s.texts) {
    pair(0, "TEXT");
    pair(8, t.layer);
    pair(10, Number(t.at.x()));
    pair(20, Number(t.at.y()));
    pair(30, "0");
    pair(40, Number(t.height_mm));
    pair(1, t.text);
  }
  pair(0, "ENDSEC");
  pair(0, "EOF");
  return o.str();
}

}  // namespace kgd

#include "core/fabrication/sheet_png.h"

#include <png.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace kgd {
namespace {

using Rgb = std::array<uint8_t, 3>;

// An image of a few flat colours (no blending), kept as indices into a palette: a third of the bytes
// of RGB to compress, and a PNG to match.
struct Canvas {
  int width = 0, height = 0;
  double scale = 1, top_mm = 0;  // pixels per mm; the sheet's y (up) of the image's first row
  std::vector<uint8_t> index;    // per pixel, into palette; 0 is the paper
  std::vector<Rgb> palette = {{255, 255, 255}};

  Eigen::Vector2d Pixel(const Eigen::Vector2d& mm) const { return {mm.x() * scale, (top_mm - mm.y()) * scale}; }
  void Put(int x, int y, const Rgb& c) {
    if (x < 0 || y < 0 || x >= width || y >= height) return;
    index[static_cast<size_t>(y) * width + x] = Colour(c);
  }
  uint8_t Colour(const Rgb& c) {
    const auto at = std::find(palette.begin(), palette.end(), c);
    if (at != palette.end()) return static_cast<uint8_t>(at - palette.begin());
    if (palette.size() == 256) return 0;  // a sheet has a dozen colours at most
    palette.push_back(c);
    return static_cast<uint8_t>(palette.size() - 1);
  }
  // A segment `thickness` pixels wide (square brush).
  void Line(Eigen::Vector2d a, Eigen::Vector2d b, const Rgb& c, int thickness) {
    const int steps = std::max(1, static_cast<int>(std::ceil((b - a).cwiseAbs().maxCoeff())));
    for (int i = 0; i <= steps; ++i) {
      const Eigen::Vector2d p = a + (b - a) * (static_cast<double>(i) / steps);
      for (int dy = 0; dy < thickness; ++dy)
        for (int dx = 0; dx < thickness; ++dx) Put(static_cast<int>(std::floor(p.x())) + dx - thickness / 2, static_cast<int>(std::floor(p.y())) + dy - thickness / 2, c);
    }
  }
  // Even-odd scanline fill of a closed polygon.
  void Fill(const std::vector<Eigen::Vector2d>& poly, const Rgb& c) {
    double lo = 1e300, hi = -1e300;
    for (const auto& p : poly) lo = std::min(lo, p.y()), hi = std::max(hi, p.y());
    for (int y = std::max(0, static_cast<int>(std::floor(lo))); y <= std::min(height - 1, static_cast<int>(std::ceil(hi))); ++y) {
      const double yc = y + 0.5;
      std::vector<double> xs;
      for (size_t i = 0; i < poly.size(); ++i) {
        const Eigen::Vector2d& a = poly[i];
        const Eigen::Vector2d& b = poly[(i + 1) % poly.size()];
        if ((a.y() <= yc) != (b.y() <= yc)) xs.push_back(a.x() + (yc - a.y()) * (b.x() - a.x()) / (b.y() - a.y()));
      }
      std::sort(xs.begin(), xs.end());
      for (size_t k = 0; k + 1 < xs.size(); k += 2)
        for (int x = std::max(0, static_cast<int>(std::ceil(xs[k] - 0.5))); x <= std::min(width - 1, static_cast<int>(std::floor(xs[k + 1] - 0.5))); ++x) Put(x, y, c);
    }
  }
};

Rgb ColourOf(uint32_t rgb) { return {static_cast<uint8_t>(rgb >> 16), static_cast<uint8_t>(rgb >> 8), static_cast<uint8_t>(rgb)}; }

}  // namespace

Result<std::string> SheetPng(const Sheet& sheet, double px_per_mm) {
  if (!(sheet.width_mm > 0) || !(sheet.height_mm > 0)) return Status::Error("PNG preview: the sheet is empty");
  constexpr double kMargin = 20;  // mm above the sheet, for the calibration square (as in the SVG)
  const double h_mm = sheet.height_mm + kMargin;
  const double scale = std::min(px_per_mm, 8192 / std::max(sheet.width_mm, h_mm));
  Canvas c;
  c.scale = scale;
  c.top_mm = h_mm;
  c.width = std::max(1, static_cast<int>(std::ceil(sheet.width_mm * scale)));
  c.height = std::max(1, static_cast<int>(std::ceil(h_mm * scale)));
  c.index.assign(static_cast<size_t>(c.width) * c.height, 0);
  auto pixels = [&](const SheetPath& p) {
    std::vector<Eigen::Vector2d> out;
    for (const auto& q : p.points) out.push_back(c.Pixel(q));
    return out;
  };
  // Fills first, so every stroke stays visible on top.
  for (const SheetPath& p : sheet.paths)
    if (p.closed && p.layer == "8" && p.points.size() >= 3) c.Fill(pixels(p), {205, 222, 255});
  for (const SheetPath& p : sheet.paths) {
    const std::vector<Eigen::Vector2d> q = pixels(p);
    const Rgb colour = ColourOf(LayerColour(p.layer));
    const int thickness = p.layer == "1" || p.layer == "4" ? 2 : 1;
    for (size_t i = 0; i + 1 < q.size(); ++i) c.Line(q[i], q[i + 1], colour, thickness);
    if (p.closed && q.size() > 2) c.Line(q.back(), q.front(), colour, thickness);
  }
  // The calibration square: 10 mm at (5, 5) mm from the top left, as in the SVG.
  const std::vector<Eigen::Vector2d> square = {c.Pixel({5, h_mm - 5}), c.Pixel({15, h_mm - 5}), c.Pixel({15, h_mm - 15}), c.Pixel({5, h_mm - 15})};
  for (size_t i = 0; i < square.size(); ++i) c.Line(square[i], square[(i + 1) % square.size()], {0, 0, 0}, 1);

  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = static_cast<png_uint_32>(c.width);
  image.height = static_cast<png_uint_32>(c.height);
  image.format = PNG_FORMAT_RGB_COLORMAP;
  image.colormap_entries = static_cast<png_uint_32>(c.palette.size());
  std::vector<uint8_t> colormap;
  for (const Rgb& rgb : c.palette) colormap.insert(colormap.end(), rgb.begin(), rgb.end());
  // Encoded once into a buffer of the largest size it can take (asking for the size first encodes twice).
  std::string bytes(PNG_IMAGE_PNG_SIZE_MAX(image), '\0');
  png_alloc_size_t size = bytes.size();
  if (!png_image_write_to_memory(&image, bytes.data(), &size, 0, c.index.data(), 0, colormap.data()))
    return Status::Error(std::string("PNG preview: ") + image.message);
  bytes.resize(size);
  return bytes;
}

}  // namespace kgd

// `kgd export` end to end: cut files read back by their own parsers (SVG polygons, DXF R12 group codes),
// a flat sample exactly, a sleeve design with its patches nested, mirrored and placed, and bad input
// refused with no file left behind.
#include <gtest/gtest.h>
#include <png.h>

#include <filesystem>
#include <fstream>
#include <algorithm>
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>

#include "tests/kgd_cli.h"

namespace kgd {
namespace {
namespace fs = std::filesystem;
using cli_test::Kgd;

using Polygon = std::vector<std::pair<double, double>>;

std::string Read(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// The closed polygons of one SVG layer (a <g data-layer="N"> group), in mm with y down as drawn.
std::vector<Polygon> SvgPolygons(const std::string& svg, const std::string& layer) {
  std::vector<Polygon> out;
  const size_t g = svg.find("data-layer=\"" + layer + "\"");
  if (g == std::string::npos) return out;
  const std::string group = svg.substr(g, svg.find("</g>", g) - g);
  const std::regex poly("<polygon points=\"([^\"]*)\"");
  for (auto it = std::sregex_iterator(group.begin(), group.end(), poly); it != std::sregex_iterator(); ++it) {
    Polygon p;
    std::istringstream points((*it)[1].str());
    for (std::string xy; points >> xy;) {
      const size_t comma = xy.find(',');
      p.push_back({std::stod(xy.substr(0, comma)), std::stod(xy.substr(comma + 1))});
    }
    out.push_back(p);
  }
  return out;
}

// Closed POLYLINEs of one DXF layer, and the header's $INSUNITS.
struct Dxf {
  int insunits = -1;
  std::map<std::string, std::vector<Polygon>> closed;
};
Dxf ParseDxf(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::pair<int, std::string>> pairs;
  for (std::string code, value; std::getline(in, code) && std::getline(in, value);) pairs.push_back({std::stoi(code), value});
  Dxf d;
  for (size_t i = 0; i < pairs.size(); ++i) {
    if (pairs[i] == std::pair<int, std::string>{9, "$INSUNITS"}) d.insunits = std::stoi(pairs[i + 1].second);
    if (pairs[i] != std::pair<int, std::string>{0, "POLYLINE"}) continue;
    std::string layer;
    bool closed = false;
    size_t j = i + 1;
    for (; pairs[j].first != 0; ++j) {
      if (pairs[j].first == 8) layer = pairs[j].second;
      if (pairs[j].first == 70) closed = std::stoi(pairs[j].second) & 1;
    }
    Polygon p;
    for (; pairs[j].second == "VERTEX"; ) {
      double x = 0, y = 0;
      for (++j; pairs[j].first != 0; ++j) {
        if (pairs[j].first == 10) x = std::stod(pairs[j].second);
        if (pairs[j].first == 20) y = std::stod(pairs[j].second);
      }
      p.push_back({x, y});
    }
    if (closed) d.closed[layer].push_back(p);
    i = j;
  }
  return d;
}

double SignedArea(const Polygon& p) {
  double a = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    const auto& [x0, y0] = p[i];
    const auto& [x1, y1] = p[(i + 1) % p.size()];
    a += x0 * y1 - x1 * y0;
  }
  return 0.5 * a;
}

std::pair<double, double> Extent(const Polygon& p) {
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  for (const auto& [x, y] : p) x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
  return {x1 - x0, y1 - y0};
}

double Perimeter(const Polygon& p) {
  double l = 0;
  for (size_t i = 0; i < p.size(); ++i) l += std::hypot(p[(i + 1) % p.size()].first - p[i].first, p[(i + 1) % p.size()].second - p[i].second);
  return l;
}

bool Inside(const Polygon& p, std::pair<double, double> q) {
  bool in = false;
  for (size_t i = 0, j = p.size() - 1; i < p.size(); j = i++)
    if ((p[i].second > q.second) != (p[j].second > q.second) &&
        q.first < (p[j].first - p[i].first) * (q.second - p[i].second) / (p[j].second - p[i].second) + p[i].first)
      in = !in;
  return in;
}

bool EdgesCross(const Polygon& a, const Polygon& b) {
  auto orient = [](std::pair<double, double> p, std::pair<double, double> q, std::pair<double, double> r) {
    return (q.first - p.first) * (r.second - p.second) - (q.second - p.second) * (r.first - p.first);
  };
  for (size_t i = 0; i < a.size(); ++i)
    for (size_t j = 0; j < b.size(); ++j) {
      const auto a0 = a[i], a1 = a[(i + 1) % a.size()], b0 = b[j], b1 = b[(j + 1) % b.size()];
      if (orient(a0, a1, b0) * orient(a0, a1, b1) < 0 && orient(b0, b1, a0) * orient(b0, b1, a1) < 0) return true;
    }
  return false;
}

fs::path TempDir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("kgd_export_test_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

TEST(Export, TheFlatSampleWithTheLineGivesA40By100MillimetreBandExactly) {
  const fs::path dir = TempDir("line");
  const auto run = Kgd("export pull_test_line --out " + (dir / "cut").string());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  for (const char* f : {"pattern.svg", "pattern.dxf", "pattern.png", "patches.svg", "patches.dxf", "patches.png", "report.json"})
    EXPECT_TRUE(fs::exists(dir / "cut" / f)) << f;
  const std::string svg = Read(dir / "cut/patches.svg");
  EXPECT_NE(svg.find("width=\"305mm\""), std::string::npos);
  EXPECT_NE(svg.find("viewBox=\"0 0 305 "), std::string::npos);
  const std::vector<Polygon> from_svg = SvgPolygons(svg, "1");
  ASSERT_EQ(from_svg.size(), 1u);
  const auto [w, h] = Extent(from_svg[0]);
  EXPECT_NEAR(std::min(w, h), 40, 0.01);
  EXPECT_NEAR(std::max(w, h), 100, 0.01);
  const Dxf dxf = ParseDxf(Read(dir / "cut/patches.dxf"));
  EXPECT_EQ(dxf.insunits, 4) << "millimetres";
  ASSERT_EQ(dxf.closed.count("1"), 1u);
  ASSERT_EQ(dxf.closed.at("1").size(), 1u);
  const auto [dw, dh] = Extent(dxf.closed.at("1")[0]);
  EXPECT_NEAR(std::min(dw, dh), 40, 0.01);
  EXPECT_NEAR(std::max(dw, dh), 100, 0.01);
  // The PNG preview at 4 px/mm: 305 mm wide; the red cut line's extent is the band's, to a pixel.
  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  const std::string png_bytes = Read(dir / "cut/patches.png");
  ASSERT_TRUE(png_image_begin_read_from_memory(&png, png_bytes.data(), png_bytes.size())) << png.message;
  png.format = PNG_FORMAT_RGB;
  std::vector<uint8_t> pixels(PNG_IMAGE_SIZE(png));
  ASSERT_TRUE(png_image_finish_read(&png, nullptr, pixels.data(), 0, nullptr)) << png.message;
  EXPECT_EQ(png.width, 1220u);
  int x0 = 1 << 30, x1 = -1, y0 = 1 << 30, y1 = -1;
  for (int y = 0; y < static_cast<int>(png.height); ++y)
    for (int x = 0; x < static_cast<int>(png.width); ++x) {
      const uint8_t* p = &pixels[3 * (static_cast<size_t>(y) * png.width + x)];
      if (p[0] == 255 && p[1] == 0 && p[2] == 0) x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
    }
  ASSERT_GE(x1, 0) << "no cut line drawn";
  const double px_w = (x1 - x0) / 4.0, px_h = (y1 - y0) / 4.0;
  EXPECT_NEAR(std::min(px_w, px_h), 40, 0.5);
  EXPECT_NEAR(std::max(px_w, px_h), 100, 0.5);
  const nlohmann::json report = nlohmann::json::parse(Read(dir / "cut/report.json"));
  ASSERT_EQ(report["pieces"].size(), 1u);
  EXPECT_EQ(report["pieces"][0]["area_distortion_max"], 0.0);
  EXPECT_EQ(report["pieces"][0]["angle_distortion_max_deg"], 0.0);
  // The pattern piece: the whole 100 x 140 mm sample, its sew line exact.
  const Dxf pattern = ParseDxf(Read(dir / "cut/pattern.dxf"));
  ASSERT_EQ(pattern.closed.at("14").size(), 1u);
  const auto [pw, ph] = Extent(pattern.closed.at("14")[0]);
  EXPECT_NEAR(std::min(pw, ph), 100, 0.01);
  EXPECT_NEAR(std::max(pw, ph), 140, 0.01);
}

TEST(Export, ASleeveDesignIsCutIntoPiecesWithPatchesNestedMirroredAndPlaced) {
  const fs::path dir = TempDir("arm");
  const std::string file = (dir / "arm.h5").string();
  const auto design = Kgd("design arm_flexion --iterations 60 --out " + file + " --json");
  ASSERT_EQ(design.exit_code, 0) << design.output;
  const auto run = Kgd("export " + file + " --out " + (dir / "cut").string() + " --json");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const nlohmann::json report = nlohmann::json::parse(run.output);
  EXPECT_EQ(report["iteration"], 60) << "the last iteration (none is within the budget yet)";
  EXPECT_NE(report.value("note", "").find("no stored iteration is within the budget (15.0 %): the last, iteration 60, reinforces"), std::string::npos)
      << "the report says the design is over the budget: " << report.dump().substr(0, 300);
  std::printf("arm flexion, iteration 60: density ratio %.4f, cleaned %.4f; %zu pieces, %zu patches, sheet usage %.2f, %.2f s\n",
              report["density_ratio"].get<double>(), report["cleaned"]["density_ratio"].get<double>(), report["pieces"].size(),
              report["patches"].size(), report["sheet_usage"].get<double>(), report["seconds"].get<double>());
  EXPECT_NEAR(report["cleaned"]["density_ratio"].get<double>(), report["density_ratio"].get<double>(), 0.03 * report["density_ratio"].get<double>());
  for (const auto& p : report["pieces"]) {
    std::printf("  piece %d: area distortion mean %.2f%% max %.2f%%, angle mean %.2f max %.2f deg\n", p["piece"].get<int>(),
                100 * p["area_distortion_mean"].get<double>(), 100 * p["area_distortion_max"].get<double>(), p["angle_distortion_mean_deg"].get<double>(),
                p["angle_distortion_max_deg"].get<double>());
    EXPECT_LE(p["area_distortion_mean"].get<double>(), 0.02);
    EXPECT_LE(p["area_distortion_max"].get<double>(), 0.05);
    EXPECT_LE(p["angle_distortion_mean_deg"].get<double>(), 2.0);
  }
  // The pieces measured from the files, not from the report's figures: the sew lines in pattern.dxf
  // (each piece's flat outline, mm) and the garment's rest area stored in the design file (`kgd
  // designs`). A sew line (the outline faired within 1 mm of it) encloses its piece's flat area to
  // within its perimeter times 1 mm; the pieces' rest areas add up to the garment's; the flat pattern
  // keeps the garment's area within 2 %; no piece's sew line encloses an area further from its rest
  // area than its reported mean area distortion and that strip allow; and every sew line turns by less
  // than 10 degrees between consecutive segments away from its corners.
  // (core/fabrication/pattern_test.cpp measures the distortion face by face.)
  const auto designs = Kgd("designs " + file + " --json");
  ASSERT_EQ(designs.exit_code, 0) << designs.output;
  const double garment_area = nlohmann::json::parse(designs.output)["garment_area_m2"].get<double>();
  const Dxf sheet = ParseDxf(Read(dir / "cut/pattern.dxf"));
  ASSERT_EQ(sheet.closed.count("14"), 1u);
  const std::vector<Polygon>& sew = sheet.closed.at("14");
  ASSERT_EQ(sew.size(), report["pieces"].size()) << "one sew line per piece";
  double rest_sum = 0, flat_sum = 0;
  for (size_t i = 0; i < sew.size(); ++i) {
    const auto& p = report["pieces"][i];
    const double flat = 1e-6 * std::abs(SignedArea(sew[i])), rest = p["rest_area_m2"].get<double>();
    const double strip = 1e-3 * Perimeter(sew[i]) * 1e-3;  // perimeter (mm to m) x 1 mm
    std::printf("  piece %zu: sew line area %.6f m^2, triangles %.6f m^2; turning max %.2f deg, within %.3f mm\n", i + 1, flat,
                p["flat_area_m2"].get<double>(), p["sew_line_turning_max_deg"].get<double>(), p["sew_line_deviation_max_mm"].get<double>());
    EXPECT_NEAR(flat, p["flat_area_m2"].get<double>(), strip) << "piece " << i + 1;
    EXPECT_LE(std::abs(flat / rest - 1), p["area_distortion_mean"].get<double>() + strip / rest) << "piece " << i + 1;
    EXPECT_LT(p["sew_line_turning_max_deg"].get<double>(), 10) << "piece " << i + 1;
    EXPECT_LE(p["sew_line_deviation_max_mm"].get<double>(), 1.0) << "piece " << i + 1;
    rest_sum += rest;
    flat_sum += flat;
  }
  EXPECT_NEAR(rest_sum, garment_area, 1e-6 * garment_area);
  EXPECT_NEAR(flat_sum / garment_area, 1.0, 0.02);
  for (const auto& s : report["seams"]) {
    std::printf("  seam %d: sides %.3f and %.3f mm\n", s["seam"].get<int>(), s["side_a_mm"].get<double>(), s["side_b_mm"].get<double>());
    EXPECT_NEAR(s["side_a_mm"].get<double>(), s["side_b_mm"].get<double>(), 0.5) << "the two sides sewn together";
  }
  std::printf("  stages:");
  for (const auto& [stage, seconds] : report["stage_seconds"].items()) std::printf(" %s %.2f s;", stage.c_str(), seconds.get<double>());
  std::printf("\n");

  // Nested patches: every outline on the sheet, and no two outlines overlap (no edges cross and
  // neither holds the other); a hole lies inside its own outline.
  const std::string svg = Read(dir / "cut/patches.svg");
  const std::vector<Polygon> patches = SvgPolygons(svg, "1");
  ASSERT_GE(patches.size(), 1u);
  std::vector<const Polygon*> outlines;
  for (const Polygon& p : patches) {
    bool hole = false;
    for (const Polygon& q : patches) hole |= &q != &p && std::abs(SignedArea(q)) > std::abs(SignedArea(p)) && Inside(q, p[0]);
    if (!hole) outlines.push_back(&p);
    for (const auto& [x, y] : p) {
      EXPECT_GE(x, 0);
      EXPECT_LE(x, 305);
      EXPECT_GE(y, 0);
    }
  }
  ASSERT_EQ(outlines.size(), report["patches"].size());
  size_t overlaps = 0;
  for (size_t i = 0; i < outlines.size(); ++i)
    for (size_t j = i + 1; j < outlines.size(); ++j)
      overlaps += EdgesCross(*outlines[i], *outlines[j]) || Inside(*outlines[i], (*outlines[j])[0]) || Inside(*outlines[j], (*outlines[i])[0]);
  EXPECT_EQ(overlaps, 0u);

  // Placement guides on the pieces are the patches, moved: the same areas and perimeters, one by one
  // (to the SVG's printed precision).
  const std::vector<Polygon> guides = SvgPolygons(Read(dir / "cut/pattern.svg"), "8");
  ASSERT_EQ(guides.size(), patches.size());
  std::vector<std::pair<double, double>> guide_shapes, patch_shapes;
  for (const Polygon& p : guides) guide_shapes.push_back({std::abs(SignedArea(p)), Perimeter(p)});
  for (const Polygon& p : patches) patch_shapes.push_back({std::abs(SignedArea(p)), Perimeter(p)});
  std::sort(guide_shapes.begin(), guide_shapes.end());
  std::sort(patch_shapes.begin(), patch_shapes.end());
  double patch_area = 0;
  for (const Polygon& p : patches) patch_area += SignedArea(p);
  for (size_t i = 0; i < guides.size(); ++i) {
    EXPECT_NEAR(guide_shapes[i].first, patch_shapes[i].first, 1e-4 * patch_shapes[i].first) << "guide " << i;
    EXPECT_NEAR(guide_shapes[i].second, patch_shapes[i].second, 1e-4 * patch_shapes[i].second) << "guide " << i;
  }

  // --no-mirror turns the patches over: the signed areas change sign.
  const auto plain = Kgd("export " + file + " --out " + (dir / "plain").string() + " --no-mirror");
  ASSERT_EQ(plain.exit_code, 0) << plain.output;
  const std::vector<Polygon> unmirrored = SvgPolygons(Read(dir / "plain/patches.svg"), "1");
  ASSERT_EQ(unmirrored.size(), patches.size());
  double unmirrored_area = 0;
  for (const Polygon& p : unmirrored) unmirrored_area += SignedArea(p);
  EXPECT_LT(unmirrored_area * patch_area, 0);
}

// A seam given in the scene file: the flat sample cut across its middle gives two 100 x 70 mm pieces
// whose seam sides are the sample's width, and the Line's band split into two patches at the seam; a
// seam that is not a path along edges is refused by the scene's name and writes nothing.
TEST(Export, SeamsGivenInTheSceneFileCutThePatternThere) {
  const fs::path dir = TempDir("seams");
  ASSERT_EQ(Kgd("scene export pull_test_line " + (dir / "scene").string()).exit_code, 0);
  // The sample's rest mesh: the vertices across its middle (z = 70 mm), in order along x.
  std::vector<std::pair<double, int>> across;
  {
    std::ifstream obj(dir / "scene/garment_rest.obj");
    int v = 0;
    for (std::string line; std::getline(obj, line);) {
      if (line.rfind("v ", 0) != 0) continue;
      std::istringstream in(line.substr(2));
      double x, y, z;
      in >> x >> y >> z;
      if (std::abs(z - 0.07) < 1e-9) across.push_back({x, v});
      ++v;
    }
  }
  std::sort(across.begin(), across.end());
  ASSERT_EQ(across.size(), 41u) << "a 2.5 mm grid across 100 mm";
  nlohmann::json scene = nlohmann::json::parse(Read(dir / "scene/scene.json"));
  std::vector<int> seam;
  for (const auto& [x, v] : across) seam.push_back(v);
  scene["garment"]["seams"] = {seam};
  std::ofstream(dir / "scene/seamed.json") << scene.dump(2);
  const auto run = Kgd("export " + (dir / "scene/seamed.json").string() + " --out " + (dir / "cut").string() + " --json");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const nlohmann::json report = nlohmann::json::parse(run.output);
  ASSERT_EQ(report["pieces"].size(), 2u);
  for (const auto& p : report["pieces"]) {
    EXPECT_NEAR(p["rest_area_m2"].get<double>(), 0.1 * 0.07, 1e-12);
    EXPECT_NEAR(p["flat_area_m2"].get<double>(), 0.1 * 0.07, 1e-9);
    EXPECT_LT(p["area_distortion_max"].get<double>(), 1e-6);
  }
  ASSERT_EQ(report["seams"].size(), 1u);
  EXPECT_NEAR(report["seams"][0]["side_a_mm"].get<double>(), 100, 1e-3);
  EXPECT_NEAR(report["seams"][0]["side_b_mm"].get<double>(), 100, 1e-3);
  ASSERT_EQ(report["patches"].size(), 2u) << "the band is split at the seam";
  for (const auto& p : report["patches"]) EXPECT_NEAR(p["area_m2"].get<double>(), 0.04 * 0.05, 1e-9);

  // A seam that jumps across the sample.
  scene["garment"]["seams"] = {{seam.front(), seam.back()}};
  std::ofstream(dir / "scene/bad.json") << scene.dump(2);
  const auto bad = Kgd("export " + (dir / "scene/bad.json").string() + " --out " + (dir / "bad").string());
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("bad.json: garment.seams: seam 1 is not a path along edges: vertices " + std::to_string(seam.front()) + " and " +
                            std::to_string(seam.back())),
            std::string::npos)
      << bad.output;
  EXPECT_FALSE(fs::exists(dir / "bad"));
}

TEST(Export, BadInputIsRefusedByNameAndLeavesNoFile) {
  const fs::path dir = TempDir("bad");
  const std::string file = (dir / "line.h5").string();
  ASSERT_EQ(Kgd("design pull_test_line --iterations 2 --out " + file).exit_code, 0);
  { std::ofstream(dir / "foreign.h5") << "not hdf5"; }
  struct Case {
    std::string args, message;
  };
  const std::vector<Case> cases = {
      {"export " + file + " --iteration 9", "iteration 9 is not stored (0..2)"},
      {"export " + file + " --formats svg,pdf", "unknown format 'pdf'"},
      {"export " + (dir / "foreign.h5").string(), "foreign.h5"},
      {"export " + (dir / "missing.h5").string(), "missing.h5"},
      {"export pull_test_all_cloth", "nothing to cut"},
      {"export no_such_scene", "no_such_scene"},
      {"export " + file + " --sheet-width-mm 1e300", "sheet width (--sheet-width-mm, sheetWidthMm) 1e+300 mm is not a finite number"},
      {"export " + file + " --seam-allowance-mm -1", "seam allowance (--seam-allowance-mm, seamAllowanceMm) -1 mm is not a finite number"},
      {"export " + file + " --min-feature-mm nan", "minimum feature (--min-feature-mm, minFeatureMm) nan mm"},
  };
  for (const Case& c : cases) {
    const fs::path out = dir / "out";
    fs::remove_all(out);
    const auto run = Kgd(c.args + " --out " + out.string());
    EXPECT_EQ(run.exit_code, 2) << c.args << ": " << run.output;
    EXPECT_NE(run.output.find(c.message), std::string::npos) << c.args << ": " << run.output;
    EXPECT_TRUE(!fs::exists(out) || fs::is_empty(out)) << c.args << " left files behind";
  }
}

}  // namespace
}  // namespace kgd

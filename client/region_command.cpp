#include "client/region_command.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "core/mesh/mesh_io.h"
#include "core/mesh/region.h"

namespace kgd::cli {
namespace {

struct RegionOptions {
  std::string body, out;
  std::vector<std::string> planes, nears, geodesics, radii, free_ends;
  int unions = 0, subtracts = 0;
  double attach_m = 0;
  bool fill_holes = false, no_tidy = false;
  double hole_area_m2 = kDefaultMaxHoleArea_m2;
  // The rule options, to read the command line's order back (CLI::App::parse_order).
  const CLI::Option *plane = nullptr, *near = nullptr, *geodesic = nullptr, *union_flag = nullptr, *subtract_flag = nullptr;
};

// "x,y,z,..." with exactly n finite numbers.
Result<std::vector<double>> ParseNumbers(const std::string& option, const std::string& text, int n, const char* form) {
  std::vector<double> out;
  size_t start = 0;
  while (true) {
    const size_t comma = text.find(',', start);
    const std::string item = text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    try {
      size_t used = 0;
      const double v = std::stod(item, &used);
      if (used != item.size() || !std::isfinite(v)) throw std::invalid_argument(item);
      out.push_back(v);
    } catch (const std::exception&) {
      return Status::Error(option + " " + text + ": '" + item + "' is not a finite number (expected " + form + ", metres)");
    }
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (static_cast<int>(out.size()) != n)
    return Status::Error(option + " " + text + ": " + std::to_string(out.size()) + " numbers, expected " + std::to_string(n) + " (" + form + ")");
  return out;
}

Eigen::Vector3d Vec(const std::vector<double>& v, int at) { return {v[at], v[at + 1], v[at + 2]}; }

// The rules in the order the command line gives them.
Result<RegionSpec> BuildSpec(const CLI::App& cmd, const RegionOptions& o) {
  if (o.radii.size() != o.geodesics.size())
    return Status::Error("each --geodesic needs its --radius R (m), given after it: " + std::to_string(o.geodesics.size()) + " --geodesic, " +
                         std::to_string(o.radii.size()) + " --radius");
  RegionSpec spec;
  spec.groups.emplace_back();
  size_t plane = 0, near = 0, geodesic = 0;
  for (const CLI::Option* opt : cmd.parse_order()) {
    if (opt == o.plane) {
      Result<std::vector<double>> v = ParseNumbers("--plane", o.planes[plane++], 6, "X,Y,Z,NX,NY,NZ");
      if (!v.ok()) return v.status();
      spec.groups.back().rules.push_back(PlaneRule{Vec(*v, 0), Vec(*v, 3)});
    } else if (opt == o.near) {
      Result<std::vector<double>> v = ParseNumbers("--near", o.nears[near++], 3, "X,Y,Z");
      if (!v.ok()) return v.status();
      spec.groups.back().rules.push_back(NearRule{Vec(*v, 0)});
    } else if (opt == o.geodesic) {
      Result<std::vector<double>> v = ParseNumbers("--geodesic", o.geodesics[geodesic], 3, "X,Y,Z");
      if (!v.ok()) return v.status();
      Result<std::vector<double>> r = ParseNumbers("--radius", o.radii[geodesic++], 1, "R");
      if (!r.ok()) return r.status();
      spec.groups.back().rules.push_back(GeodesicRule{Vec(*v, 0), (*r)[0]});
    } else if (opt == o.union_flag || opt == o.subtract_flag) {
      if (spec.groups.back().rules.empty())
        return Status::Error(std::string(opt == o.union_flag ? "--union" : "--subtract") + " must follow a rule (it starts a new group of rules)");
      spec.groups.push_back({opt == o.union_flag ? RegionOp::kUnion : RegionOp::kSubtract, {}});
    }
  }
  if (spec.groups.size() > 1 && spec.groups.back().rules.empty())
    return Status::Error(std::string(spec.groups.back().op == RegionOp::kUnion ? "--union" : "--subtract") + " at the end: give its rules after it");
  if (spec.groups.front().rules.empty()) spec.groups.clear();
  spec.tidy_boundary = !o.no_tidy;
  return spec;
}

std::string Rules(const RegionSpec& spec) {
  std::string s;
  for (size_t g = 0; g < spec.groups.size(); ++g) {
    if (g > 0) s += spec.groups[g].op == RegionOp::kUnion ? " --union" : " --subtract";
    for (const RegionRule& r : spec.groups[g].rules) s += (s.empty() ? "" : " ") + DescribeRule(r);
  }
  return s;
}

Status WriteFaceList(const std::string& path, const std::vector<int>& faces, const std::vector<std::string>& comments) {
  std::ofstream out(path);
  if (!out) return Status::Error(path + ": cannot open for writing");
  for (const std::string& c : comments) out << "# " << c << '\n';
  for (int f : faces) out << f << '\n';
  return out ? Status::Ok() : Status::Error(path + ": write failed");
}

int RunRegion(const CLI::App& cmd, const RegionOptions& o) {
  auto fail = [](const std::string& m) {
    std::cerr << "kgd region: " << m << "\n";
    return 2;
  };
  Result<RegionSpec> spec = BuildSpec(cmd, o);
  if (!spec.ok()) return fail(spec.message());
  if (!(o.hole_area_m2 >= 0) || !std::isfinite(o.hole_area_m2)) return fail("--hole-area must be a finite area >= 0 m^2");
  const bool attach = cmd.count("--attach") > 0;
  if (attach && !(o.attach_m > 0 && std::isfinite(o.attach_m))) return fail("--attach must be a finite width above 0 m");
  Result<TriMesh> body = ReadMesh(o.body);
  if (!body.ok()) return fail(body.message());
  if (Status st = ValidateMesh(body->vertices, body->faces, o.body); !st.ok()) return fail(st.message());
  Result<std::vector<int>> faces = SelectRegion(*body, *spec);
  if (!faces.ok()) return fail(o.body + ": " + faces.message());
  Result<Region> region = CheckRegion(*body, *faces, {o.hole_area_m2, o.fill_holes});
  if (!region.ok()) return fail(o.body + ": " + region.message());
  std::vector<AttachmentBand> bands;
  if (attach) {
    if (region->loops.empty()) return fail(o.body + ": --attach: the region is closed (no boundary loop to attach along)");
    Result<std::vector<AttachmentBand>> b = AttachmentBands(*body, *region, o.attach_m);
    if (!b.ok()) return fail(o.body + ": " + b.message());
    bands = std::move(b).value();
    // --free X,Y,Z: the loop whose centre is nearest the point keeps no band.
    for (const std::string& text : o.free_ends) {
      Result<std::vector<double>> p = ParseNumbers("--free", text, 3, "X,Y,Z");
      if (!p.ok()) return fail(p.message());
      auto nearest = std::min_element(bands.begin(), bands.end(), [&](const AttachmentBand& a, const AttachmentBand& b) {
        return (region->loops[a.loop].centre_m - Vec(*p, 0)).norm() < (region->loops[b.loop].centre_m - Vec(*p, 0)).norm();
      });
      if (nearest == bands.end()) return fail("--free " + text + ": every boundary loop is free already");
      bands.erase(nearest);
    }
    if (bands.empty()) return fail("--attach with every boundary loop --free: no band left");
  }

  const std::filesystem::path prefix(o.out);
  std::error_code ec;
  if (prefix.has_parent_path()) std::filesystem::create_directories(prefix.parent_path(), ec);
  if (ec) return fail(prefix.parent_path().string() + ": cannot create directory: " + ec.message());
  const std::string faces_path = o.out + ".faces.txt", attach_path = o.out + ".attach.txt";
  const std::string body_name = std::filesystem::path(o.body).filename().string();
  char area[64], cm2[32];
  std::snprintf(area, sizeof area, "%.5f m^2 (%.1f cm^2)", region->area_m2, region->area_m2 * 1e4);
  std::snprintf(cm2, sizeof cm2, "%.1f cm^2", region->area_m2 * 1e4);
  const std::string rules = Rules(*spec) + (o.no_tidy ? " --no-tidy" : "") + (o.fill_holes ? " --fill-holes" : "");
  if (Status st = WriteFaceList(faces_path, region->faces,
                                {"kgd region: a garment region of " + body_name + ", 0-based face indices, one per line (" +
                                     std::to_string(region->faces.size()) + " faces, " + cm2 + ")",
                                 "rules: " + rules});
      !st.ok())
    return fail(st.message());
  std::set<int> attached;
  int shared = 0;
  for (const AttachmentBand& b : bands)
    for (int f : b.faces) shared += !attached.insert(f).second;
  if (!bands.empty()) {
    char width[32];
    std::snprintf(width, sizeof width, "%.4g", o.attach_m);
    std::string free;
    for (const std::string& text : o.free_ends) free += " --free " + text;
    if (Status st = WriteFaceList(attach_path, std::vector<int>(attached.begin(), attached.end()),
                                  {"kgd region: attachment bands " + std::string(width) + " m wide along " +
                                       std::to_string(bands.size()) + " of the " + std::to_string(region->loops.size()) + " boundary loops of " + std::filesystem::path(faces_path).filename().string() +
                                       ", 0-based face indices of " + body_name,
                                   "rules: " + rules + " --attach " + width + free});
        !st.ok())
      return fail(st.message());
  }

  std::printf("body                  %s: %ld vertices, %ld faces\n", o.body.c_str(), (long)body->vertices.rows(), (long)body->faces.rows());
  std::printf("rules                 %s\n", rules.c_str());
  std::printf("region                %zu faces, %d vertices, 1 piece, %s\n", region->faces.size(), region->vertices, area);
  if (!region->filled_faces.empty()) std::printf("holes filled          %zu faces\n", region->filled_faces.size());
  std::printf("boundary loops        %zu\n", region->loops.size());
  for (size_t l = 0; l < region->loops.size(); ++l) {
    const RegionLoop& loop = region->loops[l];
    std::printf("  loop %-13zu  %.1f cm long, centre (%.4f, %.4f, %.4f) m, %zu vertices\n", l + 1, loop.length_m * 100, loop.centre_m.x(),
                loop.centre_m.y(), loop.centre_m.z(), loop.vertices.size());
  }
  for (const AttachmentBand& b : bands) {
    const double length = region->loops[b.loop].length_m;
    std::printf("  band %-13d  along loop %d: %zu faces, %.1f cm^2, mean width %.2f cm\n", b.loop + 1, b.loop + 1, b.faces.size(), b.area_m2 * 1e4,
                length > 0 ? 100 * b.area_m2 / length : 0.0);
  }
  if (!bands.empty())
    std::printf("attachments           %zu faces%s\n", attached.size(),
                shared > 0 ? (", " + std::to_string(shared) + " of them in two bands (the bands meet: a narrower --attach keeps them apart)").c_str() : "");
  std::printf("wrote                 %s%s\n", faces_path.c_str(), bands.empty() ? "" : (", " + attach_path).c_str());
  std::printf("scene keys            \"garment\": {\"region\": \"%s\"}", std::filesystem::path(faces_path).filename().c_str());
  if (!bands.empty()) std::printf(", \"attachments\": {\"body_faces\": \"%s\"}", std::filesystem::path(attach_path).filename().c_str());
  std::printf(" (beside the scene file)\n");
  return 0;
}

}  // namespace

void AddRegionCommand(CLI::App& app, int* exit_code) {
  auto o = std::make_shared<RegionOptions>();
  CLI::App* cmd = app.add_subcommand(
      "region",
      "Choose a garment region on a body mesh by rules and write it as the face lists a scene file names (garment.region; with --attach "
      "the attachment bands, attachments.body_faces)");
  cmd->footer(
      "Rules apply in the order given, from every face of the body: --plane and --geodesic keep the faces on their side or within their "
      "radius, --near keeps the connected piece nearest its point. --union and --subtract start a new group of rules, evaluated the same "
      "way on the whole body, whose faces are added to or removed from those before it; the result's boundary is then tidied "
      "(--no-tidy). The region must be one piece, manifold, "
      "without holes (a boundary loop enclosing less than --hole-area outside the region) or slivers (a place one face wide); a refusal "
      "names a face and a point. Coordinates and lengths in metres, as the mesh.\n"
      "Example (a sleeve 16 cm long about the right elbow of ../shared/bodies/makehuman/rest.obj):\n"
      "  kgd region rest.obj --plane -0.267,1.234,0.020,-0.726,-0.672,0.146 --plane -0.383,1.126,0.043,0.726,0.672,-0.146 \\\n"
      "      --near -0.325,1.180,0.031 --attach 0.025 --out sleeve/sleeve");
  cmd->add_option("body", o->body, "The body mesh in its rest pose (OBJ or PLY, metres)")->required();
  cmd->add_option("--out", o->out, "Write PREFIX.faces.txt (and with --attach PREFIX.attach.txt); creates the folder")->required();
  o->plane = cmd->add_option("--plane", o->planes,
                             "X,Y,Z,NX,NY,NZ: keep the faces whose centroid lies on the plane through X,Y,Z or on the side its normal "
                             "NX,NY,NZ points to (repeatable)");
  o->near = cmd->add_option("--near", o->nears, "X,Y,Z: keep the connected piece of the faces kept so far nearest the point (repeatable)");
  o->geodesic = cmd->add_option("--geodesic", o->geodesics,
                                "X,Y,Z: keep the faces whose centroid lies within --radius of the point along the surface (repeatable)");
  cmd->add_option("--radius", o->radii, "R (m): the radius of the --geodesic before it");
  o->union_flag = cmd->add_flag("--union", o->unions, "Start a group of rules whose faces are added to those before");
  o->subtract_flag = cmd->add_flag("--subtract", o->subtracts, "Start a group of rules whose faces are removed from those before");
  cmd->add_option("--attach", o->attach_m,
                  "WIDTH (m): also write the attachment bands, the region's faces within WIDTH of each boundary loop along the surface");
  cmd->add_option("--free", o->free_ends, "X,Y,Z: with --attach, the boundary loop whose centre is nearest the point gets no band (repeatable)");
  cmd->add_flag("--no-tidy", o->no_tidy,
                "Keep the faces the rules select as they are; by default the boundary is tidied: faces outside with two edges on the "
                "region are added, then faces inside with fewer than two neighbours in it removed, until none is left");
  cmd->add_flag("--fill-holes", o->fill_holes, "Add the holes (what a small boundary loop encloses) to the region instead of refusing it");
  cmd->add_option("--hole-area", o->hole_area_m2, "A boundary loop enclosing less than this outside the region is a hole (m^2)")
      ->capture_default_str();
  cmd->callback([cmd, o, exit_code] { *exit_code = RunRegion(*cmd, *o); });
}

}  // namespace kgd::cli

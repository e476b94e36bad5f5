// Cut sheets: pattern pieces and reinforcement patches laid out as drawings in millimetres, and their
// SVG and DXF text. The layers follow the AAMA/ASTM D6673 numbering where one fits:
//   "1" cut lines, "4" notches, "7" grain lines, "8" placement guides (patches drawn on the pieces,
//   registration marks), "14" sew lines, "15" labels.
// Pure geometry and text; writing files is the caller's.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/fabrication/patches.h"
#include "core/fabrication/pattern.h"

namespace kgd {

struct SheetPath {
  std::string layer;
  std::vector<Eigen::Vector2d> points;  // mm, y up
  bool closed = true;
};
struct SheetText {
  std::string layer;
  Eigen::Vector2d at;  // mm, baseline start
  double height_mm = 4;
  std::string text;
};
struct Sheet {
  std::string title;
  double width_mm = 0, height_mm = 0;
  std::vector<SheetPath> paths;
  std::vector<SheetText> texts;
};

struct SheetOptions {
  double seam_allowance_mm = 10;
  double sheet_width_mm = 305;  // the vinyl roll's width
  double gap_mm = 5;            // between nested patches
  bool mirror = true;           // heat-transfer vinyl is cut from the back
  std::string label;            // printed on every piece (job, scene)
};

// The pattern pieces: sew line (the piece's outline), cut line (the outline offset by the seam
// allowance), notches at the middle of every seam, a vertical grain line along the piece's long axis,
// the patches as placement guides with registration crosses, and labels.
Sheet PatternSheet(const Pattern& pattern, const std::vector<Patch>& patches, const SheetOptions& options);

// The patches nested on a roll of sheet_width_mm (shelves of bounding boxes, each patch turned by 0 or
// 90 degrees, gap_mm apart), mirrored when options.mirror. `usage` receives the patches' area over the
// sheet's. Errors: a patch wider than the roll either way (named).
Result<Sheet> PatchSheet(const std::vector<Patch>& patches, const SheetOptions& options, double* usage = nullptr);

// For each seam, the flat lengths (mm) of its two sides (the sewn edges), in seam order.
struct SeamSides {
  double a_mm = 0, b_mm = 0;
};
std::vector<SeamSides> SeamLengths(const Pattern& pattern);

// The colour (0xRRGGBB) a layer is drawn in, in the SVG and the PNG preview alike: cut and notches red,
// grain black, guides blue, sew grey, labels and anything else black.
uint32_t LayerColour(const std::string& layer);

// SVG in true millimetres (width and height in mm, a matching viewBox), hairline red cut strokes, a group
// per layer, and a 10 mm calibration square.
std::string SvgText(const Sheet& sheet);
// DXF R12: POLYLINE entities (closed where the path is), TEXT, $INSUNITS = 4 (mm), a layer table.
std::string DxfText(const Sheet& sheet);

}  // namespace kgd

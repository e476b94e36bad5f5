// A PNG preview of a cut sheet (core/fabrication/cut_sheet.h): what the maker sees before cutting.
// White paper, every path stroked in its layer's colour (cut lines red, guides blue, sew lines grey,
// grain black), the reinforcement placement guides filled pale blue, the 10 mm calibration square in
// the top margin. Labels are not drawn (the SVG has them). Pure pixels and bytes; writing the file is
// the caller's.
#pragma once

#include <string>

#include "core/fabrication/cut_sheet.h"
#include "core/util/status.h"

namespace kgd {

// The sheet at px_per_mm (the image is capped at 8192 pixels on its longer side, the scale lowered to
// fit), encoded as PNG (libpng). Errors: an empty sheet, an encoder failure.
Result<std::string> SheetPng(const Sheet& sheet, double px_per_mm = 4);

}  // namespace kgd

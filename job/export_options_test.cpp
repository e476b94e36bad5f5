// Export options out of range (not finite, negative, or beyond a garment's and a vinyl roll's sizes)
// are refused before any work, each naming its value; the defaults and the largest lengths pass.
#include "job/fabrication_export.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>

namespace kgd {
namespace {

// The option check runs before the scene is looked at: a scene of one face and no design, with good
// options, fails later, on its missing design.
Status Check(const ExportOptions& o) {
  SceneSpec scene;
  scene.name = "one face";
  scene.garment.faces.setZero(1, 3);
  return ExportDesignOfScene(scene, testing::TempDir() + "/kgd_export_options", o).status();
}

TEST(ExportOptions, NonFiniteOrAbsurdLengthsAreRefusedNamingTheValue) {
  const double inf = std::numeric_limits<double>::infinity(), nan = std::numeric_limits<double>::quiet_NaN();
  struct Case {
    std::function<void(ExportOptions*)> set;
    std::string message;
  };
  const std::vector<Case> cases = {
      {[&](ExportOptions* o) { o->sheet.sheet_width_mm = inf; }, "sheet width (--sheet-width-mm, sheetWidthMm) inf mm"},
      {[&](ExportOptions* o) { o->sheet.sheet_width_mm = -inf; }, "sheet width (--sheet-width-mm, sheetWidthMm) -inf mm"},
      {[&](ExportOptions* o) { o->sheet.sheet_width_mm = nan; }, "sheet width (--sheet-width-mm, sheetWidthMm) nan mm"},
      {[&](ExportOptions* o) { o->sheet.sheet_width_mm = 0; }, "sheet width (--sheet-width-mm, sheetWidthMm) 0 mm is not a finite number in (0, 10000] mm"},
      {[&](ExportOptions* o) { o->sheet.sheet_width_mm = 1e300; }, "sheet width (--sheet-width-mm, sheetWidthMm) 1e+300 mm"},
      {[&](ExportOptions* o) { o->sheet.seam_allowance_mm = inf; }, "seam allowance (--seam-allowance-mm, seamAllowanceMm) inf mm"},
      {[&](ExportOptions* o) { o->sheet.seam_allowance_mm = -1; }, "seam allowance (--seam-allowance-mm, seamAllowanceMm) -1 mm"},
      {[&](ExportOptions* o) { o->sheet.seam_allowance_mm = 1e6; }, "seam allowance (--seam-allowance-mm, seamAllowanceMm) 1e+06 mm is not a finite number in [0, 100] mm"},
      {[&](ExportOptions* o) { o->cleaning.min_feature_m = nan; }, "minimum feature (--min-feature-mm, minFeatureMm) nan mm"},
      {[&](ExportOptions* o) { o->cleaning.min_feature_m = 1e300; }, "minimum feature (--min-feature-mm, minFeatureMm) 1e+303 mm"},
      {[&](ExportOptions* o) { o->sheet.gap_mm = inf; }, "gap between patches inf mm"},
  };
  for (const Case& c : cases) {
    ExportOptions o;
    c.set(&o);
    const Status st = Check(o);
    ASSERT_FALSE(st.ok()) << c.message;
    EXPECT_NE(st.message().find(c.message), std::string::npos) << st.message();
  }
}

TEST(ExportOptions, TheDefaultsAndTheLargestLengthsPass) {
  for (const auto& set : std::vector<std::function<void(ExportOptions*)>>{
           [](ExportOptions*) {},
           [](ExportOptions* o) { o->sheet.sheet_width_mm = kMaxSheetWidthMm; },
           [](ExportOptions* o) { o->sheet.seam_allowance_mm = kMaxExportFeatureMm; },
           [](ExportOptions* o) { o->cleaning.min_feature_m = kMaxExportFeatureMm / 1000; },
           [](ExportOptions* o) { o->sheet.seam_allowance_mm = 0, o->cleaning.min_feature_m = 0, o->sheet.gap_mm = 0; }}) {
    ExportOptions o;
    set(&o);
    const Status st = Check(o);
    ASSERT_FALSE(st.ok());  // the empty scene has no design
    EXPECT_NE(st.message().find("has no design"), std::string::npos) << st.message();
  }
}

}  // namespace
}  // namespace kgd

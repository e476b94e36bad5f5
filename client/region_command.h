// `kgd region`: a garment region on a body mesh chosen by rules (planes, a point, geodesic discs, their
// unions and differences: core/mesh/region.h), checked as a garment and written as the face lists a
// scene file names (garment.region, and with --attach the bands of attachments.body_faces).
#pragma once

#include <CLI/CLI.hpp>

namespace kgd::cli {

// Registers `kgd region`; it sets *exit_code when it runs (0 written, 2 bad input or a refused region).
void AddRegionCommand(CLI::App& app, int* exit_code);

}  // namespace kgd::cli

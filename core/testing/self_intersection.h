// Self-intersection of a triangle surface: pairs of faces that share no vertex yet cross each other.
// Used to check generated and imported bodies (a self-intersecting body has no meaningful inside).
#pragma once

#include <utility>
#include <vector>

#include "core/mesh/trimesh.h"

namespace kgd {

// Pairs (f, g), f < g, of faces without a common vertex where an edge of one crosses the other
// (touching within a relative 1e-12 counts as crossing). Stops after `max_pairs`. Broad phase: a
// uniform grid of face bounding boxes with cells about twice the mean edge length.
std::vector<std::pair<int, int>> SelfIntersections(const Positions& x, const Faces& faces, int max_pairs = 100);

}  // namespace kgd

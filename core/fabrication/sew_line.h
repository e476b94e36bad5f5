// Sew lines: a pattern piece's outline as a maker would cut it. The outline runs along the garment mesh's
// edges and so steps at every one; its sew line is the same boundary faired between its corners (the
// seam ends, where seams meet, and the sharp corners of a flat sample's straight edges), resampled about
// every millimetre, within a tolerance of the outline measured on the body, with the two sides of every
// seam of equal length. Pure geometry; SI units (m) unless a name says mm or deg.
//
// The fairing is a smoothing spline (penalized least squares of second differences, as Reinsch's) fitted
// to the outline resampled at equal arc length steps, its ends (corners) fixed, reweighted as Lawson's
// algorithm does: where a point strays beyond the tolerance its target moves to the nearest place within
// it and its weight grows, where the curve turns by more than a target angle the stiffness there rises,
// so that the largest turn comes down while every point stays within the tolerance. How fast the weights
// grow decides where the curve settles around a bend of the outline; a few rates are tried and the
// smoothest fit kept. The two sides of a
// seam are flattened with their own pieces and so differ in shape: faired alike they differ in length by
// up to a percent. The shorter side is faired again within a narrower tolerance until it is as long as
// the other, and each side's remaining wiggle (about a much stiffer spline) is then scaled to their mean
// length.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "core/fabrication/pattern_piece.h"

namespace kgd {

struct SewLineOptions {
  double spacing_m = 0.001;      // the sew line's points lie about this far apart
  double tolerance_m = 0.001;    // the farthest a sew line point may lie from the outline, on the body
  double fit_tolerance = 0.9;    // the fit keeps within this fraction of it (the rest is for the seams' lengths)
  double smoothing_m = 0.01;     // the spline's length scale at first
  double target_turn_deg = 4;    // the spline is stiffened where the line turns more than this
  int iterations = 60;           // reweightings
  std::vector<double> weight_growth = {4, 2, 1.5};  // a straying point's weight grows by one of these a reweighting
};

// The largest turning angle (degrees) between consecutive segments of the closed polyline `closed`, at
// its points other than `corners` (indices into it). Zero for fewer than three points.
double MaxTurningDeg(const FlatPositions& closed, const std::vector<int>& corners = {});

// The distance (m) on the body from `q` to the polyline `p` (open, or closed when `closed`), bounded to
// first order: the least over segments j (point j to j + 1) of the plane distance divided by `scale[j]`,
// the smallest stretch of that segment's face's flat map (a plane distance d is at most d / scale[j] on
// the body). Empty `scale`: the plane distance.
double BodyDistance(const Eigen::Vector2d& q, const FlatPositions& p, const Eigen::VectorXd& scale, bool closed);

// One span of outline between two corners, faired: `sides` are one span alone (a free edge), or the two
// sides of a seam (the same garment vertices in the same order, so equal in length to round-off), which
// come back of one length. Each side is resampled into points + 1 points (the same count for all sides),
// its ends kept exactly; `at[k]` is the point of vertex k of the sides (the same for all, from their mean
// arc length fraction). With `closed`, one side only: a closed polyline (first vertex not repeated) with
// no corner, resampled into `points` points.
struct FairedSpan {
  std::vector<FlatPositions> sides;
  std::vector<int> at;
  int points = 0;
  std::vector<double> deviation_m;  // each side's farthest point from its polyline, on the body (BodyDistance)
};
// `scale[s][j]`: segment j of side s, its flat map's smallest stretch (1 for a piece flattened without
// distortion). A side of fewer than two vertices, or sides of different vertex counts, come back as given.
FairedSpan FairSpan(const std::vector<FlatPositions>& sides, const std::vector<Eigen::VectorXd>& scale, bool closed,
                    const SewLineOptions& options = {});

// Every piece's sew line (PatternPiece::sew_line and the figures beside it), from its outline and
// flat shape, the seams of `pattern` giving the corners and the pairs of sides to fair together.
void FairSewLines(Pattern* pattern, const SewLineOptions& options = {});

}  // namespace kgd

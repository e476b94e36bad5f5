// The BESO loop on the pull test: every design meets its target area, every simulation converges,
// the reinforced energy density rises as material goes, and the run is deterministic.
#include "core/beso/design_loop.h"
#include "core/testing/bodies_test_scene.h"
#include "core/scene/builtin_scenes.h"
#include "core/scene/simulate.h"
#include "core/scene/shapes.h"

#include <cmath>
#include <limits>
#include <tuple>

#include <gtest/gtest.h>

namespace kgd {
namespace {

// Quick BESO settings for the pull test: down to 60 % in 5 % steps.
BesoSettings PullTestSettings(int max_iterations) {
  BesoSettings s;
  s.budget = 0.6;
  s.evolutionary_ratio = 0.05;
  s.admission_ratio = 0.05;
  s.max_iterations = max_iterations;
  return s;
}

TEST(DesignLoop, PullTestDesignsMeetTheirTargetsAndConcentrateEnergy) {
  Result<SceneSpec> scene = PullTestScene("all_cloth");
  ASSERT_TRUE(scene.ok());
  BesoSettings s = PullTestSettings(25);
  const Result<std::vector<BesoIteration>> run = RunBeso(*scene, s);
  ASSERT_TRUE(run.ok()) << run.message();
  ASSERT_GT(run->size(), 10u);
  const Eigen::VectorXd area = FaceAreas(scene->garment.vertices, scene->garment.faces);
  const double total = area.sum(), largest = area.maxCoeff();
  EXPECT_NEAR((*run)[0].area_fraction, 1.0, 1e-12);
  EXPECT_NEAR((*run)[0].density_ratio, 1.0, 1e-12);
  for (const BesoIteration& it : *run) {
    EXPECT_EQ(it.status, SolveStatus::kConverged) << "iteration " << it.iteration;
    EXPECT_LE(std::abs(it.area_fraction * total - it.target_area_m2), 0.5 * largest + 1e-15) << "iteration " << it.iteration;
  }
  EXPECT_NEAR(run->back().area_fraction, 0.6, 0.5 * largest / total + 1e-12);
  EXPECT_GT(run->back().density_ratio, 1.1);
  // Deterministic: the same job gives the same designs.
  s.max_iterations = 8;
  const Result<std::vector<BesoIteration>> a = RunBeso(*scene, s), b = RunBeso(*scene, s);
  ASSERT_TRUE(a.ok() && b.ok());
  for (size_t k = 0; k < a->size(); ++k) EXPECT_EQ((*a)[k].design, (*b)[k].design) << "iteration " << k;
}

// Every iteration's record says where its solve spent its time: Newton's parts within the solve, and
// each term the scene builds (the pull test: membrane and fold barrier, no contact, attachment, friction
// or bending).
TEST(DesignLoop, EveryIterationRecordsWhereItsSolveSpentItsTime) {
  Result<SceneSpec> scene = PullTestScene("all_cloth");
  ASSERT_TRUE(scene.ok());
  const Result<std::vector<BesoIteration>> run = RunBeso(*scene, PullTestSettings(4));
  ASSERT_TRUE(run.ok()) << run.message();
  for (const TermRegistration& t : EnergyTermRegistry()) EXPECT_NE(TermTimeMetric(t.name), nullptr) << t.name;
  EXPECT_EQ(TermTimeMetric("no such term"), nullptr);
  for (const BesoIteration& it : *run) {
    SCOPED_TRACE("iteration " + std::to_string(it.iteration));
    EXPECT_GT(it.assembly_s, 0.0);
    if (it.iteration == 0) {  // later re-solves may take local steps only, with no global factorization
      EXPECT_GT(it.factorization_s, 0.0);
      EXPECT_GT(it.linear_solve_s, 0.0);
    }
    EXPECT_LE(it.assembly_s + it.factorization_s + it.linear_solve_s + it.line_search_s, it.simulation_s);
    EXPECT_GT(it.membrane_s, 0.0);
    EXPECT_GT(it.fold_barrier_s, 0.0);
    EXPECT_LE(it.membrane_s + it.fold_barrier_s, it.simulation_s);
    EXPECT_EQ(it.contact_s, 0.0);
    EXPECT_EQ(it.body_field_query_s, 0.0);
    EXPECT_EQ(it.attachment_s, 0.0);
    EXPECT_EQ(it.friction_s, 0.0);
    EXPECT_EQ(it.bending_s, 0.0);
  }
}

// With the authors' relaxation (C0) the pull test's uniaxial tension sits on the gradient jump, and at a
// tight tolerance Newton ends there `stalled`: the loop takes those states as equilibria (their energy
// has converged), records the status, and goes on.
TEST(DesignLoop, RunsOnTheAuthorsRelaxationThroughStalls) {
  Result<SceneSpec> scene = PullTestScene("all_cloth");
  ASSERT_TRUE(scene.ok());
  scene->effects.relaxation = Relaxation::kAuthors;
  scene->solver.grad_tol = 1e-7;
  const Result<std::vector<BesoIteration>> run = RunBeso(*scene, PullTestSettings(4));
  ASSERT_TRUE(run.ok()) << run.message();
  ASSERT_EQ(run->size(), 5u);  // iteration 0 and four BESO steps
  int stalled = 0;
  for (const BesoIteration& it : *run) {
    stalled += it.status == SolveStatus::kStalled;
    EXPECT_TRUE(it.status == SolveStatus::kConverged || it.status == SolveStatus::kStalled) << ToString(it.status);
    EXPECT_TRUE(std::isfinite(it.density_ratio));
  }
  EXPECT_GT(stalled, 0);
  EXPECT_GT(run->back().density_ratio, 1.0);
}

// Resuming from the records of iteration k gives the uninterrupted run's later iterations bit for bit,
// with either temporal averaging.
TEST(DesignLoop, ResumedRunsMatchUninterruptedOnes) {
  Result<SceneSpec> scene = PullTestScene("all_cloth");
  ASSERT_TRUE(scene.ok());
  for (bool raw : {false, true}) {
    BesoSettings s = PullTestSettings(10);
    s.average_with_raw = raw;
    const Result<std::vector<BesoIteration>> whole = RunBeso(*scene, s);
    ASSERT_TRUE(whole.ok());
    std::vector<BesoIteration> head(whole->begin(), whole->begin() + 5);
    const Result<std::vector<BesoIteration>> tail = RunBeso(*scene, s, {}, &head);
    ASSERT_TRUE(tail.ok()) << tail.message();
    ASSERT_EQ(head.size() + tail->size(), whole->size());
    for (size_t k = 0; k < tail->size(); ++k) {
      const BesoIteration &a = (*tail)[k], &b = (*whole)[head.size() + k];
      EXPECT_EQ(a.iteration, b.iteration);
      EXPECT_EQ(a.design, b.design) << "iteration " << b.iteration;
      EXPECT_TRUE(a.positions == b.positions) << "iteration " << b.iteration;
      EXPECT_TRUE(a.sensitivity == b.sensitivity) << "iteration " << b.iteration;
      EXPECT_EQ(a.energy_J, b.energy_J) << "iteration " << b.iteration;
    }
    // The two averagings are different procedures.
    if (raw) {
      BesoSettings paper = s;
      paper.average_with_raw = false;
      EXPECT_FALSE(whole->back().sensitivity == RunBeso(*scene, paper)->back().sensitivity);
    }
  }
}

TEST(DesignLoop, KeptAttachmentsStayReinforced) {
  Result<SceneSpec> scene = PullTestScene("all_cloth");
  ASSERT_TRUE(scene.ok());
  BesoSettings s = PullTestSettings(12);
  // Mark as attachments 40 faces that a free run turns to cloth.
  const Result<std::vector<BesoIteration>> free_run = RunBeso(*scene, s);
  ASSERT_TRUE(free_run.ok());
  for (size_t f = 0; f < free_run->back().design.size() && scene->attachment_faces.size() < 40; ++f)
    if (free_run->back().design[f] == kCloth) scene->attachment_faces.push_back(static_cast<int>(f));
  ASSERT_EQ(scene->attachment_faces.size(), 40u);
  s.keep_attachments = true;
  const Result<std::vector<BesoIteration>> run = RunBeso(*scene, s);
  ASSERT_TRUE(run.ok()) << run.message();
  for (const BesoIteration& it : *run)
    for (int f : scene->attachment_faces) ASSERT_EQ(it.design[f], kReinforced) << "iteration " << it.iteration << " face " << f;
  // Bands larger than the budget cannot be kept.
  s.budget = 0.005;  // the 40 faces are ~0.9 %
  const Result<std::vector<BesoIteration>> too_small = RunBeso(*scene, s);
  ASSERT_FALSE(too_small.ok());
  EXPECT_NE(too_small.message().find("more than the budget"), std::string::npos) << too_small.message();
}

// Why a run ends, from its metrics alone: still running, converged (target reached, flat objective over
// the window), the iteration limit, or nothing to resist (no reinforced energy at iteration 0).
TEST(DesignLoop, EndsForTheReasonItsHistoryGives) {
  BesoSettings s = PullTestSettings(10);
  s.converge_window = 3;
  const double area = 1.0;
  auto iteration = [](int k, double target, double energy, double reinforced) {
    BesoIteration it;
    it.iteration = k;
    it.target_area_m2 = target;
    it.energy_J = energy;
    it.reinforced_energy_J = reinforced;
    return it;
  };
  std::vector<BesoIteration> h;
  EXPECT_EQ(BesoEndOf(h, s, area), BesoEnd::kRunning);
  h.push_back(iteration(0, 1.0, 1e-3, 1e-3));
  EXPECT_EQ(BesoEndOf(h, s, area), BesoEnd::kRunning);
  for (int k = 1; k <= 4; ++k) h.push_back(iteration(k, 0.6, 2e-3, 1e-3));
  EXPECT_EQ(BesoEndOf(h, s, area), BesoEnd::kConverged);
  EXPECT_TRUE(BesoFinished(h, s, area));
  h.back().energy_J = 3e-3;  // not flat over the window
  EXPECT_EQ(BesoEndOf(h, s, area), BesoEnd::kRunning);
  for (int k = 5; k <= 10; ++k) h.push_back(iteration(k, 0.6, 1e-3 * k, 1e-3));
  EXPECT_EQ(BesoEndOf(h, s, area), BesoEnd::kIterationLimit);
  EXPECT_NE(DescribeBesoEnd(BesoEnd::kIterationLimit, h, s).find("10"), std::string::npos);
  h = {iteration(0, 1.0, 5e-10, 5e-10)};
  EXPECT_EQ(BesoEndOf(h, s, area), BesoEnd::kNothingToResist);
  EXPECT_NE(DescribeBesoEnd(BesoEnd::kNothingToResist, h, s).find("nothing to resist"), std::string::npos);
}

// A pull test whose clamps do not move gives the garment nothing to resist: the run stops after
// iteration 0.
TEST(DesignLoop, AMotionlessSceneStopsAfterIterationZero) {
  Result<SceneSpec> scene = PullTestScene("all_cloth");
  ASSERT_TRUE(scene.ok()) << scene.message();
  for (Clamp& c : scene->clamps) c.displacement_m.setZero();
  const BesoSettings s = PullTestSettings(20);
  const Result<std::vector<BesoIteration>> run = RunBeso(*scene, s);
  ASSERT_TRUE(run.ok()) << run.message();
  ASSERT_EQ(run->size(), 1u);
  EXPECT_LE(run->front().reinforced_energy_J, kNothingToResist_J);
  EXPECT_EQ(BesoEndOf(*run, s, 1.0), BesoEnd::kNothingToResist);
}

// Frames are an evaluation's, not a design's: the design loop neither reads nor simulates the motion's
// frames (here frames no simulation could use), and its history is the same as without them.
TEST(DesignLoop, ADesignNeverReadsTheMotionsFrames) {
  Result<SceneSpec> plain = PullTestScene("all_cloth");
  ASSERT_TRUE(plain.ok()) << plain.message();
  SceneSpec with_frames = *plain;
  BodyMotion motion;
  motion.faces = Faces(1, 3);
  motion.faces << 0, 1, 2;
  motion.rest = Positions::Zero(3, 3);
  motion.deformed = Positions::Zero(3, 3);
  motion.frames.assign(3, Positions::Constant(3, 3, std::numeric_limits<double>::quiet_NaN()));
  with_frames.motion = motion;
  const BesoSettings s = PullTestSettings(4);
  const Result<std::vector<BesoIteration>> a = RunBeso(*plain, s), b = RunBeso(with_frames, s);
  ASSERT_TRUE(a.ok()) << a.message();
  ASSERT_TRUE(b.ok()) << b.message();
  ASSERT_EQ(a->size(), b->size());
  for (size_t k = 0; k < a->size(); ++k) {
    EXPECT_EQ((*a)[k].design, (*b)[k].design) << "iteration " << k;
    EXPECT_EQ((*a)[k].energy_J, (*b)[k].energy_J) << "iteration " << k;
    EXPECT_EQ((*a)[k].body_field_query_s, 0.0);
  }
}

TEST(DesignLoop, BadSettingsAreRefused) {
  Result<SceneSpec> scene = PullTestScene("all_cloth");
  BesoSettings s;
  s.budget = 1.5;
  const Result<std::vector<BesoIteration>> run = RunBeso(*scene, s);
  ASSERT_FALSE(run.ok());
  EXPECT_NE(run.message().find("budget"), std::string::npos);
  for (double factor : {0.5, std::numeric_limits<double>::infinity()}) {
    BesoSettings t;
    t.resolve_tolerance_factor = factor;
    const Result<std::vector<BesoIteration>> r = RunBeso(*scene, t);
    ASSERT_FALSE(r.ok()) << factor;
    EXPECT_NE(r.message().find("resolve_tolerance_factor"), std::string::npos) << r.message();
  }
}

}  // namespace
}  // namespace kgd

// Motions with roles (docs/MODEL.md): a small sleeve cut from a limb that flexes its joint, the paper's
// way (rest straight; each motion flexes it by its own angle, + towards +z, - towards -z).
namespace kgd {
namespace {

SceneSpec FlexingSleeve(const std::vector<std::tuple<std::string, MotionRole, double, double>>& list) {
  LimbShape shape;
  shape.around = 16;
  std::vector<double> axial;
  const TriMesh rest = LimbRest(shape, &axial);
  SceneSpec s;
  s.name = "flexing_sleeve";
  for (const auto& [name, role, weight, angle] : list) {
    SceneMotion m;
    m.name = name;
    m.role = role;
    m.weight = weight;
    // |angle| > 1.5: flexed by angle - 2 (sign kept) towards +x instead (the limb turned about its axis).
    Positions deformed;
    if (std::abs(angle) > 1.5) {
      Positions turned = rest.vertices;
      turned.col(0) = rest.vertices.col(2);
      turned.col(2) = -rest.vertices.col(0);
      const Positions bent = LimbPosed(shape, turned, angle - std::copysign(2.0, angle));
      deformed = bent;
      deformed.col(0) = -bent.col(2);
      deformed.col(2) = bent.col(0);
    } else {
      deformed = LimbPosed(shape, rest.vertices, angle);
    }
    m.pose = BodyMotion{rest.faces, rest.vertices, deformed, {}};
    s.motions.push_back(std::move(m));
  }
  s.motion = s.motions.front().pose;
  for (Eigen::Index f = 0; f < rest.faces.rows(); ++f) {
    double lo = 1e300, hi = -1e300;
    for (int k = 0; k < 3; ++k) lo = std::min(lo, axial[rest.faces(f, k)]), hi = std::max(hi, axial[rest.faces(f, k)]);
    if (lo < -0.09 || hi > 0.09) continue;
    s.garment_region.push_back(static_cast<int>(f));
    if (lo < -0.07 || hi > 0.07) s.attachment_body_faces.push_back(static_cast<int>(f));
  }
  s.effects.contact = ContactModel::kUnilateral;
  s.effects.attachments = true;
  const Status st = CutGarmentFromMotion(&s);
  EXPECT_TRUE(st.ok()) << st.message();
  return s;
}

BesoSettings Quick(int iterations) {
  BesoSettings s;
  s.budget = 0.5;
  s.evolutionary_ratio = 0.06;
  s.admission_ratio = 0.06;
  s.max_iterations = iterations;
  return s;
}

void ExpectSameRun(const std::vector<BesoIteration>& a, const std::vector<BesoIteration>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (size_t k = 0; k < a.size(); ++k) {
    SCOPED_TRACE("iteration " + std::to_string(k));
    EXPECT_EQ(a[k].design, b[k].design);
    EXPECT_EQ(a[k].energy_J, b[k].energy_J);
    EXPECT_EQ(a[k].density_ratio, b[k].density_ratio);
    EXPECT_TRUE(a[k].positions == b[k].positions);
    EXPECT_EQ(a[k].sensitivity.size(), b[k].sensitivity.size());
    if (a[k].sensitivity.size() == b[k].sensitivity.size()) EXPECT_TRUE(a[k].sensitivity == b[k].sensitivity);
  }
}

// resolve_tolerance_factor: while the target area shrinks the re-solves stop at that multiple of the
// scene's tolerance (fewer Newton iterations, equilibria a re-solve at the scene's tolerance moves on);
// iteration 0 and the iterations from the budget on are at the scene's own (a re-solve there takes
// none); 1 is the loop at the tolerance throughout.
TEST(DesignLoop, TheResolvesWhileTheTargetShrinksStopAtTheFactorTimesTheTolerance) {
  const SceneSpec scene = FlexingSleeve({{"flex", MotionRole::kResist, 1.0, 0.8}});
  BesoSettings s = Quick(8);
  s.budget = 0.8;  // reached at iteration 4 (0.94^4 < 0.8)
  s.resolve_tolerance_factor = 1;
  const Result<std::vector<BesoIteration>> tight = RunBeso(scene, s);
  s.resolve_tolerance_factor = 100;
  const Result<std::vector<BesoIteration>> loose = RunBeso(scene, s);
  ASSERT_TRUE(tight.ok()) << tight.message();
  ASSERT_TRUE(loose.ok()) << loose.message();
  ASSERT_GE(loose->size(), 6u);
  EXPECT_EQ(loose->front().energy_J, tight->front().energy_J) << "iteration 0 at the scene's tolerance";
  const double final_m2 = s.budget * FaceAreas(scene.garment.vertices, scene.garment.faces).sum();
  SolverSettings at_factor = scene.solver;
  at_factor.grad_tol *= s.resolve_tolerance_factor;
  int newton_tight = 0, newton_loose = 0, shrinking = 0, moved_on = 0, at_budget = 0;
  for (size_t k = 0; k < loose->size(); ++k) {
    SCOPED_TRACE("iteration " + std::to_string(k));
    const BesoIteration& it = (*loose)[k];
    const bool reached = it.target_area_m2 <= final_m2 * (1 + 1e-12);
    SceneSpec at = scene;
    at.design = it.design;
    GarmentSystem sys(BuildGarmentModel(at).value(), at.initial);
    Simulator sim(&sys);
    Positions x = it.positions;
    if (k == 0 || reached) {
      EXPECT_EQ(sim.Solve(&x, scene.solver).iterations, 0) << "at the scene's tolerance";
      at_budget += reached;
      continue;
    }
    ++shrinking;
    EXPECT_EQ(sim.Solve(&x, at_factor).iterations, 0) << "at the factor's tolerance";
    x = it.positions;
    moved_on += sim.Solve(&x, scene.solver).iterations > 0;
    newton_loose += it.solver_iterations;
    newton_tight += (*tight)[k].solver_iterations;
  }
  EXPECT_EQ(shrinking, 3);
  EXPECT_GE(at_budget, 1);
  EXPECT_GT(moved_on, 0) << "some shrinking iteration stopped short of the scene's tolerance";
  EXPECT_LT(newton_loose, newton_tight);
}

// An allowed motion of weight 0, or any allowed motion with resist_only, is simulated and reported but
// changes no design: the run is the single-motion scene's, bit for bit.
TEST(DesignLoopMotions, AnAllowedMotionOfWeightZeroChangesNothingButIsReported) {
  const SceneSpec one = FlexingSleeve({{"flex", MotionRole::kResist, 1.0, 0.8}});
  SceneSpec single = one;
  single.motions.clear();
  const SceneSpec zero = FlexingSleeve({{"flex", MotionRole::kResist, 1.0, 0.8}, {"back", MotionRole::kAllow, 0.0, -0.8}});
  const SceneSpec allowed = FlexingSleeve({{"flex", MotionRole::kResist, 1.0, 0.8}, {"back", MotionRole::kAllow, 1.0, -0.8}});
  BesoSettings s = Quick(8), resist_only = Quick(8);
  resist_only.resist_only = true;
  const Result<std::vector<BesoIteration>> a = RunBeso(single, s), b = RunBeso(zero, s), c = RunBeso(allowed, resist_only);
  ASSERT_TRUE(a.ok()) << a.message();
  ASSERT_TRUE(b.ok()) << b.message();
  ASSERT_TRUE(c.ok()) << c.message();
  ExpectSameRun(*a, *b);
  ExpectSameRun(*a, *c);
  ASSERT_EQ(a->back().motions.size(), 1u);
  EXPECT_EQ(a->back().motions[0].name, "flexing_sleeve");
  EXPECT_EQ(a->back().motions[0].energy_J, a->back().energy_J);
  for (const BesoIteration& it : *c) {
    ASSERT_EQ(it.motions.size(), 2u);
    EXPECT_EQ(it.motions[0].reinforced_energy_J, it.reinforced_energy_J);
    EXPECT_EQ(it.motions[1].name, "back");
    EXPECT_EQ(it.motions[1].role, MotionRole::kAllow);
    EXPECT_EQ(it.motions[1].weight, 0.0);
    EXPECT_GT(it.motions[1].reinforced_energy_J, 0.0) << "the allowed motion is simulated";
  }
  EXPECT_EQ(c->front().motions[1].density_ratio, 1.0);
}

// A run of two motions resumed from the records of iteration k continues the uninterrupted one bit for
// bit, every motion's figures included: the other motion warm-starts from its stored equilibrium.
// Records without it (files of before) resume all the same, from the body, and part from it.
TEST(DesignLoopMotions, AResumedRunOfTwoMotionsMatchesTheUninterruptedOne) {
  const SceneSpec scene = FlexingSleeve({{"flex", MotionRole::kResist, 1.0, 0.8}, {"back", MotionRole::kAllow, 1.0, -0.8}});
  const BesoSettings s = Quick(8);
  const Result<std::vector<BesoIteration>> whole = RunBeso(scene, s);
  ASSERT_TRUE(whole.ok()) << whole.message();
  ASSERT_GE(whole->size(), 6u);
  for (const BesoIteration& it : *whole) {
    ASSERT_EQ(it.motion_positions.size(), 1u);
    EXPECT_EQ(it.motion_positions[0].rows(), it.positions.rows());
  }
  std::vector<BesoIteration> head(whole->begin(), whole->begin() + 3);
  const Result<std::vector<BesoIteration>> tail = RunBeso(scene, s, {}, &head);
  ASSERT_TRUE(tail.ok()) << tail.message();
  std::vector<BesoIteration> resumed = head;
  resumed.insert(resumed.end(), tail->begin(), tail->end());
  ExpectSameRun(*whole, resumed);
  for (size_t k = 0; k < whole->size() && k < resumed.size(); ++k) {
    SCOPED_TRACE("iteration " + std::to_string(k));
    ASSERT_EQ(resumed[k].motions.size(), 2u);
    EXPECT_EQ(resumed[k].motions[1].reinforced_energy_J, (*whole)[k].motions[1].reinforced_energy_J);
    EXPECT_EQ(resumed[k].motions[1].solver_iterations, (*whole)[k].motions[1].solver_iterations);
    EXPECT_TRUE(resumed[k].motion_positions[0] == (*whole)[k].motion_positions[0]);
  }
  head.back().motion_positions.clear();
  const Result<std::vector<BesoIteration>> from_body = RunBeso(scene, s, {}, &head);
  ASSERT_TRUE(from_body.ok()) << from_body.message();
  ASSERT_FALSE(from_body->empty());
  EXPECT_FALSE(from_body->front().motion_positions[0] == (*whole)[3].motion_positions[0]) << "solved again from the body: another equilibrium";
}

// With every re-solve at the scene's tolerance (resolve_tolerance_factor 1), an allowed motion's
// re-solves stop at a looser one than a resisted one's; its iteration 0 (the fully reinforced
// reference of its density ratio) and every other motion keep the scene's. The same motion of weight
// 0, allowed or resisted: the same designs, the allowed one's solves shorter, its figures those of an
// equilibrium all the same.
TEST(DesignLoopMotions, AnAllowedMotionIsReSolvedToALooserTolerance) {
  const SceneSpec allowed = FlexingSleeve({{"flex", MotionRole::kResist, 1.0, 0.8}, {"back", MotionRole::kAllow, 0.0, -0.8}});
  const SceneSpec resisted = FlexingSleeve({{"flex", MotionRole::kResist, 1.0, 0.8}, {"back", MotionRole::kResist, 0.0, -0.8}});
  BesoSettings s = Quick(8);
  s.resolve_tolerance_factor = 1;
  const Result<std::vector<BesoIteration>> a = RunBeso(allowed, s), r = RunBeso(resisted, s);
  ASSERT_TRUE(a.ok()) << a.message();
  ASSERT_TRUE(r.ok()) << r.message();
  ExpectSameRun(*a, *r);
  ASSERT_EQ(a->front().motions.size(), 2u);
  EXPECT_EQ(a->front().motions[1].energy_J, r->front().motions[1].energy_J) << "iteration 0 at the scene's tolerance";
  EXPECT_EQ(a->front().motions[1].solver_iterations, r->front().motions[1].solver_iterations);
  int newton_allowed = 0, newton_resisted = 0;
  for (size_t k = 1; k < a->size(); ++k) {
    SCOPED_TRACE("iteration " + std::to_string(k));
    const MotionMetrics &ma = (*a)[k].motions[1], &mr = (*r)[k].motions[1];
    newton_allowed += ma.solver_iterations;
    newton_resisted += mr.solver_iterations;
    EXPECT_EQ((*a)[k].motions[0].solver_iterations, (*r)[k].motions[0].solver_iterations);
    EXPECT_NEAR(ma.energy_J, mr.energy_J, 1e-3 * mr.energy_J);
    EXPECT_NEAR(ma.reinforced_energy_J, mr.reinforced_energy_J, 0.02 * mr.reinforced_energy_J);
  }
  EXPECT_LT(newton_allowed, newton_resisted);
}

// Allowing a sideways flexion moves the reinforcement out of the strain it puts into the garment:
// at the same budget the allowed motion's reinforced energy falls well below the resist-only design's,
// while the resisted motion keeps most of its density ratio.
TEST(DesignLoopMotions, AllowingAMotionMovesTheReinforcementOutOfItsStrain) {
  const SceneSpec scene = FlexingSleeve({{"flex", MotionRole::kResist, 1.0, 0.8}, {"side", MotionRole::kAllow, 1.0, 2.8}});
  BesoSettings both = Quick(14), resist_only = Quick(14);
  resist_only.resist_only = true;
  const Result<std::vector<BesoIteration>> a = RunBeso(scene, both), r = RunBeso(scene, resist_only);
  ASSERT_TRUE(a.ok()) << a.message();
  ASSERT_TRUE(r.ok()) << r.message();
  EXPECT_NEAR(a->back().area_fraction, r->back().area_fraction, 0.02);
  const MotionMetrics& allowed = a->back().motions[1];
  const MotionMetrics& allowed_ro = r->back().motions[1];
  EXPECT_LT(allowed.reinforced_energy_J, 0.5 * allowed_ro.reinforced_energy_J);
  EXPECT_GT(a->back().motions[0].density_ratio, 0.85 * r->back().motions[0].density_ratio);
}

// Bad motions are refused before any simulation, the message naming the motion.
TEST(DesignLoopMotions, BadMotionsAreRefusedByName) {
  const SceneSpec good = FlexingSleeve({{"flex", MotionRole::kResist, 1.0, 0.8}, {"back", MotionRole::kAllow, 1.0, -0.8}});
  auto refused = [&](SceneSpec scene, const std::string& words) {
    const Result<std::vector<BesoIteration>> run = RunBeso(scene, Quick(2));
    ASSERT_FALSE(run.ok());
    EXPECT_NE(run.message().find(words), std::string::npos) << run.message();
  };
  SceneSpec negative = good;
  negative.motions[1].weight = -1;
  refused(negative, "motion 'back': weight -1");
  SceneSpec topology = good;
  topology.motions[1].pose.rest.conservativeResize(topology.motions[1].pose.rest.rows() - 1, 3);
  refused(topology, "motion 'back': its rest pose has another topology");
  SceneSpec moved = good;
  moved.motions[1].pose.rest(0, 0) += 0.01;
  refused(moved, "motion 'back': its rest pose differs");
  SceneSpec none = good;
  none.motions[0].role = MotionRole::kAllow;
  refused(none, "motion 'flex': the first motion is the scene's own and must be resisted");
  SceneSpec twice = good;
  twice.motions[1].name = "flex";
  refused(twice, "motion 'flex': two motions have this name");
  SceneSpec own_mesh = *PullTestScene("all_cloth");
  own_mesh.motions = good.motions;
  refused(own_mesh, "not cut from a body");
}

// The flexing sleeve on a range of limbs (bodies_test_scene.h), built.
SceneSpec Sleeve(const std::vector<std::tuple<std::string, double, double>>& bodies, BodyObjective objective) {
  Result<SceneSpec> s = SleeveForBodies(bodies, objective);
  EXPECT_TRUE(s.ok()) << s.message();
  return s.ok() ? *s : SceneSpec{};
}

// A design for a range of bodies simulates every body on its own garment rest shape each iteration and
// reports each by name: iteration 0 is each body's fully reinforced garment (what EvaluateOnBodies
// gives), a thicker limb stretches its sleeve more, and bodies of weight 0 change no design (the run is
// the scene's own body's alone, bit for bit).
TEST(DesignLoopBodies, EveryBodyIsSimulatedOnItsOwnGarmentAndReportedByName) {
  const SceneSpec sizes = Sleeve({{"M", 0.04, 1.0}, {"S", 0.036, 1.0}, {"L", 0.044, 1.0}}, BodyObjective::kMean);
  const Result<std::vector<BesoIteration>> run = RunBeso(sizes, Quick(5));
  ASSERT_TRUE(run.ok()) << run.message();
  const Result<std::vector<BodyEvaluation>> full = EvaluateOnBodies(sizes, std::vector<uint8_t>(sizes.garment.faces.rows(), kReinforced));
  ASSERT_TRUE(full.ok()) << full.message();
  ASSERT_EQ(full->size(), 3u);
  for (const BesoIteration& it : *run) {
    ASSERT_EQ(it.motions.size(), 3u);
    for (size_t b = 0; b < 3; ++b) {
      EXPECT_EQ(it.motions[b].name, (*full)[b].name);
      EXPECT_EQ(it.motions[b].role, MotionRole::kResist);
      EXPECT_GT(it.motions[b].reinforced_energy_J, 0.0);
    }
    EXPECT_EQ(it.motions[0].energy_J, it.energy_J) << "the iteration's own figures are the scene's own body's";
  }
  const BesoIteration& first = run->front();
  for (size_t b = 0; b < 3; ++b) {
    EXPECT_EQ(first.motions[b].reinforced_energy_J, (*full)[b].full.reinforced_energy_J) << (*full)[b].name;
    EXPECT_EQ(first.motions[b].density_ratio, 1.0);
  }
  EXPECT_LT(first.motions[1].reinforced_density_J_per_m2, first.motions[0].reinforced_density_J_per_m2);
  EXPECT_GT(first.motions[2].reinforced_density_J_per_m2, first.motions[0].reinforced_density_J_per_m2);
  EXPECT_GT(run->back().motions[1].density_ratio, 1.0);
  EXPECT_GT(run->back().motions[2].density_ratio, 1.0);

  SceneSpec own = sizes;
  own.bodies.clear();
  const SceneSpec reported = Sleeve({{"M", 0.04, 1.0}, {"S", 0.036, 0.0}, {"L", 0.044, 0.0}}, BodyObjective::kWorst);
  const Result<std::vector<BesoIteration>> a = RunBeso(own, Quick(5)), b = RunBeso(reported, Quick(5));
  ASSERT_TRUE(a.ok()) << a.message();
  ASSERT_TRUE(b.ok()) << b.message();
  ExpectSameRun(*a, *b);
  EXPECT_EQ(b->back().motions[1].weight, 0.0);
  EXPECT_GT(b->back().motions[1].reinforced_energy_J, 0.0) << "a body of weight 0 is simulated";
}

// Each body's weight in an iteration's sensitivities: with `mean` the scene's weights; with `worst` the
// body of the lowest density ratio the most, the others by exp(-(q_b - q_min) / T), scaled to the
// weights' sum; a body of weight 0 stays out, and equal ratios weigh as the mean does.
TEST(DesignLoopBodies, TheWorstObjectiveWeighsTheWorstBodyMost) {
  SceneSpec scene = Sleeve({{"M", 0.04, 1.0}, {"S", 0.036, 1.0}, {"L", 0.044, 1.0}}, BodyObjective::kWorst);
  const std::vector<SceneMotion> motions = MotionsOf(scene);
  BesoIteration before;
  before.iteration = 10;
  for (const SceneMotion& m : motions) before.motions.push_back({m.name, m.role, m.weight});
  const double q[] = {2.0, 1.9, 2.1};
  for (size_t k = 0; k < 3; ++k) before.motions[k].density_ratio = q[k];
  std::vector<double> w = CaseWeights(scene, motions, before);
  ASSERT_EQ(w.size(), 3u);
  EXPECT_NEAR(w[0] + w[1] + w[2], 3.0, 1e-12);
  EXPECT_GT(w[1], w[0]);
  EXPECT_GT(w[0], w[2]);
  EXPECT_NEAR(w[0] / w[1], std::exp(-0.1 / kWorstBodyTemperature), 1e-12);
  EXPECT_NEAR(w[2] / w[1], std::exp(-0.2 / kWorstBodyTemperature), 1e-12);

  scene.body_objective = BodyObjective::kMean;
  EXPECT_EQ(CaseWeights(scene, motions, before), (std::vector<double>{1.0, 1.0, 1.0}));

  scene.body_objective = BodyObjective::kWorst;
  for (size_t k = 0; k < 3; ++k) before.motions[k].density_ratio = 1.0;
  w = CaseWeights(scene, motions, before);
  for (double v : w) EXPECT_NEAR(v, 1.0, 1e-12) << "equal ratios weigh as the mean";

  scene.bodies[1].weight = 0;
  const std::vector<SceneMotion> without_s = MotionsOf(scene);
  for (size_t k = 0; k < 3; ++k) before.motions[k].density_ratio = q[k];
  w = CaseWeights(scene, without_s, before);
  EXPECT_EQ(w[1], 0.0) << "a body of weight 0 stays out, however low its ratio";
  EXPECT_NEAR(w[0] + w[2], 2.0, 1e-12);
  EXPECT_GT(w[0], w[2]);
}

// Bad bodies are refused before any simulation, the message naming the body.
TEST(DesignLoopBodies, BadBodiesAreRefusedByName) {
  const SceneSpec good = Sleeve({{"M", 0.04, 1.0}, {"L", 0.044, 1.0}}, BodyObjective::kMean);
  auto refused = [&](SceneSpec scene, const std::string& words) {
    const Result<std::vector<BesoIteration>> run = RunBeso(scene, Quick(2));
    ASSERT_FALSE(run.ok());
    EXPECT_NE(run.message().find(words), std::string::npos) << run.message();
  };
  SceneSpec topology = good;
  topology.bodies[1].pose = FlexingLimb(0.044, 20);
  refused(topology, "body 'L': its mesh has another topology");
  SceneSpec negative = good;
  negative.bodies[1].weight = -1;
  refused(negative, "body 'L': weight -1");
  SceneSpec twice = good;
  twice.bodies[1].name = "M";
  refused(twice, "body 'M': two bodies have this name");
  SceneSpec not_own = good;
  std::swap(not_own.bodies[0], not_own.bodies[1]);
  refused(not_own, "body 'L': the first body must be the scene's own");
  SceneSpec with_motions = good;
  with_motions.motions = {{"flex", MotionRole::kResist, 1.0, *good.motion}};
  refused(with_motions, "lists bodies and motions");
  SceneSpec own_mesh = *PullTestScene("all_cloth");
  own_mesh.bodies = good.bodies;
  refused(own_mesh, "not cut from a body");
}

}  // namespace
}  // namespace kgd

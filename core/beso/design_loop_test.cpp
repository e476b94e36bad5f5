// The BESO loop on the pull test: every design meets its target area, every simulation converges,
// the reinforced energy density rises as material goes, and the run is deterministic.
#include "core/beso/design_loop.h"
#include "core/scene/builtin_scenes.h"

#include <cmath>
#include <limits>

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
}

}  // namespace
}  // namespace kgd

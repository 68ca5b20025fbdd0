// fdem/stages_run: step counts of intervals, the schedule of a two-stage scene (stage ends, frame,
// row and checkpoint intervals, an unstable or unbounded time step refused), the checkpoint digest,
// the parameters the results record, and the stages' time loop on two boxes without contact: each
// stage's platen velocity, frames, rows and checkpoints where the schedule puts them, a stop before
// the end, and a failing step handed to the caller before it propagates.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/stages_run.hpp"
#include "support/run_tool.hpp"
#include "support/scene_text.hpp"

using namespace graintwin;
using namespace graintwin::fdem;
using test::replaced;
using test::write_text;

namespace {

/// The two-box scene with checkpoints every 15 us.
std::string checkpointed_scene() {
  return replaced(test::kTwoBoxScene, "series_interval = 2e-6", "series_interval = 2e-6\ncheckpoint_interval = 1.5e-5");
}

/// The checkpointed two-box scene ready to run: its model, solver and schedule.
struct TwoBoxRun {
  test::TempDir dir;
  Scene scene = read_scene(write_text(dir, "s.toml", checkpointed_scene()));
  Model model = build_model(scene);
  RunStart start = start_run(scene, model, "s.toml");
  Solver& solver = *start.solver;
  RunSchedule schedule = schedule_run(scene, solver, "s.toml");
};

std::string schedule_error(const test::TempDir& dir, const std::string& text) {
  const Scene scene = read_scene(write_text(dir, "bad.toml", text));
  Model model = build_model(scene);
  const RunStart start = start_run(scene, model, "bad.toml");
  try {
    schedule_run(scene, *start.solver, "bad.toml");
  } catch (const UsageError& e) {
    return e.message();
  }
  return "no error";
}

}  // namespace

TEST(FdemStagesRun, StepsOfAnIntervalRoundToAtLeastOneAndZeroForNone) {
  EXPECT_EQ(steps_of(0.0, 1e-8), 0u);
  EXPECT_EQ(steps_of(1e-8, 1e-8), 1u);
  EXPECT_EQ(steps_of(1e-10, 1e-8), 1u);  // an interval shorter than a step is every step
  EXPECT_EQ(steps_of(2.6e-8, 1e-8), 3u);
  EXPECT_EQ(steps_of(2.4e-8, 1e-8), 2u);
}

TEST(FdemStagesRun, ScheduleCountsTheStagesStepsAndIntervals) {
  TwoBoxRun run;
  const RunSchedule& s = run.schedule;
  EXPECT_DOUBLE_EQ(s.dt, s.limits.stable());  // no [run] time_step: the stable limit
  const std::uint64_t per_stage = steps_of(2e-5, s.dt);
  EXPECT_EQ(s.stage_end, (std::vector<std::uint64_t>{per_stage, 2 * per_stage}));
  EXPECT_EQ(s.total, 2 * per_stage);
  EXPECT_EQ(s.frame_every, steps_of(1e-5, s.dt));
  EXPECT_EQ(s.row_every, steps_of(2e-6, s.dt));
  EXPECT_EQ(s.checkpoint_every, steps_of(1.5e-5, s.dt));

  // Without intervals: the first frame only (and the last, which the loop always writes), a row
  // every step, a checkpoint at the end only.
  const Scene bare = read_scene(write_text(run.dir, "b.toml", replaced(replaced(replaced(checkpointed_scene(), "frame_interval = 1e-5", ""),
                                                                              "series_interval = 2e-6", ""),
                                                                     "checkpoint_interval = 1.5e-5", "")));
  const RunSchedule b = schedule_run(bare, run.solver, "b.toml");
  EXPECT_EQ(b.frame_every, b.total);
  EXPECT_EQ(b.row_every, 1u);
  EXPECT_EQ(b.checkpoint_every, 0u);

  // time_step_fraction scales the automatic step, and the step counts with it.
  const Scene shorter = read_scene(write_text(run.dir, "f.toml", replaced(checkpointed_scene(), "contact = false", "contact = false\ntime_step_fraction = 0.98")));
  const RunSchedule f = schedule_run(shorter, run.solver, "f.toml");
  EXPECT_DOUBLE_EQ(f.dt, 0.98 * s.limits.stable());
  EXPECT_EQ(f.total, 2 * steps_of(2e-5, f.dt));
}

TEST(FdemStagesRun, AnUnstableOrUnboundedTimeStepIsRefusedNamingTheScene) {
  test::TempDir dir;
  const std::string unstable = schedule_error(dir, replaced(checkpointed_scene(), "contact = false", "contact = false\ntime_step = 1e-3"));
  EXPECT_NE(unstable.find("the time step 0.001 s is above the stable limit"), std::string::npos) << unstable;
  // Rigid grains only and no contact: nothing bounds the step.
  const std::string rigid_only = replaced(checkpointed_scene(), R"(kind = "tet10")", R"(kind = "rigid")");
  const std::string message = schedule_error(dir, rigid_only);
  EXPECT_NE(message.find("bad.toml: no element or contact limit bounds the time step"), std::string::npos) << message;
}

TEST(FdemStagesRun, TheDigestChangesWithTheSceneTheModelAndTheStep) {
  const std::string d = run_digest("scene", "model", 1e-8);
  EXPECT_EQ(d.size(), 16u);
  EXPECT_EQ(d, run_digest("scene", "model", 1e-8));
  EXPECT_NE(d, run_digest("scene ", "model", 1e-8));
  EXPECT_NE(d, run_digest("scene", "model2", 1e-8));
  EXPECT_NE(d, run_digest("scene", "model", std::nextafter(1e-8, 1.0)));
}

TEST(FdemStagesRun, ParametersRecordTheSceneTheStepAndWhatWasDoneBeforeTheRun) {
  TwoBoxRun run;
  const RunSchedule& s = run.schedule;
  const nlohmann::json p = run_parameters(run.scene, "s.toml", "text", run.start, s, 3, "ckpt.h5");
  EXPECT_EQ(p["scene"], "s.toml");
  EXPECT_EQ(p["scene_text"], "text");
  EXPECT_EQ(p["time_step"], s.dt);
  EXPECT_EQ(p["steps"], s.total);
  EXPECT_EQ(p["threads"], 3);
  EXPECT_EQ(p["restart"], "ckpt.h5");
  EXPECT_EQ(p["model_file"], "");
  EXPECT_EQ(p["initial_overlaps"]["relaxation_passes"], 0);
  EXPECT_EQ(p["mass_scaling"]["grains"], 0);
}

TEST(FdemStagesRun, StagesSetThePlatensAndTakeFramesRowsAndCheckpointsOnSchedule) {
  TwoBoxRun run;
  Solver& solver = run.solver;
  const RunSchedule& s = run.schedule;
  const test::TempDir& dir = run.dir;
  set_initial_velocities(solver, run.scene);
  std::vector<std::uint64_t> checkpoints, frames;
  std::uint64_t steps = 0;
  StagesRunHooks hooks;
  hooks.frame = [&] { frames.push_back(solver.step_count()); };
  hooks.checkpoint = [&] { checkpoints.push_back(solver.step_count()); };
  hooks.step = [&] { ++steps; };
  {
    ResultsWriter writer(dir / "r.h5", solver, "{}");
    run_stages(solver, run.scene, s, s.total, &writer, hooks);
    writer.finish({"test"});
  }
  EXPECT_EQ(steps, s.total);
  EXPECT_EQ(solver.step_count(), s.total);
  std::vector<std::uint64_t> expected_frames, expected_checkpoints;
  for (std::uint64_t n = 0; n < s.total; n += s.frame_every) expected_frames.push_back(n);
  expected_frames.push_back(s.total);
  for (std::uint64_t n = s.checkpoint_every; n < s.total; n += s.checkpoint_every) expected_checkpoints.push_back(n);
  expected_checkpoints.push_back(s.total);
  EXPECT_EQ(frames, expected_frames);
  EXPECT_EQ(checkpoints, expected_checkpoints);
  EXPECT_EQ(results_frame_count(dir / "r.h5"), expected_frames.size());
  const ResultsSeries series = read_results_series(dir / "r.h5");
  EXPECT_EQ(series.step.size(), (s.total + s.row_every - 1) / s.row_every);
  // The platen stood still through the first stage and moved at 0.5 m/s through the second.
  EXPECT_NEAR(solver.platens()[0].point.z(), 5e-3 - 0.5 * 2e-5, 0.5 * 2 * s.dt);
  // The rigid box was thrown upward at its scene velocity; the frame keeps each grain's spin.
  const ResultsFrame last = read_results_frame(dir / "r.h5", expected_frames.size() - 1);
  EXPECT_GT(last.centroid[5], 1.4 * solver.time());
  ASSERT_EQ(last.spin.size(), 3 * solver.model().grains.size());
  for (std::size_t g = 0; g < solver.model().grains.size(); ++g)
    EXPECT_EQ(Eigen::Vector3d(last.spin[3 * g], last.spin[3 * g + 1], last.spin[3 * g + 2]), solver.grain_spin(g)) << g;
}

TEST(FdemStagesRun, ARunStopsAtTheLastStepAskedWithACheckpointThere) {
  TwoBoxRun run;
  Solver& solver = run.solver;
  std::vector<std::uint64_t> checkpoints;
  StagesRunHooks hooks;
  hooks.checkpoint = [&] { checkpoints.push_back(solver.step_count()); };
  ResultsWriter writer(run.dir / "r.h5", solver, "{}");
  run_stages(solver, run.scene, run.schedule, 37, &writer, hooks);
  EXPECT_EQ(solver.step_count(), 37u);
  ASSERT_FALSE(checkpoints.empty());
  EXPECT_EQ(checkpoints.back(), 37u);
  EXPECT_EQ(writer.frames(), 2u);  // at step 0 and after the last
}

TEST(FdemStagesRun, AFailingStepIsHandedToTheCallerBeforeItPropagates) {
  TwoBoxRun run;
  RunSchedule s = run.schedule;
  s.dt = std::numeric_limits<double>::quiet_NaN();  // a step the solver refuses
  bool told = false;
  StagesRunHooks hooks;
  hooks.step_failed = [&](Error& e) {
    told = true;
    e.add_context("caller's line");
  };
  ResultsWriter writer(run.dir / "r.h5", run.solver, "{}");
  try {
    run_stages(run.solver, run.scene, s, s.total, &writer, hooks);
    ADD_FAILURE() << "the step did not fail";
  } catch (const Error& e) {
    ASSERT_FALSE(e.context().empty());
    EXPECT_EQ(e.context().back(), "caller's line");
  }
  EXPECT_TRUE(told);
}

// planner_demos.h — demonstrations of the receding-horizon SAMCON planner (sim/samcon_mpc.h) as BFM training rows
// (docs/BFM.md, session 23). DART-style runs, `t2m track-pd --samcon-mpc --target-noise R --export-dir DIR`, hold
// per clip the targets applied to the body (the planner's choice plus noise) and the offsets the planner chose
// (DIR/NAME.ctrl.json, sim/ctrl_file.h). Re-simulating the applied targets from the reference start visits the
// same states again (MuJoCo is deterministic), and each visited state is labelled with the planner's clean action
// there, clamp(balance expert targets + offset), in the policy's [-1, 1] action units.
//
//   PlannerDemos d = load_planner_demos(dir, refs);    // DIR/*.ctrl.json whose NAME is one of the reference clips
//                                                      // (dir: one directory or several, "DIR1,DIR2", in order)
//   ReplayBuffer buf(d.rows, D, A, /*with_expert_labels=*/true);
//   replay_planner_demos(h, refs, d, buf);              // rows (s_t, applied a_t, s_t+1, 1, clip, t, label)
//
// Rows per run: the control steps while the planner was in charge (frames_searched); a run that failed (stopped
// before the clip's end) also drops its last drop_before_fail steps (the planner was already losing the body).
// With NAME.qpos.json beside a ctrl file (what --export-dir writes), the replay is checked against it frame by
// frame: a difference above 1e-9 in any qpos value is an Error (another physics build or another reference).
// Clip ownership: the content labels of the demonstrated clips (walk, run, ...) are the planner's; the balance
// expert's labels on clips of those contents teach falling, so the trainer does not clone them there
// (planner_owned_clips).
// Errors (t2m::Error "planner demos: ..."): a missing directory, no ctrl file naming a reference clip, a file
// whose steps or nu do not match its clip, a replay that departs from its qpos.json, a buffer of other dims.
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "models/bfm/fb_agent.h"
#include "models/bfm/ref_motions.h"
#include "models/bfm/replay_buffer.h"
#include "sim/balance_tracker.h"
#include "sim/ctrl_file.h"
#include "sim/samcon_mpc.h"

namespace t2m::bfm {

struct PlannerDemoOptions {
  int drop_before_fail = 15;    // control steps dropped before the end of a failed run (0.5 s)
  sim::BalanceOptions balance;  // the expert under the planner's offsets (`t2m track-pd`'s defaults)
};

struct PlannerDemos {
  std::vector<std::string> files;         // the ctrl files used, by name
  std::vector<int> clip;                  // their reference clip
  std::vector<std::string> qpos_paths;    // NAME.qpos.json beside each ("" when absent: no check)
  std::vector<sim::CtrlSequence> seq;     // their contents
  std::vector<int> steps;                 // rows each run gives
  std::vector<std::string> skipped;       // ctrl files whose NAME is not a reference clip
  int failed_runs = 0;                    // runs the planner did not finish
  int64_t rows = 0;                       // sum of steps
};

PlannerDemos load_planner_demos(const std::string& dir, const RefMotions& refs, const PlannerDemoOptions& opt = {});

// The directories of a "DIR1,DIR2,..." list, in order (empty names kept: they are no directory).
std::vector<std::string> demo_directories(const std::string& dirs);

// Appends the rows of every run (in file-name order; the replays run in parallel, OpenMP over runs) to buf, which
// needs expert labels and the humanoid's dims.
void replay_planner_demos(const std::shared_ptr<const sim::Humanoid>& h, const RefMotions& refs,
                          const PlannerDemos& demos, ReplayBuffer& buf, const PlannerDemoOptions& opt = {});

// DAgger with the planner (docs/BFM.md, session 25): the policy as the driver of the planner's tracked body
// (sim::BodyDriver), tracking ref as t2m eval track does: z = Eq 2 on ref's kinematic-replay states (L = the
// agent's track_window), the step towards frame t applies mu(s, z_{t-1}) (s = the body's observation), mapped to
// actuator targets. `t2m track-pd --samcon-mpc --mpc-student POLICY` exports such runs; replay_planner_demos then
// labels the student's states with the planner's choice there. The agent must outlive the driver.
sim::BodyDriver policy_driver(FbAgent& agent, const std::shared_ptr<const sim::Humanoid>& h,
                              const sim::QposTrajectory& ref);

// Per reference clip: 1 when its content label (sim name dataset-N_<content>_...) is that of a demonstrated clip.
std::vector<char> planner_owned_clips(const RefMotions& refs, const PlannerDemos& demos);

}  // namespace t2m::bfm

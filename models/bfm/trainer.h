// trainer.h — the BFM training run of ARCHITECTURE.md section 5, scaled to the 2-core machine: seed the replay
// buffer with noisy-PD tracking transitions on the training clips, then FB + actor updates (FbAgent::update) with
// behaviour cloning on the seed data, and from `offline_updates` on, online collection with the current policy
// tracking training clips (z from Eq 2 on the reference), all in resumable chunks.
//
//   BfmTrainer tr(cfg, humanoid, refs, dir);   // loads dir/state.t2mckpt when it exists (resume), else fresh
//   tr.prepare_seed(on_progress);              // collects the seed buffer once (dir/seed_buffer.t2mckpt)
//   while (tr.step() < cfg.total_updates && time left) { auto s = tr.train_step(); ... }
//   tr.save();
//
// One update (train_step), every draw from the run's generators in a fixed order:
//   1. when online collection is due (step >= offline_updates, every collect_every updates): collect_transitions
//      transitions with pi(a | s, z_t), actor noise online_noise, into the online ring buffer ("collect" gen);
//   2. FB batch: batch rows, a fraction online_fraction from the online buffer once it holds >= batch rows, the
//      rest from the seed buffer ("data" gen);
//   3. z: sample_training_z with (z_track, z_goal), the batch's next_obs for goals ("z" gen);
//   4. BC batch: bc_batch rows with bc_z = Eq 2 on the row's own reference window ("data"): seed rows (obs, action),
//      or with dagger (obs, expert label), half of them from the online buffer once it holds >= bc_batch rows;
//   with demo_dir, the seed rows of steps 2 and 4 are split: a share demo_fraction from the planner's
//   demonstrations (labelled with its clean action), the rest from the seed buffer; expert-labelled BC rows (seed
//   and online) are drawn only on clips whose content the planner does not own (demonstration rows stand in
//   where there are none);
//   5. FbAgent::update(batch, "agent" gen).
// Files in dir: state.t2mckpt (nn::TrainState of the agent + generators + counters; atomic), online-STEP.t2mckpt
// (the online buffer saved with that state; older ones are removed after the state is written), seed_buffer.t2mckpt.
// The config (FbConfig + this struct) is recorded in the state; resuming with a different config is an error
// (nn::TrainState names the differing key). Deterministic for a seed and a thread count.
// Errors (t2m::Error "bfm trainer: ..."): bad config values, a seed buffer or online buffer that does not match the
// state (size / dims / rows added), a missing online buffer on resume.
#pragma once
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/bfm/collect.h"
#include "models/bfm/fb_agent.h"
#include "models/bfm/z_sampler.h"
#include "nn/train_state.h"

namespace t2m::bfm {

struct BfmTrainConfig {
  FbConfig fb;
  uint64_t seed = 0;
  int ref_clips = 300;              // training clips used as references (0 = all of the split)
  int static_holds = 0;             // standing-still references the caller adds (append_static_holds): qpos0 +
                                    // this many clip first poses the balance expert holds, max_episode_steps + 1
                                    // frames each (tools/cmd_train_bfm.cpp)
  int64_t seed_transitions = 60000;  // ARCHITECTURE: 1.5-2M; ~220/s on the loaded 2-core machine (docs/BFM.md)
  double seed_noise = 0.1;          // expert action noise of the seed data
  std::string seed_expert = "balance";  // the seed data's (and DAgger labels') tracker: "balance" (PD + balance
                                        // feedback), "balance-hips" (its root torque through the stance hips only,
                                        // sim::BalanceOptions::torque_at_hips_only) or "pd"
  int envs = 16;                    // parallel environments for collection
  int max_episode_steps = 150;
  int64_t total_updates = 20000;
  int64_t offline_updates = 3000;   // updates on seed data only before online collection starts
  int64_t collect_every = 50;       // updates between online collection rounds
  int64_t collect_transitions = 512;
  int64_t online_capacity = 100000;
  double online_fraction = 0.5;
  double online_noise = 0.2;
  int batch = 256;
  int bc_batch = 128;               // 0: no behaviour cloning
  bool dagger = true;               // BC targets = the expert's labels; half the BC rows from the policy's own
                                    // online states, relabelled by the expert (DAgger); false: seed actions only
  double z_track = 0.5, z_goal = 0.2;
  std::string demo_dir;             // planner demonstrations (models/bfm/planner_demos.h; "" = none): their rows
                                    // join the seed data with the planner's labels
  double demo_fraction = 0.5;       // with demos: the share of the seed-data rows of the FB and BC batches drawn
                                    // from the demonstrations; BC rows from the expert (seed and DAgger) are then
                                    // only drawn on clips the planner does not own (planner_owned_clips)

  nlohmann::json to_json() const;
  static BfmTrainConfig from_json(const nlohmann::json& j);  // missing keys keep defaults; unknown keys: Error
  void validate() const;
};

struct BfmStepStats {
  FbUpdateStats fb;
  bool collected = false;
  CollectStats collect;  // when collected
};

class BfmTrainer {
 public:
  BfmTrainer(const BfmTrainConfig& cfg, std::shared_ptr<const sim::Humanoid> h, const RefMotions& refs,
             std::string dir);
  ~BfmTrainer();

  bool resumed() const { return resumed_; }
  // Collects (or loads) the seed buffer; on_progress(done, total) is called between chunks.
  // With demo_dir, also replays the demonstrations into the demo buffer (checked against the count saved in the
  // state on resume).
  void prepare_seed(const std::function<void(int64_t, int64_t)>& on_progress = {});
  BfmStepStats train_step();
  void save();

  int64_t step() const { return ts_->step; }
  FbAgent& agent() { return *agent_; }
  const ReplayBuffer& seed_buffer() const { return *seed_; }
  const ReplayBuffer& online_buffer() const { return *online_; }
  const ReplayBuffer* demo_buffer() const { return demo_.get(); }  // nullptr without demo_dir
  const std::vector<char>& planner_owned() const { return owned_; }  // per reference clip (empty without demos)
  // Demonstration runs used, of those the planner did not finish, ctrl files not naming a reference clip.
  int demo_files() const { return demo_files_; }
  int demo_failed() const { return demo_failed_; }
  int demo_skipped() const { return demo_skipped_; }
  const BfmTrainConfig& config() const { return cfg_; }
  std::string state_path() const { return dir_ + "/state.t2mckpt"; }
  std::string seed_path() const { return dir_ + "/seed_buffer.t2mckpt"; }

 private:
  BfmTrainConfig cfg_;
  std::shared_ptr<const sim::Humanoid> h_;
  const RefMotions& refs_;
  std::string dir_;
  std::unique_ptr<FbAgent> agent_;
  std::unique_ptr<nn::TrainState> ts_;
  Generator gen_data_, gen_z_, gen_agent_, gen_collect_, gen_seed_;
  std::unique_ptr<ReplayBuffer> seed_, online_, demo_;
  std::vector<char> owned_;  // planner-owned reference clips (with demos)
  bool any_free_ = false;    // some clip is not owned
  int demo_files_ = 0, demo_failed_ = 0, demo_skipped_ = 0;
  std::unique_ptr<TrackingCollector> collector_;
  bool resumed_ = false;
  ReplayBatch seed_batch_, online_batch_, bc_batch_, bc_online_batch_, demo_batch_, bc_demo_batch_;
  void prepare_demos();
};

// The encoder / policy callbacks of collect.h bound to an agent.
EncodeFn agent_encoder(FbAgent& agent);
PolicyFn agent_policy(FbAgent& agent);

}  // namespace t2m::bfm

// gen_train.h — training the flow generator on a ProgramDataset (`t2m train gen`): Eq 14–15 conditional flow
// matching on standardised programs, condition dropout (FlowGeneratorConfig::cond_dropout, 0.2), AdamW
// (no decay on 1-D parameters), warm-up + cosine learning rate, gradient clipping at 1, in resumable chunks.
//
// One step: batch (B windows of W program frames, program_dataset.h) from rng "data"; t ~ U[0, 1) and ε ~ N(0, I)
// from rng "flow" (nn::sample_flow_pair); dropped samples from rng "drop"; loss = mean over real frames and
// channels of (v_η(m_t, t, Y) − (m − ε))² (nn::flow_matching_loss with the frame mask).
// objective "diffusion" (Table 5's variant): the same network and loop, but t ~ U[0, 1) and ε from rng "flow"
// (nn::sample_diffusion_pair), x_t = alpha(t) m + sigma(t) ε with the cosine (or linear) VP schedule, the network
// gets r = 1 − t and the loss is the v-prediction MSE mean over real frames of (v_η − (alpha ε − sigma m))²
// (nn::diffusion_v_loss); sample with diffusion_sampler.h.
// ema > 0: an exponential moving average of the weights (nn::Ema, decay ema with the (1 + t) / (10 + t) warm-up)
// is updated after every step and saved in the train state; on return the generator holds the AVERAGED weights
// (what `t2m train gen --ema` writes as its checkpoint), the training values are in the state file.
// Resumable: nn::TrainState at paths.state every save_every steps and at the end (parameters, AdamW moments,
// EMA shadow when ema > 0, the three generators, step); resume = bit-identical continuation for the same thread
// count. stop_at > 0 ends the run (resumably) after that many steps in total. JSONL log (step, loss, lr,
// grad_norm) and an SVG plot.
// Errors (t2m::Error): bad config values ("gen train: ..."), and those of TrainState::load on a mismatched state.
#pragma once
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

#include "models/text2bfm/generator.h"
#include "models/text2bfm/program_dataset.h"
#include "nn/train_config.h"

namespace t2m::text2bfm {

struct GenTrainConfig : nn::TrainLoopConfig {
  std::string objective = "flow";   // "flow" (Eq 15) | "diffusion" (v-prediction)
  std::string schedule = "cosine";  // diffusion only
  double ema = 0;                   // EMA decay of the weights, in [0, 1); 0: none (the final weights are kept)
  GenTrainConfig() { steps = 3000, batch = 32, lr = 3e-4, warmup = 100, save_every = 250; }
  nlohmann::json to_json() const;   // objective/schedule only when not flow, ema only when > 0 (older states resume)
  void validate() const;
};

using GenTrainPaths = nn::TrainPaths;

using GenTrainResult = nn::TrainRunResult;

GenTrainResult train_generator(FlowGenerator& gen, const ProgramDataset& data, const GenTrainConfig& cfg,
                               const GenTrainPaths& paths, bool resume, const std::string& label = "train gen");

}  // namespace t2m::text2bfm

// tiny_text2bfm.h — test helper: the four checkpoints of the Text2BFM chain with tiny, randomly initialised models
// (test_text2bfm_pipeline.cpp uses them as its fixture) saved in a directory, so pipeline-level code can run
// without the shipped checkpoints. save_tiny_text2bfm(dir) writes them and returns their paths.
#pragma once
#include <memory>
#include <string>

#include "models/bfm/policy_checkpoint.h"
#include "models/data/features.h"
#include "models/text/text_motion_model.h"
#include "models/text2bfm/pipeline.h"
#include "models/text2bfm/vbb_checkpoint.h"

namespace t2m::test_util {

inline constexpr int64_t kTinyZ = 8;  // tiny BFM latent width

inline text2bfm::PipelinePaths save_tiny_text2bfm(const std::string& dir) {
  const auto p = text2bfm::PipelinePaths::in_dir(dir);
  text::RetrievalBundle b;
  b.tokenizer = text::Tokenizer::build({"a person walks forward", "someone waves with the right hand",
                                        "a person runs in a circle", "someone sits down"});
  text::TextMotionConfig c;
  c.text.vocab = b.tokenizer.vocab_size(), c.text.dim = 8, c.text.layers = 1, c.text.heads = 2;
  c.text.embed_dim = 6, c.text.max_len = 24;
  c.motion.dim = 8, c.motion.layers = 1, c.motion.heads = 2, c.motion.patch = 4, c.motion.max_patches = 4;
  c.motion.embed_dim = 6, c.motion.feature_dim = data::kFeatureDim;
  Generator g(1);
  b.model = std::make_shared<text::TextMotionModel>(c, g);
  b.stats.mean.assign(data::kFeatureDim, 0.f);
  b.stats.std.assign(data::kFeatureDim, 1.f);
  b.window = 16;
  text::save_retrieval_checkpoint(b, p.text);

  text2bfm::VbbConfig vc;
  vc.in_dim = kTinyZ, vc.width = 16, vc.latent = 4, vc.levels = 2, vc.depth = 1, vc.groups = 4;
  text2bfm::Vbb vbb(vc, g);
  text2bfm::save_vbb(vbb, p.vbb);

  text2bfm::FlowGeneratorConfig fc;
  fc.latent = 4, fc.width = 16, fc.depth = 1, fc.heads = 2, fc.ctx_dim = 16, fc.freq_dim = 16;
  fc.adapter = {.tok_dim = 8, .width = 16, .depth = 1, .heads = 2, .ctx_dim = 16, .max_len = 24};
  text2bfm::GenBundle gb;
  gb.model = std::make_shared<text2bfm::FlowGenerator>(fc, g);
  gb.program_mean = Tensor::full({4}, 0.1);
  gb.program_std = Tensor::full({4}, 0.5);
  gb.compression = vc.compression();
  gb.window = 8;
  text2bfm::save_gen_checkpoint(gb, p.gen);

  bfm::FbConfig bc;
  bc.z_dim = kTinyZ, bc.hidden = 32, bc.b_hidden = 32;
  bfm::FbAgent agent(bc, 3);
  bfm::save_policy(agent, p.bfm);
  return p;
}

}  // namespace t2m::test_util

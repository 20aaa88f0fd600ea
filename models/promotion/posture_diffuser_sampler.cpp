// posture_diffuser_sampler.cpp — guided DDPM sampling of postures and the bundle's checkpoint I/O.
#include "models/promotion/posture_diffuser_sampler.h"

#include "autograd/no_grad.h"
#include "models/promotion/diffusion_schedule.h"
#include "nn/checkpoint.h"
#include "tensor/ops.h"
#include "tensor/rng.h"

namespace t2m::promotion {

std::vector<float> sample_postures(const PostureModel& m, const std::vector<std::string>& scripts, int n_per_script,
                                   uint64_t seed, const PostureSampleOptions& opt) {
  if (scripts.empty() || n_per_script < 1)
    throw Error("sample_postures: need at least one script and n_per_script >= 1, got " +
                std::to_string(scripts.size()) + " scripts, n " + std::to_string(n_per_script));
  ag::NoGradGuard ng;
  const PostureDiffuser& net = *m.net;
  const auto& cfg = net.config();
  std::vector<std::string> rep;
  for (const auto& s : scripts)
    for (int j = 0; j < n_per_script; ++j) rep.push_back(s);
  const int64_t B = (int64_t)rep.size();
  const text::EncodedBatch enc = m.tokenizer.encode_batch(rep, cfg.max_tokens);
  const ScriptContext cond = net.encode(enc.ids, enc.mask);
  const ScriptContext null = net.null_context(B);
  const DiffusionSchedule sched = DiffusionSchedule::linear((int)cfg.diffusion_steps, cfg.beta_start, cfg.beta_end);
  Generator gen(seed);
  const int steps = opt.steps == 0 ? sched.steps() : opt.steps;
  if (steps < 1 || steps > sched.steps())
    throw Error("sample_postures: steps " + std::to_string(opt.steps) + " outside [0, " +
                std::to_string(sched.steps()) + "] (0 = all)");
  const Tensor x = ddim_sample(sched, {B, kPoseDim}, [&](const Tensor& x_t, int t) {
    const Tensor tt = Tensor::full({B}, (double)t, DType::i64);
    const ag::Variable xv(x_t);
    const Tensor c = net.forward(xv, tt, cond).data();
    const Tensor u = net.forward(xv, tt, null).data();
    return add(u, mul(sub(c, u), opt.guidance));  // paper Eq 3
  }, gen, steps, opt.eta);
  std::vector<float> out = x.contiguous().to_vector<float>();
  denormalize_poses(out, m.stats);
  return out;
}

void save_posture_model(const PostureModel& m, const std::string& path) {
  nn::Checkpoint ck;
  ck.meta["kind"] = "promotion_posture";
  ck.meta["config"] = m.net->config().to_json();
  ck.meta["info"] = m.info;
  m.tokenizer.save_to(ck, "tokenizer");
  m.net->save_to(ck, "model.");
  ck.put("pose_mean", Tensor::from_vector(m.stats.mean, {kPoseDim}));
  ck.put("pose_std", Tensor::from_vector(m.stats.std, {kPoseDim}));
  ck.save(path);
}

PostureModel load_posture_model(const std::string& path) {
  const nn::Checkpoint ck = nn::Checkpoint::load(path);
  if (!ck.meta.contains("kind") || ck.meta["kind"] != "promotion_posture")
    throw Error("load_posture_model: " + path + " is not a promotion_posture checkpoint (kind " +
                (ck.meta.contains("kind") ? ck.meta["kind"].dump() : std::string("missing")) + ")");
  if (!ck.meta.contains("config")) throw Error("load_posture_model: " + path + " has no config");
  PostureModel m;
  const PostureDiffuserConfig cfg = PostureDiffuserConfig::from_json(ck.meta["config"]);
  Generator g(0);
  m.net = std::make_shared<PostureDiffuser>(cfg, g);
  m.net->load_from(ck, "model.");
  m.net->eval();
  m.tokenizer = text::Tokenizer::load_from(ck, "tokenizer");
  if (m.tokenizer.vocab_size() != cfg.vocab)
    throw Error("load_posture_model: " + path + " tokenizer size " + std::to_string(m.tokenizer.vocab_size()) +
                " != config vocab " + std::to_string(cfg.vocab));
  m.stats.mean = ck.expect("pose_mean", {kPoseDim}, DType::f32).to_vector<float>();
  m.stats.std = ck.expect("pose_std", {kPoseDim}, DType::f32).to_vector<float>();
  m.info = ck.meta.contains("info") ? ck.meta["info"] : nlohmann::json::object();
  return m;
}

}  // namespace t2m::promotion

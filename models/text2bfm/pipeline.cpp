// pipeline.cpp — loading the four checkpoints and running text -> programs -> latents -> simulated states.
#include "models/text2bfm/pipeline.h"

#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <limits>

#include "autograd/no_grad.h"
#include "models/bfm/policy_checkpoint.h"
#include "models/text/text_motion_model.h"
#include "models/text/tokenizer.h"
#include "models/text2bfm/compose.h"
#include "models/text2bfm/diffusion_sampler.h"
#include "models/text2bfm/flow_sampler.h"
#include "models/text2bfm/latent_cache.h"
#include "models/text2bfm/vbb_checkpoint.h"
#include "models/text2bfm/vbb_eval.h"
#include "sim/env.h"
#include "sim/observation.h"

namespace t2m::text2bfm {

namespace {

namespace fs = std::filesystem;
constexpr double kFallHeight = 0.5;  // m, sim/pd_tracker.h's fall_height
constexpr double kMaxLengthS = 120.0;
constexpr int64_t kMaxCandidates = 64;

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Process CPU time (all threads), seconds: stage cost on a machine where other processes hold the cores.
double process_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

void require_file(const std::string& path, const std::string& what, const std::string& how) {
  if (!fs::is_regular_file(path))
    throw Error("missing checkpoint " + path + " (" + what + "; make it with `" + how + "`)");
}

}  // namespace

Text2BfmModels load_text2bfm(const PipelinePaths& p) {
  require_file(p.text, "frozen text encoder", "t2m train text");
  require_file(p.vbb, "VBB", "t2m train vbb");
  require_file(p.gen, "flow generator", "t2m train gen");
  require_file(p.bfm, "BFM policy", "t2m train bfm");
  Text2BfmModels m;
  m.paths = p;
  m.text = text::load_text_motion_model(p.text);
  const auto* tm = dynamic_cast<const text::TextMotionModel*>(m.text.model.get());
  if (!tm) throw Error("text encoder " + p.text + ": not a text_encoder checkpoint");
  m.encoder = &tm->text();
  m.vbb = load_vbb(p.vbb);
  m.gen = load_gen_checkpoint(p.gen);
  m.policy = bfm::load_policy(p.bfm);
  m.humanoid = sim::Humanoid::create();

  const auto& gc = m.gen.model->config();
  const auto& vc = m.vbb->config();
  const auto& fc = m.policy->config();
  auto mismatch = [](const std::string& what, int64_t a, int64_t b) {
    if (a != b)
      throw Error("checkpoints do not fit together: " + what + " (" + std::to_string(a) + " vs " +
                  std::to_string(b) + ")");
  };
  mismatch("text encoder token width vs generator adapter tok_dim", m.encoder->config().dim, gc.adapter.tok_dim);
  mismatch("VBB latent vs generator latent", vc.latent, gc.latent);
  mismatch("VBB compression vs the generator's", vc.compression(), m.gen.compression);
  mismatch("VBB in_dim vs BFM z_dim", vc.in_dim, fc.z_dim);
  // The generator learned programs of latents from one BFM (its B); a rollout with another policy still runs but
  // the latents mean something else to it: say so in the outputs. Generators since session 47 record the latent
  // space itself (B's checksum: a policy fine-tuned from that BFM keeps it), older ones the BFM file's checksum.
  const auto recorded = [&](const char* key) { return m.gen.train.contains(key) && m.gen.train[key].is_string(); };
  if (recorded("bfm_latent_checksum")) {
    const std::string want = m.gen.train["bfm_latent_checksum"].get<std::string>(),
                      have = bfm::latent_space_checksum(*m.policy);
    if (want != have)
      m.warnings.push_back("the generator was trained on the latent space " + want + " (B of " +
                           m.gen.train.value("bfm", std::string("?")) + "), the policy " + p.bfm + " has " + have);
  } else if (recorded("bfm_checksum")) {
    const std::string want = m.gen.train["bfm_checksum"].get<std::string>(), have = file_checksum(p.bfm);
    if (want != have)
      m.warnings.push_back("the generator was trained on latents of BFM " + want + ", the policy " + p.bfm +
                           " is " + have);
  }
  sim::Env probe(m.humanoid);
  mismatch("BFM obs_dim vs the humanoid's", fc.obs_dim, probe.obs_dim());
  mismatch("BFM action_dim vs the humanoid's", fc.action_dim, probe.action_dim());
  return m;
}

void GenerateOptions::validate() const {
  if (!(length_s > 0) || length_s > kMaxLengthS)
    throw Error("generate: --length must be in (0, 120] seconds, got " + std::to_string(length_s));
  if (steps < 1) throw Error("generate: --steps must be >= 1, got " + std::to_string(steps));
  if (!std::isfinite(cfg)) throw Error("generate: --cfg must be finite");
  if (overlap < 0) throw Error("generate: --overlap must be >= 0, got " + std::to_string(overlap));
  if (candidates < 1 || candidates > kMaxCandidates)
    throw Error("generate: --candidates must be in [1, " + std::to_string(kMaxCandidates) + "], got " +
                std::to_string(candidates));
}

TextTokens encode_prompt_texts(const Text2BfmModels& m, const std::vector<std::string>& texts) {
  for (const auto& t : texts) {
    if (m.text.tokenizer.all_unknown(t))
      throw Error("generate: no word of \"" + t + "\" is in the text encoder's vocabulary (" +
                  std::to_string(m.text.tokenizer.vocab_size() - 4) + " words, e.g. 'walk', 'run', 'dance')");
  }
  ag::NoGradGuard ng;
  const int64_t max_len = std::min(m.encoder->config().max_len, m.gen.model->config().adapter.max_len);
  const text::EncodedBatch e = text::encode_captions(m.text.tokenizer, texts, max_len);
  const text::TextFeatures f = m.encoder->forward(e.ids, e.mask);
  return {f.tokens.data().contiguous(), e.mask};
}

namespace {

// Stages "sample" to "rollout" of one candidate into g (prompt, clauses, options and the text stage already set),
// with m(0) from Generator(seed).
void sample_and_roll_out(Text2BfmModels& m, const TextTokens& tt, uint64_t seed, Generation& g) {
  using clock = std::chrono::steady_clock;
  const GenerateOptions& opt = g.opt;
  // Lengths (see the header).
  const int64_t T = std::max<int64_t>(1, std::llround(opt.length_s / sim::kControlDt));
  const int64_t c = m.vbb->config().compression(), N = (int64_t)g.clauses.size();
  const int64_t per = N == 1 ? T : (T + (N - 1) * opt.overlap + N - 1) / N;
  const int64_t Tm = std::max<int64_t>(1, (per + c - 1) / c);

  // Stage "sample": m(0) ~ N(0, I), Eq 16 with CFG, then undo the standardisation.
  auto t0 = clock::now();
  double c0 = process_cpu_s();
  Generator rng(seed);
  Tensor prog;
  if (m.gen.objective == "diffusion") {  // Table 5's variant: v-prediction network, DDIM
    DiffusionSamplerOptions so;
    so.steps = opt.steps;
    so.guidance = opt.cfg;
    so.schedule = nn::noise_schedule_from_name(m.gen.schedule);
    prog = sample_programs_diffusion(*m.gen.model, tt.tokens, tt.mask, Tm, rng, so).to(DType::f32).contiguous();
  } else {
    FlowSamplerOptions so;
    so.steps = opt.steps;
    so.guidance = opt.cfg;
    prog = sample_programs(*m.gen.model, tt.tokens, tt.mask, Tm, rng, so).to(DType::f32).contiguous();
  }
  {
    const int64_t dm = prog.size(2);
    const float* mu = m.gen.program_mean.data<float>();
    const float* sd = m.gen.program_std.data<float>();
    float* p = prog.data<float>();
    for (int64_t i = 0; i < prog.numel(); ++i) p[i] = p[i] * sd[i % dm] + mu[i % dm];
  }
  g.times.sample = seconds_since(t0);
  g.cpu.sample = process_cpu_s() - c0;

  // Stage "decode": D_θ (Eq 4), Compose (Eq 18-19), projection onto the policy's sphere.
  t0 = clock::now();
  c0 = process_cpu_s();
  {
    ag::NoGradGuard ng;
    Generator unused(0);
    const Tensor zhat =
        m.vbb->decode(ag::Variable(prog.permute({0, 2, 1}).contiguous()), unused).data().contiguous();  // (B,Tz,d)
    std::vector<Tensor> segs;
    for (int64_t n = 0; n < N; ++n) segs.push_back(zhat.select(0, n));
    Tensor z = compose_latents(segs, N > 1 ? opt.overlap : 0);
    g.z = z.narrow(0, 0, std::min<int64_t>(T, z.size(0))).clone();
  }
  g.z = project_rows_to_sphere(g.z);  // the sphere the BFM's latents live on
  g.times.decode = seconds_since(t0);
  g.cpu.decode = process_cpu_s() - c0;

  // Stage "rollout": the BFM policy mean in MuJoCo from the standing start (or the given start state).
  t0 = clock::now();
  c0 = process_cpu_s();
  sim::Env env(m.humanoid);
  const int D = env.obs_dim(), nq = env.nq(), nv = env.nv(), A = env.action_dim();
  const int64_t steps = g.z.size(0), d = g.z.size(1);
  g.traj.frames = int(steps + 1);
  g.traj.nq = nq;
  g.traj.nv = nv;
  g.traj.qpos.resize((size_t)(steps + 1) * nq);
  g.traj.qvel.resize((size_t)(steps + 1) * nv);
  g.obs.resize((size_t)(steps + 1) * D);
  std::vector<double> qvel0((size_t)nv, 0.0);
  if (opt.start_qpos.empty())  // sizes checked by generate_motion
    env.reset(m.humanoid->model()->qpos0, qvel0.data(), g.obs.data());
  else
    env.reset(opt.start_qpos.data(), opt.start_qvel.data(), g.obs.data());
  const int root = m.humanoid->root_qpos();
  auto record = [&](int64_t t) {
    std::copy(env.data()->qpos, env.data()->qpos + nq, g.traj.qpos.begin() + t * nq);
    std::copy(env.data()->qvel, env.data()->qvel + nv, g.traj.qvel.begin() + t * nv);
  };
  record(0);
  Tensor obs_t = Tensor::empty({1, D}), z_t = Tensor::empty({1, d});
  bool below = false;
  g.min_root_height = root >= 0 ? g.traj.qpos[(size_t)root + 2] : 0.0;
  for (int64_t t = 0; t < steps; ++t) {
    std::copy(g.obs.begin() + t * D, g.obs.begin() + (t + 1) * D, obs_t.data<float>());
    std::copy(g.z.data<float>() + t * d, g.z.data<float>() + (t + 1) * d, z_t.data<float>());
    const Tensor a = m.policy->actor_mean(obs_t, z_t).contiguous();
    if (a.size(-1) != A) throw Error("generate: policy action width does not match the humanoid");
    env.step(a.data<float>(), g.obs.data() + (t + 1) * D);
    if (env.diverged()) throw Error("generate: the physics diverged at control step " + std::to_string(t));
    record(t + 1);
    if (root >= 0) {
      const double h = g.traj.qpos[(size_t)(t + 1) * nq + root + 2];
      g.min_root_height = std::min(g.min_root_height, h);
      if (h < kFallHeight && !below) {
        ++g.falls;
        if (g.first_fall_s < 0) g.first_fall_s = double(t + 1) * sim::kControlDt;
      }
      below = h < kFallHeight;
    }
  }
  g.times.rollout = seconds_since(t0);
  g.cpu.rollout = process_cpu_s() - c0;
}

// Time to the first fall, +inf without one: candidates are ranked by it.
double upright_rank(const Generation& g) {
  return g.first_fall_s < 0 ? std::numeric_limits<double>::infinity() : g.first_fall_s;
}

void add_generation_times(StageTimes& sum, const StageTimes& t) {
  sum.sample += t.sample, sum.decode += t.decode, sum.rollout += t.rollout;
}

}  // namespace

Generation generate_motion(Text2BfmModels& m, const std::string& prompt, const GenerateOptions& opt) {
  opt.validate();
  const size_t nq = (size_t)m.humanoid->model()->nq, nv = (size_t)m.humanoid->model()->nv;
  if (!(opt.start_qpos.empty() && opt.start_qvel.empty()) &&
      !(opt.start_qpos.size() == nq && opt.start_qvel.size() == nv))
    throw Error("generate: a start state needs qpos [" + std::to_string(nq) + "] and qvel [" + std::to_string(nv) +
                "], got [" + std::to_string(opt.start_qpos.size()) + "] and [" +
                std::to_string(opt.start_qvel.size()) + "]");
  Generation head;
  head.prompt = prompt;
  head.opt = opt;
  if (text::split_words(prompt).empty()) throw Error("generate: the prompt is empty");
  head.clauses = opt.compose ? split_clauses(prompt) : std::vector<std::string>{text::normalize(prompt)};
  if (head.clauses.empty()) throw Error("generate: the prompt has no clause with words");
  if (!opt.compose && m.text.tokenizer.all_unknown(prompt))
    throw Error("generate: no word of \"" + prompt + "\" is in the text encoder's vocabulary");

  // Stage "text": tokenizer + frozen text encoder (once for all candidates).
  const auto t0 = std::chrono::steady_clock::now();
  const double c0 = process_cpu_s();
  const TextTokens tt = encode_prompt_texts(m, head.clauses);
  head.times.text = seconds_since(t0);
  head.cpu.text = process_cpu_s() - c0;

  // Candidates: the longest upright rollout (no fall beats any fall), then fewer falls, then the lower seed.
  Generation best;
  StageTimes times = head.times, cpu = head.cpu;
  std::vector<double> upright;
  for (int64_t k = 0; k < opt.candidates; ++k) {
    Generation g = head;
    sample_and_roll_out(m, tt, opt.seed + uint64_t(k), g);
    add_generation_times(times, g.times);
    add_generation_times(cpu, g.cpu);
    upright.push_back(g.first_fall_s < 0 ? double(g.traj.frames - 1) * sim::kControlDt : g.first_fall_s);
    const double uk = upright_rank(g), ub = upright_rank(best);
    if (k == 0 || uk > ub || (uk == ub && g.falls < best.falls)) {
      best = std::move(g);
      best.candidate = k;
    }
  }
  best.times = times, best.cpu = cpu;
  best.candidate_upright_s = std::move(upright);
  return best;
}

}  // namespace t2m::text2bfm

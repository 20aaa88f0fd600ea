// cmd_train_gen.cpp — `t2m train gen`: the Text2BFM flow generator (Eq 14–15) on the TRAIN split of the Bandai
// data. Programs m = posterior means of the frozen VBB encoder (Eq 3) over the cached policy latents (Eq 2, the
// frozen BFM; latent_cache.h), text = the frozen text encoder's token features of captions made from the clips'
// labels (make_caption, --paraphrases per clip). Resumable chunks (--resume, --stop-at), progress bar, JSONL log +
// SVG plot, OUT/gen_small.t2mckpt (+ --ship PATH) and OUT/summary.json. See docs/GENERATE.md.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "autograd/no_grad.h"
#include "models/bfm/policy_checkpoint.h"
#include "models/data/captions.h"
#include "models/text/text_motion_model.h"
#include "models/text2bfm/gen_train.h"
#include "models/text2bfm/latent_cache.h"
#include "models/text2bfm/pipeline_checkpoints.h"
#include "models/text2bfm/vbb_checkpoint.h"
#include "models/text2bfm/program_dataset.h"
#include "nn/checkpoint.h"
#include "tensor/ops.h"
#include "tensor/parallel.h"
#include "tools/command.h"
#include "tools/text_data.h"

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using t2m::Error;
namespace t2b = t2m::text2bfm;

struct GenArgs {
  std::string ckpt_dir = "models/checkpoints", text, vbb, bfm, latents, manifest, out, ship;
  bool resume = false;
  int threads = 0, paraphrases = 8;
  int64_t window = 16;  // program frames (x compression latents)
  t2b::GenTrainConfig train;
  t2b::FlowGeneratorConfig gen;
};

std::string or_default(const std::string& v, const std::string& d) { return v.empty() ? d : v; }

void require(const std::string& path, const std::string& how) {
  if (!fs::is_regular_file(path)) throw Error("train gen: missing " + path + " (make it with `" + how + "`)");
}

void run(GenArgs a, const std::string& cmdline) {
  if (a.threads > 0) t2m::set_num_threads(a.threads);
  if (a.paraphrases < 1) throw Error("train gen: --paraphrases must be >= 1");
  if (a.window < 1) throw Error("train gen: --window must be >= 1");
  a.train.validate();
  const auto set = t2b::PipelinePaths::in_dir(a.ckpt_dir);
  const std::string text_p = or_default(a.text, set.text), vbb_p = or_default(a.vbb, set.vbb);
  const std::string bfm_p = or_default(a.bfm, set.bfm);
  require(text_p, "t2m train text");
  require(vbb_p, "t2m train vbb");
  require(bfm_p, "t2m train bfm");
  const std::string out = a.out.empty() ? t2m::cli::default_output_dir("gen") : a.out;
  fs::create_directories(out);

  // Frozen parts.
  const auto tb = t2m::text::load_text_motion_model(text_p);
  const auto& enc = dynamic_cast<const t2m::text::TextMotionModel&>(*tb.model).text();
  const auto vbb = t2b::load_vbb(vbb_p);
  auto agent = t2m::bfm::load_policy(bfm_p);
  if (vbb->config().in_dim != agent->config().z_dim) throw Error("train gen: VBB in_dim != BFM z_dim");

  // Policy latents of the train clips (Eq 2), cached per BFM.
  const std::string mpath = or_default(a.manifest, t2m::data::default_cache_dir() + "/bandai/manifest.json");
  const std::string lpath = or_default(a.latents, t2m::data::default_cache_dir() + "/latents/train.t2mckpt");
  fs::create_directories(fs::path(lpath).parent_path());
  const std::string sum = t2b::file_checksum(bfm_p);
  const int L = agent->config().track_window;
  const t2b::LatentSet ls = t2b::ensure_latent_cache(lpath, sum, L, [&] {
    if (!fs::exists(mpath)) throw Error("train gen: no manifest at " + mpath + " (run `t2m data prepare`)");
    const auto manifest = t2m::data::load_manifest(mpath);
    auto h = t2m::sim::Humanoid::create();
    std::fprintf(stderr, "train gen: extracting the train-split policy latents (Eq 2) ...\n");
    return t2b::extract_split_latents(*agent, *h, manifest, t2m::data::Split::train, sum, L);
  });

  // Programs (Eq 3 posterior means) and captions.
  std::vector<t2m::Tensor> z;
  std::vector<std::string> texts;
  std::vector<std::vector<int64_t>> caps;
  for (int c = 0; c < ls.clips(); ++c) {
    z.push_back(t2m::Tensor::from_vector(std::vector<float>(ls.z_at(c, 0), ls.z_at(c, 0) + ls.frames(c) * ls.z_dim),
                                         {ls.frames(c), ls.z_dim}));
    caps.emplace_back();
    for (int k = 0; k < a.paraphrases; ++k) {
      caps.back().push_back((int64_t)texts.size());
      texts.push_back(t2m::data::make_caption(ls.content[c], ls.style[c], 0, k).text);
    }
  }
  std::fprintf(stderr, "train gen: %d train clips, %zu captions; encoding programs and text ...\n", ls.clips(),
               texts.size());
  auto programs = t2b::encode_programs(*vbb, z);
  const int64_t max_len = std::min(enc.config().max_len, a.gen.adapter.max_len);
  const auto eb = t2m::text::encode_captions(tb.tokenizer, texts, max_len);
  t2m::Tensor tokens;
  {
    t2m::ag::NoGradGuard ng;  // in chunks of 512 captions: one pass over all 17,944 needs ~5.6 GB
    std::vector<t2m::Tensor> parts;
    const int64_t n = eb.ids.size(0);
    for (int64_t i = 0; i < n; i += 512) {
      const int64_t k = std::min<int64_t>(512, n - i);
      parts.push_back(enc.forward(eb.ids.narrow(0, i, k).contiguous(), eb.mask.narrow(0, i, k).contiguous())
                          .tokens.data().contiguous());
    }
    tokens = t2m::concat(parts, 0);
  }
  const auto data = t2b::make_program_dataset(std::move(programs), caps, tokens, eb.mask, a.window);

  a.gen.latent = vbb->config().latent;
  a.gen.adapter.tok_dim = enc.config().dim;
  a.gen.adapter.max_len = enc.config().max_len;
  t2m::Generator g(a.train.seed);
  auto model = std::make_shared<t2b::FlowGenerator>(a.gen, g);
  std::fprintf(stderr, "train gen: generator %lld parameters, window %lld programs x %lld latents\n",
               (long long)model->num_parameters(), (long long)a.window, (long long)vbb->config().compression());
  const t2b::GenTrainPaths p{out + "/train_state.t2mckpt", out + "/log.jsonl", out + "/loss.svg"};
  const auto r = t2b::train_generator(*model, data, a.train, p, a.resume);

  t2b::GenBundle b;
  b.model = model;
  b.program_mean = data.mean;
  b.program_std = data.std;
  b.compression = vbb->config().compression();
  b.window = a.window;
  b.objective = a.train.objective;
  b.schedule = a.train.schedule;
  b.train = {{"command", cmdline}, {"steps", r.steps}, {"config", a.train.to_json()},
             {"data", "Bandai-Namco-Research-Motiondataset (CC BY-NC 4.0), train split"},
             {"text_encoder", text_p}, {"vbb", vbb_p}, {"bfm", bfm_p}, {"bfm_checksum", sum},
             {"bfm_latent_checksum", t2m::bfm::latent_space_checksum(*agent)}};
  const std::string ckpt = out + "/gen_small.t2mckpt";
  t2b::save_gen_checkpoint(b, ckpt);
  const json summary = {{"checkpoint", ckpt}, {"steps", r.steps}, {"seconds_this_run", r.seconds},
                        {"final_loss_smoothed", r.final_loss}, {"parameters", model->num_parameters()},
                        {"clips", ls.clips()}, {"captions", texts.size()}, {"train", b.train},
                        {"generator", t2b::flow_config_to_json(a.gen)}};
  t2m::nn::write_file_atomic(out + "/summary.json", summary.dump(1) + "\n");
  if (!a.ship.empty()) t2m::cli::copy_file_atomic(ckpt, a.ship);
  std::printf("gen (%s): %lld steps, loss %.4f (smoothed, train split); checkpoint %s%s%s\n  log %s, plot %s\n",
              a.train.objective.c_str(), (long long)r.steps, r.final_loss, ckpt.c_str(), a.ship.empty() ? "" : ", shipped to ", a.ship.c_str(),
              p.log.c_str(), p.svg.c_str());
}

void add_train_gen(CLI::App& app) {
  auto* grp = t2m::cli::command_group(app, "train", "train a model");
  auto a = std::make_shared<GenArgs>();
  // CPU default: a reduced fm-small (width 128, depth 4) that trains in ~15 min on 2 cores.
  a->gen = t2b::FlowGeneratorConfig::small();
  a->gen.width = 128, a->gen.ctx_dim = 128;
  a->gen.adapter.width = 128, a->gen.adapter.ctx_dim = 128;
  auto* c = grp->add_subcommand("gen", "train the Text2BFM flow generator on VBB programs (Eq 15, train split)");
  c->add_option("--checkpoints", a->ckpt_dir, "directory of the frozen text encoder, VBB and BFM")
      ->capture_default_str();
  c->add_option("--text", a->text, "text encoder checkpoint (default CHECKPOINTS/text_encoder.t2mckpt)");
  c->add_option("--vbb", a->vbb, "VBB checkpoint (default CHECKPOINTS/vbb_small.t2mckpt)");
  c->add_option("--bfm", a->bfm, "BFM policy checkpoint (default CHECKPOINTS/bfm_stand.t2mckpt)");
  c->add_option("--latents", a->latents, "latent cache (default ~/.cache/t2m/latents/train.t2mckpt)");
  c->add_option("--manifest", a->manifest, "data manifest (default ~/.cache/t2m/bandai/manifest.json)");
  c->add_option("--out", a->out, "output directory (default ~/.cache/t2m/gen)");
  c->add_option("--ship", a->ship, "also copy the checkpoint here (models/checkpoints/gen_small.t2mckpt)");
  c->add_flag("--resume", a->resume, "continue from OUT/train_state.t2mckpt");
  c->add_option("--steps", a->train.steps, "optimizer steps")->capture_default_str();
  c->add_option("--batch", a->train.batch, "windows per batch")->capture_default_str();
  c->add_option("--lr", a->train.lr, "peak learning rate (warm-up + cosine to lr/10)")->capture_default_str();
  c->add_option("--warmup", a->train.warmup, "warm-up steps")->capture_default_str();
  c->add_option("--seed", a->train.seed, "seed (init, batches, noise, dropout)")->capture_default_str();
  c->add_option("--save-every", a->train.save_every, "steps between resumable checkpoints")->capture_default_str();
  c->add_option("--stop-at", a->train.stop_at, "stop (resumably) after this many steps in total");
  c->add_option("--objective", a->train.objective, "flow (Eq 15) | diffusion (v-prediction, Table 5's variant)")
      ->capture_default_str();
  c->add_option("--schedule", a->train.schedule, "diffusion noise schedule: cosine | linear")->capture_default_str();
  c->add_option("--ema", a->train.ema, "EMA decay of the weights (0 = off); the checkpoint then holds the averaged "
                                       "weights")
      ->capture_default_str();
  c->add_option("--window", a->window, "program frames per training window")->capture_default_str();
  c->add_option("--paraphrases", a->paraphrases, "captions per clip")->capture_default_str();
  c->add_option("--width", a->gen.width, "generator width")->capture_default_str();
  c->add_option("--depth", a->gen.depth, "DiT blocks")->capture_default_str();
  c->add_option("--heads", a->gen.heads, "attention heads")->capture_default_str();
  c->add_option("--ctx-dim", a->gen.ctx_dim, "text context width (adapter output)")->capture_default_str();
  c->add_option("--threads", a->threads, "threads (0 = default); results are deterministic per count");
  c->callback([a, c] {
    GenArgs x = *a;
    x.gen.adapter.ctx_dim = x.gen.ctx_dim;
    x.gen.adapter.width = x.gen.ctx_dim;
    run(x, "t2m train gen " + c->config_to_str(false, false));
  });
}

}  // namespace

T2M_COMMAND(add_train_gen);

// trainer.cpp — seed data, batches, latent mix, online collection and resumable state of BFM training
// (see trainer.h).
#include "models/bfm/trainer.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "autograd/no_grad.h"
#include "models/bfm/planner_demos.h"
#include "nn/checkpoint.h"
#include "tensor/ops.h"

namespace t2m::bfm {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {
// Rows of the batch parts one after the other (the single part itself when there is one).
Tensor concat_rows(const std::vector<Tensor>& parts) { return parts.size() == 1 ? parts[0] : concat(parts, 0); }

// Distinct Philox keys for the run's streams.
uint64_t stream_seed(uint64_t seed, uint64_t k) {
  uint64_t x = seed * 0x9E3779B97F4A7C15ull + k * 0xBF58476D1CE4E5B9ull + 0x94D049BB133111EBull;
  x ^= x >> 31;
  return x;
}
}  // namespace

json BfmTrainConfig::to_json() const {
  json j = {{"fb", fb.to_json()},
          {"seed", seed},
          {"ref_clips", ref_clips},
          {"static_holds", static_holds},
          {"seed_transitions", seed_transitions},
          {"seed_noise", seed_noise},
          {"seed_expert", seed_expert},
          {"envs", envs},
          {"max_episode_steps", max_episode_steps},
          {"total_updates", total_updates},
          {"offline_updates", offline_updates},
          {"collect_every", collect_every},
          {"collect_transitions", collect_transitions},
          {"online_capacity", online_capacity},
          {"online_fraction", online_fraction},
          {"online_noise", online_noise},
          {"batch", batch},
          {"bc_batch", bc_batch},
          {"dagger", dagger},
          {"z_track", z_track},
          {"z_goal", z_goal}};
  if (!demo_dir.empty()) j["demo_dir"] = demo_dir, j["demo_fraction"] = demo_fraction;  // older runs: no keys
  return j;
}

BfmTrainConfig BfmTrainConfig::from_json(const json& j) {
  BfmTrainConfig c;
  if (!j.is_object()) throw Error("bfm trainer: config is not a JSON object");
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string& k = it.key();
    const json& v = it.value();
    try {
      if (k == "fb") c.fb = FbConfig::from_json(v);
      else if (k == "seed") c.seed = v.get<uint64_t>();
      else if (k == "ref_clips") c.ref_clips = v.get<int>();
      else if (k == "static_holds") c.static_holds = v.get<int>();
      else if (k == "seed_transitions") c.seed_transitions = v.get<int64_t>();
      else if (k == "seed_noise") c.seed_noise = v.get<double>();
      else if (k == "seed_expert") c.seed_expert = v.get<std::string>();
      else if (k == "envs") c.envs = v.get<int>();
      else if (k == "max_episode_steps") c.max_episode_steps = v.get<int>();
      else if (k == "total_updates") c.total_updates = v.get<int64_t>();
      else if (k == "offline_updates") c.offline_updates = v.get<int64_t>();
      else if (k == "collect_every") c.collect_every = v.get<int64_t>();
      else if (k == "collect_transitions") c.collect_transitions = v.get<int64_t>();
      else if (k == "online_capacity") c.online_capacity = v.get<int64_t>();
      else if (k == "online_fraction") c.online_fraction = v.get<double>();
      else if (k == "online_noise") c.online_noise = v.get<double>();
      else if (k == "batch") c.batch = v.get<int>();
      else if (k == "bc_batch") c.bc_batch = v.get<int>();
      else if (k == "dagger") c.dagger = v.get<bool>();
      else if (k == "z_track") c.z_track = v.get<double>();
      else if (k == "z_goal") c.z_goal = v.get<double>();
      else if (k == "demo_dir") c.demo_dir = v.get<std::string>();
      else if (k == "demo_fraction") c.demo_fraction = v.get<double>();
      else throw Error("bfm trainer: unknown config key '" + k + "'");
    } catch (const json::exception& e) {
      throw Error("bfm trainer: config key '" + k + "': " + e.what());
    }
  }
  return c;
}

void BfmTrainConfig::validate() const {
  fb.validate();
  const auto bad = [](const std::string& what) { throw Error("bfm trainer: " + what); };
  if (seed_transitions < 1) bad("seed_transitions must be >= 1");
  if (envs < 1 || max_episode_steps < 1) bad("envs and max_episode_steps must be >= 1");
  if (batch < 2 || bc_batch < 0) bad("batch must be >= 2 and bc_batch >= 0");
  if (total_updates < 0 || offline_updates < 0 || collect_every < 1 || collect_transitions < 1 || online_capacity < 1)
    bad("update / collection counts out of range");
  if (!(online_fraction >= 0 && online_fraction <= 1)) bad("online_fraction must be in [0, 1]");
  if (!(seed_noise >= 0) || !(online_noise >= 0)) bad("noise must be >= 0");
  if (!(z_track >= 0 && z_goal >= 0 && z_track + z_goal <= 1)) bad("z_track, z_goal in [0, 1] with sum <= 1");
  if (ref_clips < 0) bad("ref_clips must be >= 0");
  if (static_holds < 0) bad("static_holds must be >= 0");
  if (!(demo_fraction >= 0 && demo_fraction <= 1)) bad("demo_fraction must be in [0, 1]");
  try {  // the tracker names are set_expert's (models/bfm/collect)
    CollectOptions probe;
    set_expert(probe, seed_expert);
  } catch (const Error& e) {
    bad(std::string("seed_expert: ") + e.what());
  }
}

EncodeFn agent_encoder(FbAgent& agent) {
  return [&agent](const Tensor& s) { return agent.embed_backward(s); };
}
PolicyFn agent_policy(FbAgent& agent) {
  return [&agent](const Tensor& obs, const Tensor& z, float noise_std, Generator& gen, Tensor& action) {
    agent.act(obs, z, noise_std, gen, action);
  };
}

BfmTrainer::BfmTrainer(const BfmTrainConfig& cfg, std::shared_ptr<const sim::Humanoid> h, const RefMotions& refs,
                       std::string dir)
    : cfg_(cfg), h_(std::move(h)), refs_(refs), dir_(std::move(dir)), gen_data_(stream_seed(cfg.seed, 1)),
      gen_z_(stream_seed(cfg.seed, 2)), gen_agent_(stream_seed(cfg.seed, 3)), gen_collect_(stream_seed(cfg.seed, 4)),
      gen_seed_(stream_seed(cfg.seed, 5)) {
  cfg_.validate();
  if (refs.obs_dim != cfg_.fb.obs_dim || h_->model()->nu != cfg_.fb.action_dim)
    throw Error("bfm trainer: obs/action dims of the humanoid (" + std::to_string(refs.obs_dim) + ", " +
                std::to_string(h_->model()->nu) + ") differ from the config's (" + std::to_string(cfg_.fb.obs_dim) +
                ", " + std::to_string(cfg_.fb.action_dim) + ")");
  fs::create_directories(dir_);
  agent_ = std::make_unique<FbAgent>(cfg_.fb, cfg_.seed);
  json run = cfg_.to_json();
  run.erase("fb");
  run.erase("total_updates");  // a run may be extended
  ts_ = std::make_unique<nn::TrainState>(agent_->train_state(run));
  ts_->generator("data", gen_data_).generator("z", gen_z_).generator("agent", gen_agent_);
  ts_->generator("collect", gen_collect_);
  online_ = std::make_unique<ReplayBuffer>(cfg_.online_capacity, cfg_.fb.obs_dim, cfg_.fb.action_dim, cfg_.dagger);
  CollectOptions co;
  set_expert(co, cfg_.seed_expert);
  co.envs = cfg_.envs;
  co.max_episode_steps = cfg_.max_episode_steps;
  co.window = cfg_.fb.track_window;
  collector_ = std::make_unique<TrackingCollector>(h_, refs_, co);
  if (fs::exists(state_path())) {
    ts_->load(state_path());
    resumed_ = true;
    const std::string of = ts_->user.value("online_file", std::string());
    const int64_t added = ts_->user.value("online_added", (int64_t)0);
    if (!of.empty()) {
      if (!fs::exists(dir_ + "/" + of)) throw Error("bfm trainer: online buffer " + dir_ + "/" + of + " is missing");
      ReplayBuffer b = ReplayBuffer::load(dir_ + "/" + of);
      if (b.capacity() != cfg_.online_capacity || b.added() != added || b.obs_dim() != cfg_.fb.obs_dim ||
          b.has_expert_labels() != cfg_.dagger)
        throw Error("bfm trainer: online buffer " + of + " does not match the state (rows added " +
                    std::to_string(b.added()) + " vs " + std::to_string(added) + ")");
      *online_ = std::move(b);
    } else if (added != 0) {
      throw Error("bfm trainer: the state records an online buffer but names no file");
    }
  }
}

BfmTrainer::~BfmTrainer() = default;

void BfmTrainer::prepare_seed(const std::function<void(int64_t, int64_t)>& on_progress) {
  const json id = {{"seed", cfg_.seed},   {"ref_clips", cfg_.ref_clips}, {"transitions", cfg_.seed_transitions},
                   {"noise", cfg_.seed_noise}, {"expert", cfg_.seed_expert}, {"labels", cfg_.dagger}, {"envs", cfg_.envs}, {"max_episode_steps", cfg_.max_episode_steps},
                   {"ref_names_frames", refs_.total_frames()}};
  const std::string id_path = dir_ + "/seed_buffer.json";
  if (fs::exists(seed_path()) && fs::exists(id_path)) {
    json have;
    try {
      std::ifstream f(id_path);
      f >> have;
    } catch (const std::exception&) {
      have = nullptr;
    }
    if (have == id) {
      seed_ = std::make_unique<ReplayBuffer>(ReplayBuffer::load(seed_path()));
      if (seed_->size() != cfg_.seed_transitions || seed_->obs_dim() != cfg_.fb.obs_dim ||
          seed_->action_dim() != cfg_.fb.action_dim || seed_->has_expert_labels() != cfg_.dagger)
        throw Error("bfm trainer: seed buffer " + seed_path() + " does not match its description");
      prepare_demos();
      return;
    }
  }
  if (resumed_) throw Error("bfm trainer: resuming, but the seed buffer " + seed_path() +
                            " is missing or was made with another config");
  seed_ = std::make_unique<ReplayBuffer>(cfg_.seed_transitions, cfg_.fb.obs_dim, cfg_.fb.action_dim, cfg_.dagger);
  CollectOptions co = collector_->options();
  co.action_noise = cfg_.seed_noise;  // the expert is already the run's (collector_'s options)
  TrackingCollector expert(h_, refs_, co);
  Generator g(gen_seed_.seed());  // always from the start: the seed buffer is a pure function of the config
  const int64_t chunk = 8192;
  for (int64_t done = 0; done < cfg_.seed_transitions;) {
    const int64_t n = std::min(chunk, cfg_.seed_transitions - done);
    expert.collect_expert(n, g, *seed_);
    done += n;
    if (on_progress) on_progress(done, cfg_.seed_transitions);
  }
  seed_->save(seed_path());
  nn::write_file_atomic(id_path, id.dump(1) + "\n");
  prepare_demos();
}

void BfmTrainer::prepare_demos() {
  if (cfg_.demo_dir.empty()) return;
  const PlannerDemos d = load_planner_demos(cfg_.demo_dir, refs_);
  if (resumed_ && ts_->user.value("demo_rows", (int64_t)-1) != d.rows)
    throw Error("bfm trainer: resuming, but " + cfg_.demo_dir + " gives " + std::to_string(d.rows) +
                " demonstration rows, the state was trained on " +
                std::to_string(ts_->user.value("demo_rows", (int64_t)-1)));
  demo_ = std::make_unique<ReplayBuffer>(d.rows, cfg_.fb.obs_dim, cfg_.fb.action_dim, /*with_expert_labels=*/true);
  replay_planner_demos(h_, refs_, d, *demo_);
  owned_ = planner_owned_clips(refs_, d);
  any_free_ = std::find(owned_.begin(), owned_.end(), 0) != owned_.end();
  ts_->user["demo_rows"] = d.rows;
  demo_files_ = (int)d.files.size(), demo_failed_ = d.failed_runs, demo_skipped_ = (int)d.skipped.size();
}

BfmStepStats BfmTrainer::train_step() {
  if (!seed_) throw Error("bfm trainer: prepare_seed() before train_step()");
  BfmStepStats out;
  const int64_t step = ts_->step;
  const int L = cfg_.fb.track_window;
  const EncodeFn enc = agent_encoder(*agent_);
  if (step >= cfg_.offline_updates && (step - cfg_.offline_updates) % cfg_.collect_every == 0) {
    out.collect = collector_->collect_policy(cfg_.collect_transitions, enc, agent_policy(*agent_), gen_collect_,
                                             *online_);
    out.collected = true;
  }
  // FB batch: seed rows then online rows.
  const int64_t B = cfg_.batch;
  const int64_t n_on = online_->size() >= B ? std::llround(B * cfg_.online_fraction) : 0;
  const int64_t n_seed_all = B - n_on;
  const int64_t n_demo = demo_ ? std::llround(n_seed_all * cfg_.demo_fraction) : 0;
  const int64_t n_seed = n_seed_all - n_demo;
  const auto ensure = [&](ReplayBatch& b, int64_t n) {
    if (!b.obs.defined() || b.obs.size(0) != n) b = make_replay_batch(n, cfg_.fb.obs_dim, cfg_.fb.action_dim);
  };
  FbBatch fb;
  std::vector<const ReplayBatch*> parts;  // seed, demo, online rows
  if (n_seed > 0) {
    ensure(seed_batch_, n_seed);
    seed_->sample_into(n_seed, gen_data_, seed_batch_);
    parts.push_back(&seed_batch_);
  }
  if (n_demo > 0) {
    ensure(demo_batch_, n_demo);
    demo_->sample_into(n_demo, gen_data_, demo_batch_);
    parts.push_back(&demo_batch_);
  }
  if (n_on > 0) {
    ensure(online_batch_, n_on);
    online_->sample_into(n_on, gen_data_, online_batch_);
    parts.push_back(&online_batch_);
  }
  const auto join = [&](Tensor ReplayBatch::*field) {
    std::vector<Tensor> ts;
    for (const ReplayBatch* p : parts) ts.push_back(p->*field);
    return concat_rows(ts);
  };
  fb.obs = join(&ReplayBatch::obs), fb.action = join(&ReplayBatch::action);
  fb.next_obs = join(&ReplayBatch::next_obs), fb.not_done = join(&ReplayBatch::not_done);
  {
    ag::NoGradGuard ng;
    fb.z = sample_training_z(B, ZMix{cfg_.z_track, cfg_.z_goal}, refs_, L, fb.next_obs, enc, cfg_.fb.z_dim, gen_z_);
    if (cfg_.bc_batch > 0) {
      // BC rows: seed rows, plus (DAgger) the policy's own online states relabelled by the expert.
      // With demos: a share of the seed rows from the planner; expert labels only on clips it does not own.
      const int64_t n_bc_on = cfg_.dagger && online_->size() >= cfg_.bc_batch ? cfg_.bc_batch / 2 : 0;
      const int64_t n_bc_demo = demo_ ? std::llround((cfg_.bc_batch - n_bc_on) * cfg_.demo_fraction) : 0;
      const int64_t n_bc_seed = cfg_.bc_batch - n_bc_on - n_bc_demo;
      std::vector<const ReplayBatch*> bc_parts;  // seed, demo, online rows
      // Expert rows with demos: on clips the planner does not own; where none is found (every clip owned, or an
      // early online buffer without such rows) the planner's rows stand in.
      const auto draw = [&](const ReplayBuffer& b, int64_t n, bool expert_rows, ReplayBatch& out) {
        ensure(out, n);
        if (demo_ && expert_rows) {
          const auto free = [&](int64_t row) { return !owned_[(size_t)b.clip_at(row)]; };
          if (!any_free_ || !b.sample_where_into(n, gen_data_, free, out)) demo_->sample_into(n, gen_data_, out);
        } else {
          b.sample_into(n, gen_data_, out);
        }
        bc_parts.push_back(&out);
      };
      if (n_bc_seed > 0) draw(*seed_, n_bc_seed, true, bc_batch_);
      if (n_bc_demo > 0) draw(*demo_, n_bc_demo, false, bc_demo_batch_);
      if (n_bc_on > 0) draw(*online_, n_bc_on, true, bc_online_batch_);
      // Targets: the expert's (or planner's) labels with dagger, else the seed actions (no demos, no online rows).
      const bool labels = cfg_.dagger || demo_;
      std::vector<Tensor> obs, act, clips, frames;
      for (const ReplayBatch* p : bc_parts) {
        obs.push_back(p->obs), clips.push_back(p->clip), frames.push_back(p->frame);
        act.push_back(labels && p->expert_action.defined() ? p->expert_action : p->action);
      }
      fb.bc_obs = concat_rows(obs), fb.bc_action = concat_rows(act);
      const Tensor clip = concat_rows(clips).contiguous(), frame = concat_rows(frames).contiguous();
      fb.bc_z = window_latents(refs_, clip.data<int64_t>(), frame.data<int64_t>(), cfg_.bc_batch, L, enc);
    }
  }
  out.fb = agent_->update(fb, gen_agent_);
  ++ts_->step;
  return out;
}

void BfmTrainer::save() {
  const std::string name = online_->size() > 0 ? "online-" + std::to_string(ts_->step) + ".t2mckpt" : "";
  if (!name.empty()) online_->save(dir_ + "/" + name);
  ts_->user["online_file"] = name;
  ts_->user["online_added"] = online_->added();
  ts_->save(state_path());
  for (const auto& e : fs::directory_iterator(dir_)) {  // older online buffers
    const std::string f = e.path().filename().string();
    if (f.rfind("online-", 0) == 0 && f != name) fs::remove(e.path());
  }
}

}  // namespace t2m::bfm

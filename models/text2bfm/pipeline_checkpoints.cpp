// pipeline_checkpoints.cpp — generator and VBB checkpoint files (see the header for the formats).
#include "models/text2bfm/pipeline_checkpoints.h"

#include <cmath>
#include <set>

#include "nn/checkpoint.h"

namespace t2m::text2bfm {

using json = nlohmann::json;

namespace {

template <typename T>
void read_field(const json& j, const char* key, T& v, std::set<std::string>& seen, const std::string& who) {
  seen.insert(key);
  if (!j.contains(key)) return;
  try {
    v = j.at(key).get<T>();
  } catch (const std::exception& e) {
    throw Error(who + ": field '" + key + "' is malformed: " + e.what());
  }
}

void reject_unknown(const json& j, const std::set<std::string>& seen, const std::string& who) {
  for (auto it = j.begin(); it != j.end(); ++it)
    if (!seen.count(it.key())) throw Error(who + ": unknown config field '" + it.key() + "'");
}

}  // namespace

json flow_config_to_json(const FlowGeneratorConfig& c) {
  const auto& a = c.adapter;
  return {{"latent", c.latent}, {"width", c.width}, {"depth", c.depth}, {"heads", c.heads}, {"ctx_dim", c.ctx_dim},
          {"mlp_ratio", c.mlp_ratio}, {"freq_dim", c.freq_dim}, {"cond_dropout", c.cond_dropout},
          {"guidance", c.guidance},
          {"adapter", {{"tok_dim", a.tok_dim}, {"width", a.width}, {"depth", a.depth}, {"heads", a.heads},
                       {"ctx_dim", a.ctx_dim}, {"max_len", a.max_len}}}};
}

FlowGeneratorConfig flow_config_from_json(const json& j) {
  const std::string who = "generator config";
  if (!j.is_object()) throw Error(who + ": not a JSON object");
  FlowGeneratorConfig c;
  std::set<std::string> seen;
  read_field(j, "latent", c.latent, seen, who);
  read_field(j, "width", c.width, seen, who);
  read_field(j, "depth", c.depth, seen, who);
  read_field(j, "heads", c.heads, seen, who);
  read_field(j, "ctx_dim", c.ctx_dim, seen, who);
  read_field(j, "mlp_ratio", c.mlp_ratio, seen, who);
  read_field(j, "freq_dim", c.freq_dim, seen, who);
  read_field(j, "cond_dropout", c.cond_dropout, seen, who);
  read_field(j, "guidance", c.guidance, seen, who);
  seen.insert("adapter");
  reject_unknown(j, seen, who);
  if (j.contains("adapter")) {
    const json& a = j.at("adapter");
    if (!a.is_object()) throw Error(who + ": 'adapter' is not an object");
    std::set<std::string> s2;
    read_field(a, "tok_dim", c.adapter.tok_dim, s2, who + " adapter");
    read_field(a, "width", c.adapter.width, s2, who + " adapter");
    read_field(a, "depth", c.adapter.depth, s2, who + " adapter");
    read_field(a, "heads", c.adapter.heads, s2, who + " adapter");
    read_field(a, "ctx_dim", c.adapter.ctx_dim, s2, who + " adapter");
    read_field(a, "max_len", c.adapter.max_len, s2, who + " adapter");
    reject_unknown(a, s2, who + " adapter");
  }
  return c;
}

PipelinePaths PipelinePaths::in_dir(const std::string& dir) {
  return {dir + "/text_encoder.t2mckpt", dir + "/vbb_small.t2mckpt", dir + "/gen_small.t2mckpt",
          dir + "/bfm_stand.t2mckpt"};
}

void save_gen_checkpoint(const GenBundle& b, const std::string& path) {
  if (!b.model) throw Error("gen checkpoint " + path + ": no model");
  const int64_t d = b.model->config().latent;
  if (!b.program_mean.defined() || b.program_mean.numel() != d || !b.program_std.defined() ||
      b.program_std.numel() != d)
    throw Error("gen checkpoint " + path + ": program stats must have " + std::to_string(d) + " entries");
  nn::Checkpoint ck;
  ck.meta = {{"format", "t2m-gen-1"},
             {"config", flow_config_to_json(b.model->config())},
             {"program", {{"compression", b.compression}, {"latent", d}, {"window", b.window}}},
             {"train", b.train}};
  if (b.objective != "flow" && b.objective != "diffusion")
    throw Error("gen checkpoint " + path + ": objective must be flow or diffusion, got '" + b.objective + "'");
  if (b.objective == "diffusion")
    ck.meta["objective"] = {{"kind", "diffusion"}, {"prediction", "v"}, {"schedule", b.schedule}};
  b.model->save_to(ck, "model.");
  ck.put("program_mean", b.program_mean.to(DType::f32).reshape({d}));
  ck.put("program_std", b.program_std.to(DType::f32).reshape({d}));
  ck.save(path);
}

GenBundle load_gen_checkpoint(const std::string& path) {
  const nn::Checkpoint ck = nn::Checkpoint::load(path);
  const std::string who = "gen checkpoint " + path;
  if (ck.meta.value("format", std::string()) != "t2m-gen-1")
    throw Error(who + ": not a generator checkpoint (format '" + ck.meta.value("format", std::string()) +
                "', expected 't2m-gen-1')");
  GenBundle b;
  FlowGeneratorConfig cfg;
  try {
    cfg = flow_config_from_json(ck.meta.at("config"));
    const json& p = ck.meta.at("program");
    b.compression = p.at("compression").get<int64_t>();
    b.window = p.at("window").get<int64_t>();
    b.train = ck.meta.value("train", json::object());
    if (ck.meta.contains("objective")) {
      const json& o = ck.meta.at("objective");
      b.objective = o.at("kind").get<std::string>();
      if (b.objective != "flow" && b.objective != "diffusion")
        throw Error("unknown objective '" + b.objective + "' (flow | diffusion)");
      if (o.value("prediction", std::string("v")) != "v") throw Error("only v-prediction diffusion is supported");
      b.schedule = o.value("schedule", std::string("cosine"));
      if (b.schedule != "cosine" && b.schedule != "linear")
        throw Error("unknown noise schedule '" + b.schedule + "' (cosine | linear)");
    }
  } catch (const Error& e) {
    throw Error(who + ": " + e.what());
  } catch (const std::exception& e) {
    throw Error(who + ": malformed meta: " + e.what());
  }
  if (b.compression < 1) throw Error(who + ": compression must be >= 1");
  Generator g(0);
  b.model = std::make_shared<FlowGenerator>(cfg, g);
  b.model->load_from(ck, "model.");
  b.model->eval();
  b.program_mean = ck.expect("program_mean", {cfg.latent}, DType::f32).clone();
  b.program_std = ck.expect("program_std", {cfg.latent}, DType::f32).clone();
  for (float s : b.program_std.to_vector<float>())
    if (!(s > 0) || !std::isfinite(s)) throw Error(who + ": program_std has an entry <= 0 or non-finite");
  return b;
}

}  // namespace t2m::text2bfm

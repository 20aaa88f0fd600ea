// replay_buffer.cpp — ring storage, uniform sampling and the checkpoint file of the replay buffer.
#include "models/bfm/replay_buffer.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "nn/checkpoint.h"

namespace t2m::bfm {

namespace {
std::string num(int64_t v) { return std::to_string(v); }
}  // namespace

ReplayBatch make_replay_batch(int64_t n, int obs_dim, int action_dim) {
  ReplayBatch b;
  b.obs = Tensor::empty({n, obs_dim});
  b.action = Tensor::empty({n, action_dim});
  b.next_obs = Tensor::empty({n, obs_dim});
  b.not_done = Tensor::empty({n, 1});
  b.clip = Tensor::empty({n}, DType::i64);
  b.frame = Tensor::empty({n}, DType::i64);
  return b;
}

ReplayBuffer::ReplayBuffer(int64_t capacity, int obs_dim, int action_dim, bool with_expert_labels)
    : capacity_(capacity), obs_dim_(obs_dim), action_dim_(action_dim), labels_(with_expert_labels) {
  if (capacity < 1 || obs_dim < 1 || action_dim < 1)
    throw Error("replay buffer: capacity " + num(capacity) + ", obs_dim " + num(obs_dim) + ", action_dim " +
                num(action_dim) + " (each must be >= 1)");
  obs_ = Tensor::empty({capacity, obs_dim});
  action_ = Tensor::empty({capacity, action_dim});
  next_obs_ = Tensor::empty({capacity, obs_dim});
  not_done_ = Tensor::empty({capacity});
  clip_ = Tensor::empty({capacity}, DType::i64);
  frame_ = Tensor::empty({capacity}, DType::i64);
  if (labels_) expert_action_ = Tensor::empty({capacity, action_dim});
}

void ReplayBuffer::clear() { size_ = cursor_ = added_ = 0; }

void ReplayBuffer::add(const float* obs, const float* action, const float* next_obs, float not_done, int64_t clip,
                       int64_t frame, const float* expert_action) {
  if (labels_ != (expert_action != nullptr))
    throw Error(labels_ ? "replay buffer: add: this buffer needs an expert action per row"
                        : "replay buffer: add: an expert action given to a buffer without expert labels");
  if (labels_)
    for (int i = 0; i < action_dim_; ++i)
      if (!std::isfinite(expert_action[i]))
        throw Error("replay buffer: add: non-finite expert action value at index " + num(i));
  for (int i = 0; i < obs_dim_; ++i)
    if (!std::isfinite(obs[i]) || !std::isfinite(next_obs[i]))
      throw Error("replay buffer: add: non-finite observation value at index " + num(i));
  for (int i = 0; i < action_dim_; ++i)
    if (!std::isfinite(action[i])) throw Error("replay buffer: add: non-finite action value at index " + num(i));
  if (not_done != 0.0f && not_done != 1.0f)
    throw Error("replay buffer: add: not_done must be 0 or 1, got " + std::to_string(not_done));
  const int64_t r = cursor_;
  std::memcpy(obs_.data<float>() + r * obs_dim_, obs, sizeof(float) * obs_dim_);
  std::memcpy(action_.data<float>() + r * action_dim_, action, sizeof(float) * action_dim_);
  std::memcpy(next_obs_.data<float>() + r * obs_dim_, next_obs, sizeof(float) * obs_dim_);
  not_done_.data<float>()[r] = not_done;
  clip_.data<int64_t>()[r] = clip;
  frame_.data<int64_t>()[r] = frame;
  if (labels_) std::memcpy(expert_action_.data<float>() + r * action_dim_, expert_action, sizeof(float) * action_dim_);
  cursor_ = (cursor_ + 1) % capacity_;
  size_ = std::min(size_ + 1, capacity_);
  ++added_;
}

void ReplayBuffer::check_row(int64_t i) const {
  if (i < 0 || i >= size_) throw Error("replay buffer: row " + num(i) + " out of range [0, " + num(size_) + ")");
}
const float* ReplayBuffer::obs_row(int64_t i) const { check_row(i); return obs_.data<float>() + i * obs_dim_; }
const float* ReplayBuffer::action_row(int64_t i) const {
  check_row(i);
  return action_.data<float>() + i * action_dim_;
}
const float* ReplayBuffer::next_obs_row(int64_t i) const {
  check_row(i);
  return next_obs_.data<float>() + i * obs_dim_;
}
float ReplayBuffer::not_done_at(int64_t i) const { check_row(i); return not_done_.data<float>()[i]; }
int64_t ReplayBuffer::clip_at(int64_t i) const { check_row(i); return clip_.data<int64_t>()[i]; }
int64_t ReplayBuffer::frame_at(int64_t i) const { check_row(i); return frame_.data<int64_t>()[i]; }
const float* ReplayBuffer::expert_action_row(int64_t i) const {
  if (!labels_) throw Error("replay buffer: this buffer has no expert labels");
  check_row(i);
  return expert_action_.data<float>() + i * action_dim_;
}

void ReplayBuffer::gather(const int64_t* index, int64_t n, ReplayBatch& out) const {
  const auto need = [&](const Tensor& t, const Shape& s, DType d, const char* name) {
    if (!t.defined() || t.shape() != s || t.dtype() != d || !t.is_contiguous())
      throw Error(std::string("replay buffer: batch tensor ") + name + " must be a contiguous " + dtype_name(d) + " " +
                  shape_str(s) + ", got " + (t.defined() ? shape_str(t.shape()) : std::string("undefined")));
  };
  need(out.obs, {n, obs_dim_}, DType::f32, "obs");
  need(out.action, {n, action_dim_}, DType::f32, "action");
  need(out.next_obs, {n, obs_dim_}, DType::f32, "next_obs");
  need(out.not_done, {n, 1}, DType::f32, "not_done");
  need(out.clip, {n}, DType::i64, "clip");
  need(out.frame, {n}, DType::i64, "frame");
  for (int64_t k = 0; k < n; ++k) check_row(index[k]);
  if (labels_ && (!out.expert_action.defined() || out.expert_action.shape() != Shape{n, action_dim_} ||
                  out.expert_action.dtype() != DType::f32 || !out.expert_action.is_contiguous()))
    out.expert_action = Tensor::empty({n, action_dim_});
  float* oe = labels_ ? out.expert_action.data<float>() : nullptr;
  const float* e = labels_ ? expert_action_.data<float>() : nullptr;
  const float *o = obs_.data<float>(), *a = action_.data<float>(), *no = next_obs_.data<float>();
  float *oo = out.obs.data<float>(), *oa = out.action.data<float>(), *ono = out.next_obs.data<float>();
  float* od = out.not_done.data<float>();
  int64_t *oc = out.clip.data<int64_t>(), *of = out.frame.data<int64_t>();
#pragma omp parallel for schedule(static) if (n >= 512)
  for (int64_t k = 0; k < n; ++k) {
    const int64_t r = index[k];
    std::memcpy(oo + k * obs_dim_, o + r * obs_dim_, sizeof(float) * obs_dim_);
    std::memcpy(ono + k * obs_dim_, no + r * obs_dim_, sizeof(float) * obs_dim_);
    std::memcpy(oa + k * action_dim_, a + r * action_dim_, sizeof(float) * action_dim_);
    od[k] = not_done_.data<float>()[r];
    oc[k] = clip_.data<int64_t>()[r];
    of[k] = frame_.data<int64_t>()[r];
    if (oe) std::memcpy(oe + k * action_dim_, e + r * action_dim_, sizeof(float) * action_dim_);
  }
}

void ReplayBuffer::draw_rows(int64_t n, Generator& gen, int64_t* idx) const {
  if (n < 1) throw Error("replay buffer: sample of " + num(n) + " rows (must be >= 1)");
  if (size_ == 0) throw Error("replay buffer: sample from an empty buffer");
  // Two 64-bit draws per Philox counter; index = draw mod size (bias < size / 2^64).
  const uint64_t base = gen.advance((uint64_t)(n + 1) / 2);
  for (int64_t k = 0; k < n; k += 2) {
    uint32_t r[4];
    philox4x32(gen.seed(), base + (uint64_t)k / 2, r);
    idx[k] = (int64_t)((((uint64_t)r[1] << 32) | r[0]) % (uint64_t)size_);
    if (k + 1 < n) idx[k + 1] = (int64_t)((((uint64_t)r[3] << 32) | r[2]) % (uint64_t)size_);
  }
}

void ReplayBuffer::sample_into(int64_t n, Generator& gen, ReplayBatch& out) const {
  std::vector<int64_t> idx((size_t)std::max<int64_t>(n, 0));
  draw_rows(n, gen, idx.data());
  gather(idx.data(), n, out);
}

bool ReplayBuffer::sample_where_into(int64_t n, Generator& gen, const std::function<bool(int64_t)>& keep,
                                     ReplayBatch& out) const {
  std::vector<int64_t> idx((size_t)std::max<int64_t>(n, 0)), kept;
  kept.reserve(idx.size());
  for (int dry = 0; (int64_t)kept.size() < n;) {
    draw_rows(n, gen, idx.data());
    const size_t before = kept.size();
    for (int64_t k = 0; k < n && (int64_t)kept.size() < n; ++k)
      if (keep(idx[(size_t)k])) kept.push_back(idx[(size_t)k]);
    dry = kept.size() == before ? dry + 1 : 0;
    if (dry == 64) return false;
  }
  gather(kept.data(), n, out);
  return true;
}

ReplayBatch ReplayBuffer::sample(int64_t n, Generator& gen) const {
  ReplayBatch b = make_replay_batch(std::max<int64_t>(n, 1), obs_dim_, action_dim_);
  sample_into(n, gen, b);
  return b;
}

void ReplayBuffer::save(const std::string& path) const {
  nn::Checkpoint ck;
  ck.meta = {{"format", "t2m-replay-1"}, {"capacity", capacity_}, {"size", size_},     {"cursor", cursor_},
             {"obs_dim", obs_dim_},      {"action_dim", action_dim_}, {"added", added_},
             {"expert_labels", labels_}};
  ck.put("obs", obs_.narrow(0, 0, size_));
  ck.put("action", action_.narrow(0, 0, size_));
  ck.put("next_obs", next_obs_.narrow(0, 0, size_));
  ck.put("not_done", not_done_.narrow(0, 0, size_));
  ck.put("clip", clip_.narrow(0, 0, size_));
  ck.put("frame", frame_.narrow(0, 0, size_));
  if (labels_) ck.put("expert_action", expert_action_.narrow(0, 0, size_));
  ck.save(path);
}

ReplayBuffer ReplayBuffer::load(const std::string& path) {
  const nn::Checkpoint ck = nn::Checkpoint::load(path);
  const std::string where = "replay buffer " + path + ": ";
  const auto& m = ck.meta;
  if (!m.is_object() || m.value("format", std::string()) != "t2m-replay-1")
    throw Error(where + "not a replay buffer file (format tag is not t2m-replay-1)");
  int64_t capacity, size, cursor, added, od, ad;
  bool labels;
  try {
    labels = m.value("expert_labels", false);
    capacity = m.at("capacity").get<int64_t>();
    size = m.at("size").get<int64_t>();
    cursor = m.at("cursor").get<int64_t>();
    added = m.at("added").get<int64_t>();
    od = m.at("obs_dim").get<int64_t>();
    ad = m.at("action_dim").get<int64_t>();
  } catch (const std::exception& e) {
    throw Error(where + "bad metadata (" + e.what() + ")");
  }
  if (capacity < 1 || od < 1 || ad < 1 || od > (1 << 20) || ad > (1 << 20) || size < 0 || size > capacity ||
      cursor < 0 || cursor >= capacity || added < size || (size < capacity && cursor != size))
    throw Error(where + "inconsistent sizes (capacity " + num(capacity) + ", size " + num(size) + ", cursor " +
                num(cursor) + ", added " + num(added) + ", obs_dim " + num(od) + ", action_dim " + num(ad) + ")");
  const Tensor& obs = ck.expect("obs", {size, od}, DType::f32);
  const Tensor& act = ck.expect("action", {size, ad}, DType::f32);
  const Tensor& nobs = ck.expect("next_obs", {size, od}, DType::f32);
  const Tensor& nd = ck.expect("not_done", {size}, DType::f32);
  const Tensor& clip = ck.expect("clip", {size}, DType::i64);
  const Tensor& frame = ck.expect("frame", {size}, DType::i64);
  const auto finite = [&](const Tensor& t, const char* name) {
    const float* p = t.data<float>();
    for (int64_t i = 0; i < t.numel(); ++i)
      if (!std::isfinite(p[i])) throw Error(where + "non-finite value in " + name + " at element " + num(i));
  };
  finite(obs, "obs");
  finite(act, "action");
  finite(nobs, "next_obs");
  const Tensor* exp = labels ? &ck.expect("expert_action", {size, ad}, DType::f32) : nullptr;
  if (exp) finite(*exp, "expert_action");
  for (int64_t i = 0; i < size; ++i)
    if (nd.data<float>()[i] != 0.0f && nd.data<float>()[i] != 1.0f)
      throw Error(where + "not_done[" + num(i) + "] is not 0 or 1");
  ReplayBuffer b(capacity, (int)od, (int)ad, labels);
  if (exp) b.expert_action_.narrow(0, 0, size).copy_(*exp);
  b.obs_.narrow(0, 0, size).copy_(obs);
  b.action_.narrow(0, 0, size).copy_(act);
  b.next_obs_.narrow(0, 0, size).copy_(nobs);
  b.not_done_.narrow(0, 0, size).copy_(nd);
  b.clip_.narrow(0, 0, size).copy_(clip);
  b.frame_.narrow(0, 0, size).copy_(frame);
  b.size_ = size;
  b.cursor_ = cursor;
  b.added_ = added;
  return b;
}

}  // namespace t2m::bfm

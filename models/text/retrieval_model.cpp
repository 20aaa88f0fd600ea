// retrieval_model.cpp — the retrieval checkpoint format and batched, normalised caption / motion embedding.
#include "models/text/retrieval_model.h"

#include <algorithm>
#include <cmath>

#include "autograd/no_grad.h"
#include "nn/loss_contrastive.h"
#include "tensor/ops.h"

namespace t2m::text {

namespace {

constexpr const char* kFormat = "t2m-retrieval-1";

[[noreturn]] void fail(const std::string& src, const std::string& what) {
  throw Error("retrieval checkpoint " + src + ": " + what);
}

// Unit rows of a (B, E) embedding, written into rows [row0, row0 + B) of out (N, E) float32.
void store_normalised(const ag::Variable& e, Tensor& out, int64_t row0) {
  const Tensor n = nn::l2_normalize(e).data().to(DType::f32).contiguous();
  const int64_t B = n.size(0), E = n.size(1);
  std::copy(n.data<float>(), n.data<float>() + B * E, out.data<float>() + row0 * E);
}

}  // namespace

EncodedBatch encode_captions(const Tokenizer& tok, const std::vector<std::string>& texts, int64_t max_len) {
  EncodedBatch eb = tok.encode_batch(texts, max_len);
  int64_t L = 2;
  for (int64_t l : eb.length) L = std::max(L, l);
  if (L < eb.ids.size(1)) {
    eb.ids = eb.ids.slice(1, 0, L).contiguous();
    eb.mask = eb.mask.slice(1, 0, L).contiguous();
  }
  return eb;
}

Crop centre_crop(int64_t frames, int64_t window) {
  Crop c;
  c.len = std::min(frames, window);
  c.start = (frames - c.len) / 2;
  return c;
}

nn::Checkpoint make_retrieval_checkpoint(const RetrievalBundle& b) {
  if (!b.model) throw Error("retrieval checkpoint: no model");
  nn::Checkpoint ck;
  b.model->save_to(ck, "model.");
  const int64_t F = b.stats.dim();
  if (F != b.model->feature_dim())
    throw Error("retrieval checkpoint: stats have " + std::to_string(F) + " dims, the model " +
                std::to_string(b.model->feature_dim()));
  ck.put("feature_mean", Tensor::from_vector(b.stats.mean, {F}));
  ck.put("feature_std", Tensor::from_vector(b.stats.std, {F}));
  ck.meta["format"] = kFormat;
  ck.meta["kind"] = b.model->kind();
  ck.meta["config"] = b.model->config_json();
  ck.meta["window"] = b.window;
  ck.meta["train"] = b.train;
  b.tokenizer.save_to(ck, "tokenizer");
  return ck;
}

void save_retrieval_checkpoint(const RetrievalBundle& b, const std::string& path) {
  make_retrieval_checkpoint(b).save(path);
}

RetrievalCheckpoint read_retrieval_checkpoint(const std::string& path, const std::string& kind) {
  return read_retrieval_checkpoint(nn::Checkpoint::load(path), kind);
}

RetrievalCheckpoint read_retrieval_checkpoint(nn::Checkpoint ck, const std::string& kind) {
  const std::string src = ck.source();
  const auto& m = ck.meta;
  if (!m.is_object() || !m.contains("format") || m["format"] != kFormat)
    fail(src, std::string("not a retrieval checkpoint (meta.format is not \"") + kFormat + "\")");
  if (!m.contains("kind") || !m["kind"].is_string() || m["kind"].get<std::string>() != kind)
    fail(src,
         "holds a '" + (m.contains("kind") ? m["kind"].dump() : std::string("?")) + "' model, expected '" + kind + "'");
  if (!m.contains("config") || !m["config"].is_object()) fail(src, "meta.config missing or not an object");
  if (!m.contains("window") || !m["window"].is_number_integer() || m["window"].get<int64_t>() < 1)
    fail(src, "meta.window missing or not a positive integer");
  RetrievalCheckpoint r;
  r.config = m["config"];
  r.bundle.window = m["window"].get<int64_t>();
  if (m.contains("train")) r.bundle.train = m["train"];
  r.bundle.tokenizer = Tokenizer::load_from(ck, "tokenizer");
  if (!ck.has("feature_mean") || !ck.has("feature_std")) fail(src, "feature_mean / feature_std missing");
  const Tensor& mean = ck.get("feature_mean");
  const Tensor& sd = ck.get("feature_std");
  if (mean.dim() != 1 || mean.dtype() != DType::f32 || sd.shape() != mean.shape() || sd.dtype() != DType::f32)
    fail(src, "feature_mean / feature_std must be float32 (F,) tensors of one shape, got " + shape_str(mean.shape()) +
                  " and " + shape_str(sd.shape()));
  r.bundle.stats.mean = mean.to_vector<float>();
  r.bundle.stats.std = sd.to_vector<float>();
  for (float s : r.bundle.stats.std)
    if (!(s > 0) || !std::isfinite(s)) fail(src, "feature_std holds a value <= 0 or non-finite");
  for (float v : r.bundle.stats.mean)
    if (!std::isfinite(v)) fail(src, "feature_mean holds a non-finite value");
  r.ck = std::move(ck);
  return r;
}

Tensor embed_texts(const RetrievalBundle& b, const std::vector<std::string>& texts, int64_t batch) {
  if (!b.model) throw Error("embed_texts: no model");
  if (texts.empty()) throw Error("embed_texts: no texts");
  ag::NoGradGuard ng;
  b.model->eval();
  const int64_t N = (int64_t)texts.size();
  Tensor out;
  for (int64_t i0 = 0; i0 < N; i0 += batch) {
    const int64_t n = std::min(batch, N - i0);
    std::vector<std::string> part(texts.begin() + i0, texts.begin() + i0 + n);
    EncodedBatch eb = encode_captions(b.tokenizer, part, b.model->max_text_len());
    ag::Variable e = b.model->embed_text(eb.ids, eb.mask);
    if (!out.defined()) out = Tensor::zeros({N, e.size(1)});
    store_normalised(e, out, i0);
  }
  return out;
}

Tensor embed_motions(const RetrievalBundle& b, const std::vector<const std::vector<float>*>& clips, int64_t batch) {
  if (!b.model) throw Error("embed_motions: no model");
  if (clips.empty()) throw Error("embed_motions: no motions");
  const int64_t F = b.model->feature_dim();
  if (b.stats.dim() != F) throw Error("embed_motions: stats dimension differs from the model's features");
  const int64_t W = std::min(b.window, b.model->max_frames());
  for (size_t i = 0; i < clips.size(); ++i)
    if (clips[i]->empty() || clips[i]->size() % F != 0)
      throw Error("embed_motions: motion " + std::to_string(i) + " has " + std::to_string(clips[i]->size()) +
                  " values, not a positive multiple of " + std::to_string(F));
  ag::NoGradGuard ng;
  b.model->eval();
  const int64_t N = (int64_t)clips.size();
  Tensor out;
  for (int64_t i0 = 0; i0 < N; i0 += batch) {
    const int64_t n = std::min(batch, N - i0);
    int64_t T = 1;
    for (int64_t i = 0; i < n; ++i) T = std::max(T, centre_crop((int64_t)clips[i0 + i]->size() / F, W).len);
    Tensor x = Tensor::zeros({n, T, F}), mask = Tensor::zeros({n, T});
    float* xp = x.data<float>();
    float* mp = mask.data<float>();
    for (int64_t i = 0; i < n; ++i) {
      const std::vector<float>& f = *clips[i0 + i];
      const Crop c = centre_crop((int64_t)f.size() / F, W);
      for (int64_t t = 0; t < c.len; ++t) {
        const float* src = f.data() + (c.start + t) * F;
        float* dst = xp + (i * T + t) * F;
        for (int64_t d = 0; d < F; ++d) dst[d] = (src[d] - b.stats.mean[d]) / b.stats.std[d];
        mp[i * T + t] = 1.0f;
      }
    }
    ag::Variable e = b.model->embed_motion(ag::Variable(x), mask);
    if (!out.defined()) out = Tensor::zeros({N, e.size(1)});
    store_normalised(e, out, i0);
  }
  return out;
}

}  // namespace t2m::text

// test_casim_gpt.cpp — the token GPT of the AR CASIM baseline: causal masking, text padding masks, a gradcheck,
// sampling (top-k / temperature / length / seed), tiny overfits of both conditionings, training batches and the
// code-set cache, bad inputs.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <unistd.h>
#include <vector>

#include "autograd/autograd.h"
#include "models/casim/ar_checkpoint.h"
#include "models/casim/ar_codes.h"
#include "models/casim/ar_gpt.h"
#include "models/casim/ar_sample.h"
#include "models/casim/ar_train.h"
#include "nn/loss_classification.h"
#include "nn/optim_adamw.h"
#include "tensor/ops.h"

namespace {

using namespace t2m;
using namespace t2m::casim;

ArGptConfig tiny(ArCond cond) {
  ArGptConfig c;
  c.cond = cond, c.codes = 6, c.max_motion = 8, c.text_dim = 5, c.pooled_dim = 4, c.max_text = 6;
  c.dim = 16, c.layers = 2, c.heads = 2;
  return c;
}

ArText text_of(Generator& g, int64_t B, int64_t L, DType dt = DType::f32) {
  return {rand_normal({B, L, 5}, g, 0, 1, dt), Tensor::ones({B, L}, dt), rand_normal({B, 4}, g, 0, 1, dt)};
}

Tensor ids(std::vector<int64_t> v, int64_t B) { return Tensor::from_vector(v, {B, (int64_t)v.size() / B}); }

double maxdiff(const Tensor& a, const Tensor& b) { return amax(abs(sub(a, b))).item(); }

TEST(CasimGpt, LaterTokensDoNotChangeEarlierLogits) {
  for (ArCond cond : {ArCond::cls, ArCond::tok}) {
    Generator g(1);
    ArGpt m(tiny(cond), g);
    const ArText t = text_of(g, 1, 3);
    const Tensor a = m.forward(t, ids({1, 2, 3, 4, 5}, 1)).data();  // (1, 6, 7)
    const Tensor b = m.forward(t, ids({1, 2, 3, 0, 0}, 1)).data();  // tokens 3.. changed
    // Row i predicts c_i from c_<i: rows 0..3 see only c_0..c_2, row 4 sees c_3.
    EXPECT_LT(maxdiff(a.slice(1, 0, 4), b.slice(1, 0, 4)), 1e-6) << ar_cond_name(cond);
    EXPECT_GT(maxdiff(a.slice(1, 4, 6), b.slice(1, 4, 6)), 1e-4) << ar_cond_name(cond);
    // A shorter input gives the same leading rows.
    const Tensor c = m.forward(t, ids({1, 2, 3}, 1)).data();
    EXPECT_LT(maxdiff(a.slice(1, 0, 4), c), 1e-6);
  }
}

TEST(CasimGpt, PaddedTextTokensDoNotChangeTheOutputs) {
  Generator g(2);
  ArGpt m(tiny(ArCond::tok), g);
  ArText t = text_of(g, 1, 2);
  const Tensor codes = ids({3, 1, 4}, 1);
  const Tensor ref = m.forward(t, codes).data();
  // The same two real tokens plus three padding tokens with arbitrary values.
  ArText p = t;
  p.tokens = concat({t.tokens, rand_normal({1, 3, 5}, g, 0, 10)}, 1);
  p.mask = Tensor::from_vector(std::vector<float>{1, 1, 0, 0, 0}, {1, 5});
  EXPECT_LT(maxdiff(ref, m.forward(p, codes).data()), 1e-5);
  // A batch of two with different lengths gives each row what it gives alone.
  ArText two{concat({p.tokens, rand_normal({1, 5, 5}, g)}, 0),
             concat({p.mask, Tensor::ones({1, 5})}, 0), Tensor()};
  const Tensor out = m.forward(two, ids({3, 1, 4, 3, 1, 4}, 2)).data();
  EXPECT_LT(maxdiff(ref, out.slice(0, 0, 1)), 1e-5);
  // The real text does matter.
  ArText q = t;
  q.tokens = rand_normal({1, 2, 5}, g);
  EXPECT_GT(maxdiff(ref, m.forward(q, codes).data()), 1e-4);
}

// Central differences in float64 of the teacher-forced cross-entropy w.r.t. parameters on every path: text
// projection (prefix), attention, token embedding, start-of-motion vector.
TEST(CasimGpt, GradcheckOfTheLossInDoublePrecision) {
  for (ArCond cond : {ArCond::cls, ArCond::tok}) {
    ArGptConfig c = tiny(cond);
    c.layers = 1, c.dim = 8;
    Generator g(3);
    ArGpt m(c, g);
    m.to(DType::f64);
    ArText t = text_of(g, 1, 2, DType::f64);
    const Tensor in = ids({1, 2}, 1), tgt = ids({1, 2, 6}, 1);
    auto loss = [&] { return nn::cross_entropy(m.forward(t, in), tgt); };
    m.zero_grad();
    loss().backward();
    int checked = 0;
    for (auto& [name, w] : m.named_parameters()) {
      if (name != "text_proj.weight" && name != "block0.attn.qkv.weight" && name != "tok_emb.weight" &&
          name != "som")
        continue;
      const Tensor an = w.grad().contiguous();
      for (int64_t e : {int64_t{0}, w.numel() / 2 + 1, w.numel() - 1}) {
        double* p = w.data().data<double>() + e;
        const double h = 1e-6, v0 = *p;
        *p = v0 + h;
        const double lp = loss().item();
        *p = v0 - h;
        const double lm = loss().item();
        *p = v0;
        const double num = (lp - lm) / (2 * h);
        EXPECT_NEAR(an.data<double>()[e], num, 1e-7 + 1e-5 * std::abs(num))
            << ar_cond_name(cond) << " " << name << "[" << e << "]";
        ++checked;
      }
    }
    EXPECT_EQ(checked, 12);
  }
}

TEST(CasimGptSample, SampleFromLogitsIsTheInverseCdfOfTheTopK) {
  const float lg[4] = {0.0f, std::log(3.0f), -1e9f, 5.0f};  // index 3 = end token
  // Without the end token: p = (0.25, 0.75, 0); the CDF runs over the candidates by descending logit: 1, 0, 2.
  EXPECT_EQ(sample_from_logits(lg, 4, 1.0, 0, false, 0.7), 1);
  EXPECT_EQ(sample_from_logits(lg, 4, 1.0, 0, false, 0.8), 0);
  // Temperature 2 flattens: p(1) = sqrt3 / (1 + sqrt3) = 0.634, so u = 0.7 now picks 0.
  EXPECT_EQ(sample_from_logits(lg, 4, 2.0, 0, false, 0.6), 1);
  EXPECT_EQ(sample_from_logits(lg, 4, 2.0, 0, false, 0.7), 0);

  EXPECT_EQ(sample_from_logits(lg, 4, 1.0, 1, false, 0.01), 1);  // top-1 = argmax
  EXPECT_EQ(sample_from_logits(lg, 4, 0.0, 0, true, 0.99), 3);   // greedy with the end allowed
  EXPECT_EQ(sample_from_logits(lg, 4, 1.0, 2, true, 0.5), 3);    // top-2 = {3, 1}: p(3) = e^5/(e^5+3) > 0.5
}

TEST(CasimGptSample, SeededAndLengthControlled) {
  Generator g(4);
  ArGpt m(tiny(ArCond::tok), g);
  const ArText t = text_of(g, 3, 2);
  Generator s1(9), s2(9);
  const auto a = sample_codes(m, t, {}, s1), b = sample_codes(m, t, {}, s2);
  EXPECT_EQ(a, b);
  for (const auto& r : a) {
    EXPECT_GE(r.size(), 1u);
    EXPECT_LE(r.size(), 8u);
    for (int64_t c : r) EXPECT_TRUE(c >= 0 && c < 6);
  }
  ArSampleOptions o;
  o.tokens = 5;
  for (const auto& r : sample_codes(m, t, o, s1)) EXPECT_EQ(r.size(), 5u);
  o.tokens = 9;
  EXPECT_THROW(sample_codes(m, t, o, s1), Error);
}

// Two captions -> two different code sequences (with end tokens): after training, greedy decoding reproduces each.
void overfit(ArCond cond) {
  Generator g(5);
  ArGpt m(tiny(cond), g);
  ArText t = text_of(g, 2, 3);
  t.mask = Tensor::from_vector(std::vector<float>{1, 1, 1, 1, 1, 0}, {2, 3});
  const std::vector<std::vector<int64_t>> want = {{1, 2, 3, 4}, {5, 0, 5}};
  const Tensor in = ids({1, 2, 3, 4, 5, 0, 5, 0}, 2);
  const Tensor tgt = ids({1, 2, 3, 4, 6, 5, 0, 5, 6, -100}, 2);
  nn::AdamWOptions ao;
  ao.lr = 1e-2;
  nn::AdamW opt(m.named_parameters(), ao);
  double first = 0, last = 0;
  for (int s = 0; s < 120; ++s) {
    opt.zero_grad();
    ag::Variable l = nn::cross_entropy(m.forward(t, in), tgt);
    l.backward();
    opt.step();
    if (s == 0) first = l.item();
    last = l.item();
  }
  EXPECT_LT(last, 0.05 * first) << ar_cond_name(cond);
  m.eval();
  ArSampleOptions o;
  o.temperature = 0;
  Generator sg(1);
  EXPECT_EQ(sample_codes(m, t, o, sg), want) << ar_cond_name(cond);
}

TEST(CasimGpt, ClsOverfitsATinyBatch) { overfit(ArCond::cls); }
TEST(CasimGpt, TokOverfitsATinyBatch) { overfit(ArCond::tok); }

TEST(CasimGpt, BadInputsAndCheckpoint) {
  Generator g(6);
  auto m = std::make_shared<ArGpt>(tiny(ArCond::tok), g);
  const ArText t = text_of(g, 1, 2);
  EXPECT_THROW(m->forward(t, ids({6}, 1)), Error);                  // code >= K
  EXPECT_THROW(m->forward(t, Tensor::zeros({1, 9}, DType::i64)), Error);  // n > max_motion
  EXPECT_THROW(m->forward(text_of(g, 1, 7), ids({1}, 1)), Error);   // L > max_text
  ArText nomask = t;
  nomask.mask = Tensor();
  EXPECT_THROW(m->forward(nomask, ids({1}, 1)), Error);
  ArGpt cls(tiny(ArCond::cls), g);
  EXPECT_THROW(cls.forward(ArText{t.tokens, t.mask, Tensor()}, ids({1}, 1)), Error);  // no pooled feature
  EXPECT_THROW(ar_cond_from_name("mean"), Error);
  ArGptConfig bad = tiny(ArCond::tok);
  bad.heads = 3;
  EXPECT_THROW(ArGpt(bad, g), Error);
  const std::string p = std::filesystem::temp_directory_path() / ("casim_ar_" + std::to_string(getpid()) + ".ck");
  save_ar({m, 1234, {{"note", "test"}}}, p);
  const ArBundle r = load_ar(p);
  EXPECT_EQ(r.vq_crc, 1234u);
  EXPECT_LT(maxdiff(r.model->forward(t, ids({1, 2}, 1)).data(), m->forward(t, ids({1, 2}, 1)).data()), 1e-7);
  EXPECT_THROW(load_vq(p), Error);
  std::filesystem::remove(p);
}

TEST(CasimCodes, CacheRoundTripAndBadFiles) {
  const std::string dir = std::filesystem::temp_directory_path() / ("casim_codes_" + std::to_string(getpid()));
  CodeSet s;
  s.codes = 4;
  s.items.push_back({"dataset-1_walk_normal_001", "walk", "normal", true, {0, 3, 2}});
  int made = 0;
  auto make = [&] { ++made; return s; };
  const CodeSet a = ensure_code_set(dir + "/c.json", 77, make);
  const CodeSet b = ensure_code_set(dir + "/c.json", 77, make);  // cached
  EXPECT_EQ(made, 1);
  EXPECT_EQ(b.items[0].codes, (std::vector<int64_t>{0, 3, 2}));
  EXPECT_TRUE(b.items[0].mirrored);
  ensure_code_set(dir + "/c.json", 78, make);  // another tokenizer: rebuilt
  EXPECT_EQ(made, 2);
  s.items[0].codes = {4};
  save_code_set(s, dir + "/bad.json");
  EXPECT_THROW(load_code_set(dir + "/bad.json"), Error);  // code out of range
  EXPECT_THROW(load_code_set(dir + "/missing.json"), Error);
  std::filesystem::remove_all(dir);
}

TEST(CasimArBatch, TargetsEndOnlyWhenTheCropReachesTheEnd) {
  const std::string tp = std::string(T2M_SOURCE_DIR) + "/models/checkpoints/text_encoder.t2mckpt";
  if (!std::filesystem::exists(tp)) GTEST_SKIP() << "no " << tp;
  const ArTextEncoder text(tp);
  CodeSet s;
  s.codes = 5;
  s.items.push_back({"a", "walk", "normal", false, {1, 2}});
  s.items.push_back({"b", "run", "active", false, {0, 1, 2, 3, 4, 4, 3, 2, 1, 0}});
  Generator d(1), c(2);
  const ArBatch b = make_ar_batch(s, text, 16, 4, 0.0, d, c);
  ASSERT_EQ(b.inputs.size(1), 4);
  const auto in = b.inputs.to_vector<int64_t>(), tg = b.targets.to_vector<int64_t>();
  for (int r = 0; r < 16; ++r) {
    if (tg[r * 5 + 2] == 5 && in[r * 4] == 1 && in[r * 4 + 1] == 2 && tg[r * 5 + 3] == -100) continue;  // item a
    // item b: a crop of 4 consecutive codes; the end token only for the crop ending at the last code.
    for (int i = 0; i < 4; ++i) EXPECT_EQ(tg[r * 5 + i], in[r * 4 + i]);
    EXPECT_EQ(tg[r * 5 + 4], in[r * 4] == 3 && in[r * 4 + 1] == 2 ? 5 : -100);  // only the crop [3, 2, 1, 0]
  }
  EXPECT_EQ(b.text.tokens.size(0), 16);
  // With corruption every input may change, the targets never do.
  Generator d2(1), c2(2);
  const ArBatch k = make_ar_batch(s, text, 16, 4, 0.99, d2, c2);
  EXPECT_EQ(k.targets.to_vector<int64_t>(), tg);
  EXPECT_NE(k.inputs.to_vector<int64_t>(), in);
}

}  // namespace

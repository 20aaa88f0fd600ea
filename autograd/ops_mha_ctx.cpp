// ops_mha_ctx.cpp — forward/backward of mha_cross_ctx: GEMMs for K and the per-head value projection around the
// fused per-head loops of tensor/fused/attention_ctx.h.
// Forward:  K = ctx W_k^T + b_k | P, U = P ctx (fused) | o_h = U_h W_v,h^T (batched over heads) | o += r b_v.
// Backward: U = P ctx again | dW_v,h = dO_h^T U_h | db_v = sum r dO | dU_h = dO_h W_v,h | fused: dP = dU ctx^T ->
//           dq, dK (through the softmax and QK-norm), dctx = sum_h P^T dU | dW_k = dK^T ctx | db_k = sum dK |
//           dctx += dK W_k.
#include "autograd/ops_mha_ctx.h"

#include <atomic>
#include <memory>
#include <string>

#include "autograd/node.h"
#include "tensor/fused/attention_ctx.h"
#include "tensor/gemm.h"

namespace t2m::ag {

namespace {

std::atomic<int> g_force{0};  // 0 auto, 1 always, 2 never

struct Saved {
  fused::AttentionShape s;
  int64_t C = 0;
  bool norm = false, bias = false;
  double eps = 1e-6;
  Tensor q, ctx, w, k, att, rows;  // rows: (B, H, Tq) sums of the probabilities (U is recomputed: not kept)
  Tensor rstd_q, rstd_k, qn_w, kn_w;
};

template <typename T>
fused::AttentionHeads<T> heads_of(const Saved& sv, const T* key_mask) {
  fused::AttentionHeads<T> a;
  a.s = sv.s;
  const int64_t D = sv.s.H * sv.s.d;
  a.q = sv.q.data<T>(), a.ldq = D;
  a.k = sv.k.data<T>(), a.ldk = D;
  a.key_mask = key_mask;
  if (sv.norm) a.q_norm = sv.qn_w.data<T>(), a.k_norm = sv.kn_w.data<T>(), a.norm_eps = (T)sv.eps;
  return a;
}

template <typename T>
Tensor forward_impl(Saved& sv, const Tensor& bias, const Tensor& mask) {
  const fused::AttentionShape& s = sv.s;
  const int64_t B = s.B, H = s.H, Tq = s.Tq, Tk = s.Tk, d = s.d, D = H * d, C = sv.C;
  const DType dt = sv.q.dtype();
  const T* w = sv.w.data<T>();
  sv.k = Tensor::empty({B, Tk, D}, dt);  // K = ctx W_k^T + b_k
  gemm_bias(false, true, B * Tk, D, C, (T)1, sv.ctx.data<T>(), C, w, C, bias.defined() ? bias.data<T>() : nullptr,
            sv.k.data<T>(), D);
  sv.att = Tensor::empty({B, H, Tq, Tk}, dt);
  Tensor u = Tensor::empty({H, B, Tq, C}, dt);  // freed at the end of the forward
  if (sv.norm) sv.rstd_q = Tensor::empty({B * H * Tq}, dt), sv.rstd_k = Tensor::empty({B * H * Tk}, dt);
  fused::attention_ctx_forward<T>(u.data<T>(), sv.att.data<T>(), sv.norm ? sv.rstd_q.data<T>() : nullptr,
                                  sv.norm ? sv.rstd_k.data<T>() : nullptr,
                                  heads_of<T>(sv, mask.defined() ? mask.data<T>() : nullptr), sv.ctx.data<T>(), C);
  Tensor out = Tensor::empty({B, Tq, D}, dt);  // o_h = U_h W_v,h^T: rows (b, t), head h's d columns
  gemm_batched(false, true, H, B * Tq, d, C, (T)1, u.data<T>(), C, B * Tq * C, w + D * C, C, d * C, (T)0,
               out.data<T>(), D, d);
  sv.rows = Tensor::empty({B, H, Tq}, dt);
  const T* p = sv.att.data<T>();
  T* r = sv.rows.data<T>();
  for (int64_t i = 0; i < B * H * Tq; ++i) {
    T sum = 0;
    for (int64_t j = 0; j < Tk; ++j) sum += p[i * Tk + j];
    r[i] = sum;  // 1 up to rounding, 0 for a query with no visible key
  }
  if (bias.defined()) {  // + (sum_s P_h) b_v,h
    const T* bv = bias.data<T>() + D;
    T* o = out.data<T>();
    for (int64_t b = 0; b < B; ++b)
      for (int64_t t = 0; t < Tq; ++t)
        for (int64_t h = 0; h < H; ++h) {
          const T rs = r[(b * H + h) * Tq + t];
          T* oh = o + (b * Tq + t) * D + h * d;
          for (int64_t j = 0; j < d; ++j) oh[j] += rs * bv[h * d + j];
        }
  }
  return out;
}

struct Grads {
  Tensor dq, dctx, dw, db, dqn, dkn;
};

template <typename T>
void backward_impl(const Saved& sv, const Tensor& g, Grads& o) {
  const fused::AttentionShape& s = sv.s;
  const int64_t B = s.B, H = s.H, Tq = s.Tq, Tk = s.Tk, d = s.d, D = H * d, C = sv.C;
  const DType dt = g.dtype();
  const T* w = sv.w.data<T>();
  const T* go = g.data<T>();
  auto ptr = [](Tensor& t) { return t.defined() ? t.data<T>() : nullptr; };
  if (o.dw.defined()) {  // dW_v,h (d x C) = dO_h^T U_h, U = P ctx recomputed (the forward's bits)
    Tensor u = Tensor::empty({H, B, Tq, C}, dt);
    fused::attention_ctx_values<T>(u.data<T>(), sv.att.data<T>(), s, sv.ctx.data<T>(), C);
    gemm_batched(true, false, H, d, C, B * Tq, (T)1, go, D, d, u.data<T>(), C, B * Tq * C, (T)0,
                 o.dw.data<T>() + D * C, C, d * C);
  }
  if (o.db.defined()) {  // db_v = sum over (b, t) of r dO
    T* dbv = o.db.data<T>() + D;
    const T* r = sv.rows.data<T>();
    std::fill(dbv, dbv + D, (T)0);
    for (int64_t b = 0; b < B; ++b)
      for (int64_t t = 0; t < Tq; ++t)
        for (int64_t h = 0; h < H; ++h) {
          const T rs = r[(b * H + h) * Tq + t];
          const T* gh = go + (b * Tq + t) * D + h * d;
          for (int64_t j = 0; j < d; ++j) dbv[h * d + j] += rs * gh[j];
        }
  }
  const bool need_dk = o.dctx.defined() || o.dw.defined() || o.db.defined();
  if (!o.dq.defined() && !need_dk && !o.dqn.defined() && !o.dkn.defined()) return;
  Tensor du = Tensor::empty({H, B, Tq, C}, dt);  // dU_h = dO_h W_v,h
  gemm_batched(false, false, H, B * Tq, C, d, (T)1, go, D, d, w + D * C, C, d * C, (T)0, du.data<T>(), C, B * Tq * C);
  Tensor dk = need_dk ? Tensor::empty({B, Tk, D}, dt) : Tensor();
  fused::attention_ctx_backward<T>(ptr(o.dq), D, ptr(dk), D, ptr(o.dctx), ptr(o.dqn), ptr(o.dkn), du.data<T>(),
                                   sv.att.data<T>(), sv.norm ? sv.rstd_q.data<T>() : nullptr,
                                   sv.norm ? sv.rstd_k.data<T>() : nullptr, heads_of<T>(sv, nullptr),
                                   sv.ctx.data<T>(), C);
  if (!need_dk) return;
  const T* dkp = dk.data<T>();
  if (o.dw.defined())  // dW_k (D x C) = dK^T ctx
    gemm(true, false, D, C, B * Tk, (T)1, dkp, D, sv.ctx.data<T>(), C, (T)0, o.dw.data<T>(), C);
  if (o.db.defined()) {  // db_k = column sums of dK
    T* dbk = o.db.data<T>();
    std::fill(dbk, dbk + D, (T)0);
    for (int64_t r = 0; r < B * Tk; ++r)
      for (int64_t j = 0; j < D; ++j) dbk[j] += dkp[r * D + j];
  }
  if (o.dctx.defined())  // dctx += dK W_k
    gemm(false, false, B * Tk, C, D, (T)1, dkp, D, w, C, (T)1, o.dctx.data<T>(), C);
}

}  // namespace

bool mha_cross_ctx_serves(int64_t Tq, int64_t Tk, int64_t H, int64_t d) {
  fused::AttentionShape s;
  s.B = 1, s.H = H, s.Tq = Tq, s.Tk = Tk, s.d = d;
  return Tq >= 1 && Tk >= 1 && H >= 1 && d >= 1 && fused::attention_heads_eligible(s);
}

bool mha_cross_ctx_chosen(int64_t Tq, int64_t Tk, int64_t C, int64_t H, int64_t d) {
  const int f = g_force.load();
  if (f == 2 || !mha_cross_ctx_serves(Tq, Tk, H, d)) return false;
  if (f == 1) return true;
  const double D = double(H * d), q = double(Tq), k = double(Tk), c = double(C);
  const double kv_form = 2 * k * c * D + 2 * q * k * D;                // K, V; Q K^T, P V
  const double ctx_form = k * c * D + q * k * D + H * q * k * c + q * c * D;  // K; Q K^T; U = P ctx; o = U W_v^T
  return ctx_form <= 0.8 * kv_form;
}

void mha_cross_ctx_force(const char* mode) {
  const std::string m = mode ? mode : "";
  if (m == "auto") g_force = 0;
  else if (m == "always") g_force = 1;
  else if (m == "never") g_force = 2;
  else throw Error("mha_cross_ctx_force: unknown mode '" + m + "' (auto, always, never)");
}

// q (B,Tq,D), ctx (B,Tk,C), kv_weight (2D,C), kv_bias (2D) -> (B,Tq,D)
Variable mha_cross_ctx(const Variable& q, const Variable& ctx, const Variable& kv_weight, const Variable& kv_bias,
                       const Variable& q_norm, const Variable& k_norm, const Tensor& key_mask, const MhaOptions& opt) {
  auto fail = [&](const std::string& what) {
    std::string m = "mha_cross_ctx: " + what + " (q " + shape_str(q.shape()) + ", ctx " + shape_str(ctx.shape()) +
                    ", kv_weight " + shape_str(kv_weight.shape());
    if (kv_bias.defined()) m += ", kv_bias " + shape_str(kv_bias.shape());
    if (q_norm.defined()) m += ", q_norm " + shape_str(q_norm.shape());
    if (k_norm.defined()) m += ", k_norm " + shape_str(k_norm.shape());
    if (key_mask.defined()) m += ", key_mask " + shape_str(key_mask.shape());
    throw Error(m + ", heads " + std::to_string(opt.heads) + ")");
  };
  if (opt.heads < 1) fail("heads must be >= 1");
  if (opt.rope || opt.causal) fail("rope and causal are for self-attention only");
  if (q.dim() != 3 || ctx.dim() != 3) fail("q and ctx must be 3-D (B, T, width)");
  const int64_t B = q.size(0), Tq = q.size(1), D = q.size(2), Tk = ctx.size(1), C = ctx.size(2), H = opt.heads;
  if (D == 0 || D % H != 0) fail("q's last dim must be heads * d");
  const int64_t d = D / H;
  if (ctx.size(0) != B) fail("batch sizes differ");
  if (Tq < 1 || Tk < 1 || C < 1) fail("sequence lengths and the context width must be >= 1");
  if (kv_weight.shape() != Shape{2 * D, C}) fail("kv_weight must be (2 * D, C)");
  if (kv_bias.defined() && kv_bias.shape() != Shape{2 * D}) fail("kv_bias must be (2 * D)");
  const DType dt = q.dtype();
  if (dt != DType::f32 && dt != DType::f64) fail("inputs must be float32 or float64");
  if (ctx.dtype() != dt || kv_weight.dtype() != dt || (kv_bias.defined() && kv_bias.dtype() != dt))
    fail("dtypes differ");
  if (q_norm.defined() != k_norm.defined()) fail("give both QK-norm weights or neither");
  if (q_norm.defined() && (q_norm.shape() != Shape{d} || k_norm.shape() != Shape{d}))
    fail("QK-norm weights must be (d) = [" + std::to_string(d) + "]");
  if (q_norm.defined() && (q_norm.dtype() != dt || k_norm.dtype() != dt)) fail("QK-norm weight dtype differs");
  if (key_mask.defined() && key_mask.shape() != Shape{B, Tk})
    fail("key_mask must be (B, Tk) = [" + std::to_string(B) + ", " + std::to_string(Tk) + "]");
  if (!mha_cross_ctx_serves(Tq, Tk, H, d)) fail("shape not served by the fused per-head loops");
  auto sv = std::make_shared<Saved>();
  sv->s.B = B, sv->s.H = H, sv->s.Tq = Tq, sv->s.Tk = Tk, sv->s.d = d;
  sv->C = C, sv->norm = q_norm.defined(), sv->bias = kv_bias.defined(), sv->eps = opt.norm_eps;
  sv->q = q.data().contiguous(), sv->ctx = ctx.data().contiguous(), sv->w = kv_weight.data().contiguous();
  if (sv->norm) sv->qn_w = q_norm.data().contiguous(), sv->kn_w = k_norm.data().contiguous();
  const Tensor bias = kv_bias.defined() ? kv_bias.data().contiguous() : Tensor();
  const Tensor mask = key_mask.defined() ? key_mask.to(dt).contiguous() : Tensor();
  Tensor out = dt == DType::f32 ? forward_impl<float>(*sv, bias, mask) : forward_impl<double>(*sv, bias, mask);
  std::vector<Variable> inputs{q, ctx, kv_weight};
  if (sv->bias) inputs.push_back(kv_bias);
  if (sv->norm) inputs.insert(inputs.end(), {q_norm, k_norm});
  return record("mha_cross_ctx", out, inputs, [sv](const Tensor& grad, const std::vector<bool>& need) {
    const Saved& v = *sv;
    const int64_t D = v.s.H * v.s.d, ib = v.bias ? 3 : -1, in = v.bias ? 4 : 3;
    const DType dt = grad.dtype();
    Grads o;
    if (need[0]) o.dq = Tensor::empty({v.s.B, v.s.Tq, D}, dt);
    if (need[1]) o.dctx = Tensor::empty({v.s.B, v.s.Tk, v.C}, dt);
    if (need[2]) o.dw = Tensor::empty({2 * D, v.C}, dt);
    if (ib >= 0 && need[ib]) o.db = Tensor::empty({2 * D}, dt);
    if (v.norm && need[in]) o.dqn = Tensor::zeros({v.s.d}, dt);
    if (v.norm && need[in + 1]) o.dkn = Tensor::zeros({v.s.d}, dt);
    const Tensor g = grad.contiguous();
    if (dt == DType::f32)
      backward_impl<float>(v, g, o);
    else
      backward_impl<double>(v, g, o);
    std::vector<Tensor> r(need.size());
    r[0] = o.dq, r[1] = o.dctx, r[2] = o.dw;
    if (ib >= 0) r[ib] = o.db;
    if (v.norm) r[in] = o.dqn, r[in + 1] = o.dkn;
    return r;
  });
}

}  // namespace t2m::ag

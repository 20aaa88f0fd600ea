// ops_mha.cpp — forward/backward of the multi-head attention core over the fused kernels.
// Shapes the small-head path serves run fused::attention_heads_forward/backward: per head, straight from the
// projections' rows into the output rows, and from the output gradient into d(src) (no head-layout copies).
// Other shapes:
// Forward:  gather heads (B,T,W)->(B,H,T,d) | rms_norm q,k | rope q,k (in place) | attention | merge heads.
// Backward: gather g | (QK-norm: recompute normed+rotated q,k) | attention_backward | rope_backward (in place) |
//           rms_norm_backward | scatter into d(src).
#include "autograd/ops_mha.h"

#include <cstring>
#include <memory>
#include <string>

#include "autograd/node.h"
#include "tensor/fused/attention.h"
#include "tensor/fused/attention_heads.h"
#include "tensor/fused/rms_norm.h"
#include "tensor/fused/rope.h"
#include "tensor/parallel.h"

namespace t2m::ag {

namespace {

int threads_for(int64_t work) { return work < kParallelGrain ? 1 : std::max(1, get_num_threads()); }

// src (B, T, W) rows, columns [col + h*d, col + (h+1)*d) of row (b, t)  ->  dst (B, H, T, d).
template <typename T>
void gather_heads(T* dst, const T* src, int64_t B, int64_t Tlen, int64_t W, int64_t col, int64_t H, int64_t d) {
  const int nt = threads_for(B * Tlen * H * d);
#pragma omp parallel for num_threads(nt) schedule(static) if (nt > 1)
  for (int64_t r = 0; r < B * H; ++r) {
    const int64_t b = r / H, h = r % H;
    for (int64_t t = 0; t < Tlen; ++t)
      std::memcpy(dst + (r * Tlen + t) * d, src + (b * Tlen + t) * W + col + h * d, sizeof(T) * d);
  }
}

// The inverse layout change: src (B, H, T, d)  ->  columns [col, col + H*d) of dst (B, T, W).
template <typename T>
void scatter_heads(T* dst, const T* src, int64_t B, int64_t Tlen, int64_t W, int64_t col, int64_t H, int64_t d) {
  const int nt = threads_for(B * Tlen * H * d);
#pragma omp parallel for num_threads(nt) schedule(static) if (nt > 1)
  for (int64_t r = 0; r < B * Tlen; ++r) {
    const int64_t b = r / Tlen, t = r % Tlen;
    for (int64_t h = 0; h < H; ++h)
      std::memcpy(dst + r * W + col + h * d, src + ((b * H + h) * Tlen + t) * d, sizeof(T) * d);
  }
}

// Where q, k and v come from: (B, T, W) contiguous sources and the column where their H*d block starts.
struct Sources {
  Tensor q, k, v;
  int64_t qcol = 0, kcol = 0, vcol = 0;
};

// Everything the backward needs. With QK-norm only the pre-norm heads are kept: the normed and rotated q/k
// (as large again) are recomputed in the backward by the same kernels, so they come out bit-identical.
struct Saved {
  fused::AttentionShape s;
  bool heads = false;  // the fused heads path: src, the norm weights, rstd, att and the rope tables are kept
  Sources src;
  bool norm = false, rope = false;
  int64_t pos0 = 0;
  double base = 10000.0;
  double rstd_eps = 1e-6;                    // QK RMS-norm epsilon
  Tensor qh, kh, rstd_q, rstd_k, qn_w, kn_w;  // pre-norm heads, their rstd, norm weights (norm only)
  Tensor qr, kr;                             // rotated q/k (no norm only; else recomputed)
  Tensor v, att;                             // values and the probabilities
  Tensor cos_tab, sin_tab;                   // rope tables (rope only)
};

// q, k (B,H,T,d) as the attention sees them: RMS-norm of the pre-norm heads qh/kh (rstd written), then RoPE.
template <typename T>
void normed_rotated(Tensor& q, Tensor& k, T* rstd_q, T* rstd_k, const Saved& sv) {
  const fused::AttentionShape& s = sv.s;
  const int64_t BH = s.B * s.H, d = s.d;
  q = Tensor::empty(sv.qh.shape(), sv.qh.dtype()), k = Tensor::empty(sv.kh.shape(), sv.kh.dtype());
  fused::rms_norm_forward<T>(q.data<T>(), rstd_q, sv.qh.data<T>(), sv.qn_w.data<T>(), BH * s.Tq, d, (T)sv.rstd_eps);
  fused::rms_norm_forward<T>(k.data<T>(), rstd_k, sv.kh.data<T>(), sv.kn_w.data<T>(), BH * s.Tk, d, (T)sv.rstd_eps);
  if (sv.rope) {
    fused::rope_forward<T>(q.data<T>(), q.data<T>(), sv.cos_tab.data<T>(), sv.sin_tab.data<T>(), BH, s.Tq, d);
    fused::rope_forward<T>(k.data<T>(), k.data<T>(), sv.cos_tab.data<T>(), sv.sin_tab.data<T>(), BH, s.Tk, d);
  }
}

// The fused heads path's view of the saved sources (key_mask: the forward's, or null in the backward).
template <typename T>
fused::AttentionHeads<T> heads_args(const Saved& sv, const T* key_mask) {
  fused::AttentionHeads<T> a;
  a.s = sv.s;
  a.q = sv.src.q.data<T>() + sv.src.qcol, a.ldq = sv.src.q.size(2);
  a.k = sv.src.k.data<T>() + sv.src.kcol, a.ldk = sv.src.k.size(2);
  a.v = sv.src.v.data<T>() + sv.src.vcol, a.ldv = sv.src.v.size(2);
  a.key_mask = key_mask;
  if (sv.norm) a.q_norm = sv.qn_w.data<T>(), a.k_norm = sv.kn_w.data<T>(), a.norm_eps = (T)sv.rstd_eps;
  if (sv.rope) a.cos_tab = sv.cos_tab.data<T>(), a.sin_tab = sv.sin_tab.data<T>();
  return a;
}

template <typename T>
Tensor forward_impl(const Sources& src, const Tensor& qn_w, const Tensor& kn_w, const Tensor& mask, Saved& sv) {
  const fused::AttentionShape& s = sv.s;
  const int64_t B = s.B, H = s.H, Tq = s.Tq, Tk = s.Tk, d = s.d, Wq = src.q.size(2), Wk = src.k.size(2);
  const DType dt = src.q.dtype();
  if (sv.rope) {  // self-attention: Tq == Tk, one table
    sv.cos_tab = Tensor::empty({Tq, d / 2}, dt), sv.sin_tab = Tensor::empty({Tq, d / 2}, dt);
    fused::rope_table<T>(sv.cos_tab.data<T>(), sv.sin_tab.data<T>(), Tq, d, sv.base, sv.pos0);
  }
  if (sv.norm) {
    sv.qn_w = qn_w, sv.kn_w = kn_w;
    sv.rstd_q = Tensor::empty({B * H * Tq}, dt), sv.rstd_k = Tensor::empty({B * H * Tk}, dt);
  }
  sv.att = Tensor::empty({B, H, Tq, Tk}, dt);
  if (fused::attention_heads_eligible(s)) {
    sv.heads = true, sv.src = src;
    Tensor out = Tensor::empty({B, Tq, H * d}, dt);
    fused::attention_heads_forward<T>(out.data<T>(), H * d, sv.att.data<T>(),
                                      sv.norm ? sv.rstd_q.data<T>() : nullptr, sv.norm ? sv.rstd_k.data<T>() : nullptr,
                                      heads_args<T>(sv, mask.defined() ? mask.data<T>() : nullptr));
    return out;
  }
  Tensor q = Tensor::empty({B, H, Tq, d}, dt), k = Tensor::empty({B, H, Tk, d}, dt);
  sv.v = Tensor::empty({B, H, Tk, d}, dt);
  gather_heads<T>(q.data<T>(), src.q.data<T>(), B, Tq, Wq, src.qcol, H, d);
  gather_heads<T>(k.data<T>(), src.k.data<T>(), B, Tk, Wk, src.kcol, H, d);
  gather_heads<T>(sv.v.data<T>(), src.v.data<T>(), B, Tk, src.v.size(2), src.vcol, H, d);
  if (sv.norm) {
    sv.qh = q, sv.kh = k;
    normed_rotated<T>(q, k, sv.rstd_q.data<T>(), sv.rstd_k.data<T>(), sv);
  } else {
    if (sv.rope) {
      fused::rope_forward<T>(q.data<T>(), q.data<T>(), sv.cos_tab.data<T>(), sv.sin_tab.data<T>(), B * H, Tq, d);
      fused::rope_forward<T>(k.data<T>(), k.data<T>(), sv.cos_tab.data<T>(), sv.sin_tab.data<T>(), B * H, Tk, d);
    }
    sv.qr = q, sv.kr = k;
  }
  Tensor o = Tensor::empty({B, H, Tq, d}, dt);
  fused::attention_forward<T>(o.data<T>(), sv.att.data<T>(), q.data<T>(), k.data<T>(), sv.v.data<T>(),
                              mask.defined() ? mask.data<T>() : nullptr, s);
  Tensor out = Tensor::empty({B, Tq, H * d}, dt);
  scatter_heads<T>(out.data<T>(), o.data<T>(), B, Tq, H * d, 0, H, d);
  return out;
}

// Gradients of the heads: dq (B,H,Tq,d) before the norm, dk, dv (B,H,Tk,d); dqn/dkn (d) accumulated.
struct HeadGrads {
  Tensor dq, dk, dv, dqn, dkn;
};

template <typename T>
HeadGrads backward_impl(const Tensor& g, const Saved& sv, bool want_q, bool want_k, bool want_v, bool want_qn,
                        bool want_kn) {
  const fused::AttentionShape& s = sv.s;
  const int64_t B = s.B, H = s.H, Tq = s.Tq, Tk = s.Tk, d = s.d;
  const DType dt = g.dtype();
  Tensor go = Tensor::empty({B, H, Tq, d}, dt);
  gather_heads<T>(go.data<T>(), g.data<T>(), B, Tq, H * d, 0, H, d);
  HeadGrads r;
  const bool need_dq = want_q || want_qn, need_dk = want_k || want_kn;
  Tensor dqr = need_dq ? Tensor::empty({B, H, Tq, d}, dt) : Tensor();
  Tensor dkr = need_dk ? Tensor::empty({B, H, Tk, d}, dt) : Tensor();
  if (want_v) r.dv = Tensor::empty({B, H, Tk, d}, dt);
  auto ptr = [](const Tensor& t) { return t.defined() ? const_cast<Tensor&>(t).data<T>() : nullptr; };
  Tensor qr = sv.qr, kr = sv.kr;
  if (sv.norm) {  // recompute what the forward fed the attention (rstd scratch: identical values, not needed)
    Tensor rq = Tensor::empty({B * H * Tq}, dt), rk = Tensor::empty({B * H * Tk}, dt);
    normed_rotated<T>(qr, kr, rq.data<T>(), rk.data<T>(), sv);
  }
  fused::attention_backward<T>(ptr(dqr), ptr(dkr), ptr(r.dv), go.data<T>(), sv.att.data<T>(), qr.data<T>(),
                               kr.data<T>(), sv.v.data<T>(), s);
  if (sv.rope) {
    if (need_dq) fused::rope_backward<T>(ptr(dqr), ptr(dqr), sv.cos_tab.data<T>(), sv.sin_tab.data<T>(), B * H, Tq, d);
    if (need_dk) fused::rope_backward<T>(ptr(dkr), ptr(dkr), sv.cos_tab.data<T>(), sv.sin_tab.data<T>(), B * H, Tk, d);
  }
  if (!sv.norm) {
    r.dq = dqr, r.dk = dkr;
    return r;
  }
  if (want_qn) r.dqn = Tensor::zeros({d}, dt);
  if (want_kn) r.dkn = Tensor::zeros({d}, dt);
  if (need_dq) {
    r.dq = Tensor::empty(dqr.shape(), dt);
    fused::rms_norm_backward<T>(ptr(r.dq), ptr(r.dqn), dqr.data<T>(), sv.qh.data<T>(), sv.qn_w.data<T>(),
                                sv.rstd_q.data<T>(), B * H * Tq, d);
  }
  if (need_dk) {
    r.dk = Tensor::empty(dkr.shape(), dt);
    fused::rms_norm_backward<T>(ptr(r.dk), ptr(r.dkn), dkr.data<T>(), sv.kh.data<T>(), sv.kn_w.data<T>(),
                                sv.rstd_k.data<T>(), B * H * Tk, d);
  }
  return r;
}

// Shape checks shared by both entry points; returns the attention shape. qw/kw: expected last dims.
fused::AttentionShape check(const char* op, const Tensor& qsrc, const Tensor& kvsrc, int64_t qparts,
                            int64_t kvparts, const Variable& qn, const Variable& kn, const Tensor& mask,
                            const MhaOptions& opt) {
  auto fail = [&](const std::string& what) {
    std::string m = std::string(op) + ": " + what + " (input " + shape_str(qsrc.shape());
    if (&qsrc != &kvsrc) m += ", kv " + shape_str(kvsrc.shape());
    if (qn.defined()) m += ", q_norm " + shape_str(qn.shape());
    if (kn.defined()) m += ", k_norm " + shape_str(kn.shape());
    if (mask.defined()) m += ", key_mask " + shape_str(mask.shape());
    throw Error(m + ", heads " + std::to_string(opt.heads) + ")");
  };
  if (opt.heads < 1) fail("heads must be >= 1");
  if (qsrc.dim() != 3 || kvsrc.dim() != 3) fail("inputs must be 3-D (B, T, width)");
  const int64_t H = opt.heads, Wq = qsrc.size(2);
  if (Wq % (qparts * H) != 0 || Wq == 0) fail("last dim must be " + std::to_string(qparts) + " * heads * d");
  const int64_t d = Wq / (qparts * H);
  if (kvsrc.size(2) != kvparts * H * d) fail("kv last dim must be " + std::to_string(kvparts) + " * heads * d");
  if (qsrc.size(0) != kvsrc.size(0)) fail("batch sizes differ");
  if (qsrc.dtype() != DType::f32 && qsrc.dtype() != DType::f64) fail("inputs must be float32 or float64");
  if (qsrc.dtype() != kvsrc.dtype()) fail("dtypes differ");
  if (qn.defined() != kn.defined()) fail("give both QK-norm weights or neither");
  if (qn.defined() && (qn.shape() != Shape{d} || kn.shape() != Shape{d}))
    fail("QK-norm weights must be (d) = [" + std::to_string(d) + "]");
  if (qn.defined() && (qn.dtype() != qsrc.dtype() || kn.dtype() != qsrc.dtype())) fail("QK-norm weight dtype differs");
  if (opt.rope && d % 2 != 0) fail("rope needs an even head dim, got d = " + std::to_string(d));
  if (opt.rope && opt.rope_pos0 < 0) fail("rope_pos0 must be >= 0");
  fused::AttentionShape s;
  s.B = qsrc.size(0), s.H = H, s.Tq = qsrc.size(1), s.Tk = kvsrc.size(1), s.d = d, s.causal = opt.causal;
  if (s.Tq < 1 || s.Tk < 1) fail("sequence lengths must be >= 1");
  if (mask.defined() && mask.shape() != Shape{s.B, s.Tk})
    fail("key_mask must be (B, Tk) = [" + std::to_string(s.B) + ", " + std::to_string(s.Tk) + "]");
  if (opt.causal && s.Tq != s.Tk) fail("causal attention needs Tq == Tk");
  return s;
}

std::shared_ptr<Saved> make_saved(const fused::AttentionShape& s, const Variable& qn, const MhaOptions& opt) {
  auto sv = std::make_shared<Saved>();
  sv->s = s, sv->norm = qn.defined(), sv->rope = opt.rope, sv->pos0 = opt.rope_pos0, sv->base = opt.rope_base;
  sv->rstd_eps = opt.norm_eps;
  return sv;
}

Tensor run_forward(const Sources& src, const Variable& qn, const Variable& kn, const Tensor& key_mask, Saved& sv) {
  const DType dt = src.q.dtype();
  Tensor mask = key_mask.defined() ? key_mask.to(dt).contiguous() : Tensor();
  Tensor qw = qn.defined() ? qn.data().contiguous() : Tensor(), kw = kn.defined() ? kn.data().contiguous() : Tensor();
  return dt == DType::f32 ? forward_impl<float>(src, qw, kw, mask, sv) : forward_impl<double>(src, qw, kw, mask, sv);
}

// Where the fused heads backward writes: the gradients of the sources (any undefined: not needed) at the columns of
// q, k and v, and the norm-weight gradients (accumulated; undefined: not needed).
struct HeadsGradOut {
  Tensor dq, dk, dv, dqn, dkn;
};

template <typename T>
void heads_backward_impl(const Tensor& g, const Saved& sv, HeadsGradOut& o) {
  auto at = [](Tensor& t, int64_t col) { return t.defined() ? t.data<T>() + col : nullptr; };
  auto ld = [](const Tensor& t) { return t.defined() ? t.size(2) : int64_t(0); };
  fused::attention_heads_backward<T>(at(o.dq, sv.src.qcol), ld(o.dq), at(o.dk, sv.src.kcol), ld(o.dk),
                                     at(o.dv, sv.src.vcol), ld(o.dv), at(o.dqn, 0), at(o.dkn, 0), g.data<T>(),
                                     g.size(2), sv.att.data<T>(), sv.norm ? sv.rstd_q.data<T>() : nullptr,
                                     sv.norm ? sv.rstd_k.data<T>() : nullptr, heads_args<T>(sv, nullptr));
}

void run_heads_backward(const Tensor& grad, const Saved& sv, HeadsGradOut& o) {
  const Tensor g = grad.contiguous();
  if (g.dtype() == DType::f32)
    heads_backward_impl<float>(g, sv, o);
  else
    heads_backward_impl<double>(g, sv, o);
}

HeadGrads run_backward(const Tensor& grad, const Saved& sv, bool q, bool k, bool v, bool qn, bool kn) {
  const Tensor g = grad.contiguous();
  return g.dtype() == DType::f32 ? backward_impl<float>(g, sv, q, k, v, qn, kn)
                                 : backward_impl<double>(g, sv, q, k, v, qn, kn);
}

// Writes head gradient h (B,H,T,d) into columns [col, col + H*d) of dst (B,T,W).
void scatter_grad(Tensor& dst, const Tensor& h, int64_t col) {
  const int64_t B = h.size(0), H = h.size(1), Tlen = h.size(2), d = h.size(3), W = dst.size(2);
  if (h.dtype() == DType::f32)
    scatter_heads<float>(dst.data<float>(), h.data<float>(), B, Tlen, W, col, H, d);
  else
    scatter_heads<double>(dst.data<double>(), h.data<double>(), B, Tlen, W, col, H, d);
}

}  // namespace

// qkv (B,T,3*H*d) [q|k|v] -> out (B,T,H*d); dqkv (B,T,3*H*d) written part by part; dq_norm/dk_norm (d).
Variable mha_self(const Variable& qkv, const Variable& q_norm, const Variable& k_norm, const Tensor& key_mask,
                  const MhaOptions& opt) {
  const Tensor x = qkv.data().dim() == 3 ? qkv.data().contiguous() : qkv.data();
  const fused::AttentionShape s = check("mha_self", x, x, 3, 3, q_norm, k_norm, key_mask, opt);
  auto sv = make_saved(s, q_norm, opt);
  const int64_t D = s.H * s.d;
  Tensor out = run_forward(Sources{x, x, x, 0, D, 2 * D}, q_norm, k_norm, key_mask, *sv);
  std::vector<Variable> inputs{qkv};
  if (q_norm.defined()) inputs.insert(inputs.end(), {q_norm, k_norm});
  return record("mha_self", out, inputs, [sv, D](const Tensor& g, const std::vector<bool>& need) {
    const bool nx = need[0], nqn = sv->norm && need[1], nkn = sv->norm && need[2];
    std::vector<Tensor> r(need.size());
    if (sv->heads) {
      HeadsGradOut o;
      if (nx) o.dq = o.dk = o.dv = r[0] = Tensor::empty({sv->s.B, sv->s.Tq, 3 * D}, g.dtype());  // all written
      if (nqn) o.dqn = r[1] = Tensor::zeros({sv->s.d}, g.dtype());
      if (nkn) o.dkn = r[2] = Tensor::zeros({sv->s.d}, g.dtype());
      run_heads_backward(g, *sv, o);
      return r;
    }
    HeadGrads h = run_backward(g, *sv, nx, nx, nx, nqn, nkn);
    if (nx) {
      r[0] = Tensor::empty({sv->s.B, sv->s.Tq, 3 * D}, g.dtype());  // every column is written below
      scatter_grad(r[0], h.dq, 0);
      scatter_grad(r[0], h.dk, D);
      scatter_grad(r[0], h.dv, 2 * D);
    }
    if (sv->norm) r[1] = h.dqn, r[2] = h.dkn;
    return r;
  });
}

// q (B,Tq,H*d), kv (B,Tk,2*H*d) [k|v] -> out (B,Tq,H*d); dq, dkv written; dq_norm/dk_norm (d).
Variable mha_cross(const Variable& q, const Variable& kv, const Variable& q_norm, const Variable& k_norm,
                   const Tensor& key_mask, const MhaOptions& opt) {
  const Tensor qx = q.data().dim() == 3 ? q.data().contiguous() : q.data();
  const Tensor kx = kv.data().dim() == 3 ? kv.data().contiguous() : kv.data();
  const fused::AttentionShape s = check("mha_cross", qx, kx, 1, 2, q_norm, k_norm, key_mask, opt);
  auto sv = make_saved(s, q_norm, opt);
  if (opt.rope && s.Tq != s.Tk) throw Error("mha_cross: rope needs Tq == Tk (one position table), got " +
                                            std::to_string(s.Tq) + " and " + std::to_string(s.Tk));
  const int64_t D = s.H * s.d;
  Tensor out = run_forward(Sources{qx, kx, kx, 0, 0, D}, q_norm, k_norm, key_mask, *sv);
  std::vector<Variable> inputs{q, kv};
  if (q_norm.defined()) inputs.insert(inputs.end(), {q_norm, k_norm});
  return record("mha_cross", out, inputs, [sv, D](const Tensor& g, const std::vector<bool>& need) {
    const bool nqn = sv->norm && need[2], nkn = sv->norm && need[3];
    std::vector<Tensor> r(need.size());
    if (sv->heads) {
      HeadsGradOut o;
      if (need[0]) o.dq = r[0] = Tensor::empty({sv->s.B, sv->s.Tq, D}, g.dtype());
      if (need[1]) o.dk = o.dv = r[1] = Tensor::empty({sv->s.B, sv->s.Tk, 2 * D}, g.dtype());
      if (nqn) o.dqn = r[2] = Tensor::zeros({sv->s.d}, g.dtype());
      if (nkn) o.dkn = r[3] = Tensor::zeros({sv->s.d}, g.dtype());
      run_heads_backward(g, *sv, o);
      return r;
    }
    HeadGrads h = run_backward(g, *sv, need[0], need[1], need[1], nqn, nkn);
    if (need[0]) {
      r[0] = Tensor::empty({sv->s.B, sv->s.Tq, D}, g.dtype());
      scatter_grad(r[0], h.dq, 0);
    }
    if (need[1]) {
      r[1] = Tensor::empty({sv->s.B, sv->s.Tk, 2 * D}, g.dtype());
      scatter_grad(r[1], h.dk, 0);
      scatter_grad(r[1], h.dv, D);
    }
    if (sv->norm) r[2] = h.dqn, r[3] = h.dkn;
    return r;
  });
}

}  // namespace t2m::ag

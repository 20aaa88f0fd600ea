// attention.cpp — S = scale Q K^T (gemm_batched) into att, masked max-subtracted softmax in place, out = P V.
// Backward: dV = P^T dO; dP = dO V^T; dS = P * (dP - rowsum(P * dP)) * scale; dQ = dS K; dK = dS^T Q.
// exp_approx's clamps vectorise only without -ftrapping-math; nothing here reads floating-point exception flags.
#pragma GCC optimize("no-trapping-math")
#include "tensor/fused/attention.h"

#include <atomic>
#include <cmath>
#include <string>

#include "tensor/fused/attention_heads.h"
#include "tensor/fused/attention_small.h"
#include "tensor/fused/fast_exp.h"
#include "tensor/fused/kernel_util.h"
#include "tensor/fused/scratch.h"
#include "tensor/gemm.h"

namespace t2m::fused {

namespace {

void check_shape(const char* op, const AttentionShape& s) {
  check_dim(op, "B", s.B, 0);
  check_dim(op, "H", s.H, 1);
  check_dim(op, "Tq", s.Tq, 1);
  check_dim(op, "Tk", s.Tk, 1);
  check_dim(op, "d", s.d, 1);
  if (s.causal && s.Tq != s.Tk)
    throw Error(std::string(op) + ": causal attention needs Tq == Tk, got Tq=" + std::to_string(s.Tq) +
                " Tk=" + std::to_string(s.Tk));
}

std::atomic<int> g_forced_path{0};  // 0 auto, 1 small, 2 gemm

bool use_small(const AttentionShape& s) { return g_forced_path.load() != 2 && attention_small_eligible(s); }

}  // namespace

const char* attention_path(const AttentionShape& s) { return use_small(s) ? "small" : "gemm"; }

void attention_force_path(const char* name) {
  const std::string n = name ? name : "";
  if (n == "auto") g_forced_path = 0;
  else if (n == "small") g_forced_path = 1;
  else if (n == "gemm") g_forced_path = 2;
  else throw Error("attention_force_path: unknown path '" + n + "' (small, gemm, auto)");
}

double attention_forward_flops(const AttentionShape& s) {
  return 4.0 * (double)s.B * (double)s.H * (double)s.Tq * (double)s.Tk * (double)s.d;
}

template <typename T>
void attention_forward(T* out, T* att, const T* q, const T* k, const T* v, const T* key_mask,
                       const AttentionShape& s) {
  const char* op = "attention_forward";
  check_shape(op, s);
  if (s.B == 0) return;
  check_ptr(op, "out", out);
  check_ptr(op, "att", att);
  check_ptr(op, "q", q);
  check_ptr(op, "k", k);
  check_ptr(op, "v", v);
  if (use_small(s)) return attention_small_forward(out, att, q, k, v, key_mask, s);
  const int64_t BH = s.B * s.H, Tq = s.Tq, Tk = s.Tk, d = s.d;
  const T scale = (T)(1.0 / std::sqrt((double)d));
  gemm_batched(false, true, BH, Tq, Tk, d, scale, q, d, Tq * d, k, d, Tk * d, (T)0, att, Tk, Tq * Tk);
  const int nt = fused_threads(BH * Tq * Tk);
#pragma omp parallel for num_threads(nt) schedule(static) if (nt > 1)
  for (int64_t r = 0; r < BH * Tq; ++r) {
    const int64_t b = r / (s.H * Tq), i = r % Tq;
    T* p = att + r * Tk;
    const T* m = key_mask ? key_mask + b * Tk : nullptr;
    const int64_t jend = s.causal ? i + 1 : Tk;  // keys [jend, Tk) are hidden by the causal mask
    T mx = 0;
    bool any = false;
    for (int64_t j = 0; j < jend; ++j) {
      if (m && m[j] == (T)0) continue;
      if (!any || p[j] > mx) mx = p[j];
      any = true;
    }
    if (!any) {
      for (int64_t j = 0; j < Tk; ++j) p[j] = 0;
      continue;
    }
    for (int64_t j = 0; j < jend; ++j) p[j] = fexp(p[j] - mx);
    if (m)
      for (int64_t j = 0; j < jend; ++j)
        if (m[j] == (T)0) p[j] = 0;
    for (int64_t j = jend; j < Tk; ++j) p[j] = 0;
    T sum = 0;
#pragma omp simd reduction(+ : sum)
    for (int64_t j = 0; j < jend; ++j) sum += p[j];
    const T inv = (T)1 / sum;
    for (int64_t j = 0; j < jend; ++j) p[j] *= inv;
  }
  gemm_batched(false, false, BH, Tq, d, Tk, (T)1, att, Tk, Tq * Tk, v, d, Tk * d, (T)0, out, d, Tq * d);
}

template <typename T>
void attention_backward(T* dq, T* dk, T* dv, const T* dout, const T* att, const T* q, const T* k, const T* v,
                        const AttentionShape& s) {
  const char* op = "attention_backward";
  check_shape(op, s);
  if (s.B == 0) return;
  check_ptr(op, "dout", dout);
  check_ptr(op, "att", att);
  if (use_small(s)) {
    if (dq || dk) check_ptr(op, "v", v);
    if (dq) check_ptr(op, "k", k);
    if (dk) check_ptr(op, "q", q);
    return attention_small_backward(dq, dk, dv, dout, att, q, k, v, s);
  }
  const int64_t BH = s.B * s.H, Tq = s.Tq, Tk = s.Tk, d = s.d;
  const T scale = (T)(1.0 / std::sqrt((double)d));
  if (dv) gemm_batched(true, false, BH, Tk, d, Tq, (T)1, att, Tk, Tq * Tk, dout, d, Tq * d, (T)0, dv, d, Tk * d);
  if (!dq && !dk) return;
  check_ptr(op, "v", v);
  T* ds = fused_scratch<T>(2, BH * Tq * Tk);
  gemm_batched(false, true, BH, Tq, Tk, d, (T)1, dout, d, Tq * d, v, d, Tk * d, (T)0, ds, Tk, Tq * Tk);
  const int nt = fused_threads(BH * Tq * Tk);
#pragma omp parallel for num_threads(nt) schedule(static) if (nt > 1)
  for (int64_t r = 0; r < BH * Tq; ++r) {
    const T* p = att + r * Tk;
    T* g = ds + r * Tk;
    T dot = 0;
#pragma omp simd reduction(+ : dot)
    for (int64_t j = 0; j < Tk; ++j) dot += p[j] * g[j];
    for (int64_t j = 0; j < Tk; ++j) g[j] = p[j] * (g[j] - dot) * scale;
  }
  if (dq) {
    check_ptr(op, "k", k);
    gemm_batched(false, false, BH, Tq, d, Tk, (T)1, ds, Tk, Tq * Tk, k, d, Tk * d, (T)0, dq, d, Tq * d);
  }
  if (dk) {
    check_ptr(op, "q", q);
    gemm_batched(true, false, BH, Tk, d, Tq, (T)1, ds, Tk, Tq * Tk, q, d, Tq * d, (T)0, dk, d, Tk * d);
  }
}

bool attention_heads_eligible(const AttentionShape& s) { return use_small(s); }

template <typename T>
void check_attention_heads(const char* op, const AttentionHeads<T>& a, bool values) {
  const AttentionShape& s = a.s;
  check_shape(op, s);
  if (!attention_heads_eligible(s))
    throw Error(std::string(op) + ": shape not served by the fused heads path (Tq*Tk=" + std::to_string(s.Tq * s.Tk) +
                ", d=" + std::to_string(s.d) + "); use the (B, H, T, d) attention");
  const int64_t w = s.H * s.d;
  if (a.ldq < w || a.ldk < w || (values && a.ldv < w))
    throw Error(std::string(op) + ": leading dimensions must be >= H*d = " + std::to_string(w) + ", got " +
                std::to_string(a.ldq) + ", " + std::to_string(a.ldk) + (values ? ", " + std::to_string(a.ldv) : ""));
  if ((a.q_norm == nullptr) != (a.k_norm == nullptr))
    throw Error(std::string(op) + ": give both norm weights or neither");
  if ((a.cos_tab == nullptr) != (a.sin_tab == nullptr))
    throw Error(std::string(op) + ": give both RoPE tables or neither");
  if (a.cos_tab && (s.Tq != s.Tk || s.d % 2 != 0))
    throw Error(std::string(op) + ": RoPE needs Tq == Tk and an even d, got Tq=" + std::to_string(s.Tq) + " Tk=" +
                std::to_string(s.Tk) + " d=" + std::to_string(s.d));
  if (!(a.norm_eps >= 0)) throw Error(std::string(op) + ": norm_eps must be >= 0");
  if (s.B == 0) return;
  check_ptr(op, "q", a.q);
  check_ptr(op, "k", a.k);
  if (values) check_ptr(op, "v", a.v);
}

template <typename T>
void attention_heads_forward(T* out, int64_t ldo, T* att, T* rstd_q, T* rstd_k, const AttentionHeads<T>& a) {
  const char* op = "attention_heads_forward";
  check_attention_heads(op, a, true);
  if (a.s.B == 0) return;
  check_ptr(op, "out", out);
  check_ptr(op, "att", att);
  if (ldo < a.s.H * a.s.d) throw Error("attention_heads_forward: ldo must be >= H*d, got " + std::to_string(ldo));
  if (a.q_norm) {
    check_ptr(op, "rstd_q", rstd_q);
    check_ptr(op, "rstd_k", rstd_k);
  }
  attention_small_heads_forward(out, ldo, att, rstd_q, rstd_k, a);
}

template <typename T>
void attention_heads_backward(T* dq, int64_t lddq, T* dk, int64_t lddk, T* dv, int64_t lddv, T* dq_norm, T* dk_norm,
                              const T* dout, int64_t ldg, const T* att, const T* rstd_q, const T* rstd_k,
                              const AttentionHeads<T>& a) {
  const char* op = "attention_heads_backward";
  check_attention_heads(op, a, true);
  if (a.s.B == 0) return;
  check_ptr(op, "dout", dout);
  check_ptr(op, "att", att);
  const int64_t w = a.s.H * a.s.d;
  if (ldg < w || (dq && lddq < w) || (dk && lddk < w) || (dv && lddv < w))
    throw Error("attention_heads_backward: leading dimensions must be >= H*d = " + std::to_string(w));
  if (a.q_norm) {
    check_ptr(op, "rstd_q", rstd_q);
    check_ptr(op, "rstd_k", rstd_k);
  }
  attention_small_heads_backward(dq, lddq, dk, lddk, dv, lddv, a.q_norm ? dq_norm : nullptr,
                                 a.q_norm ? dk_norm : nullptr, dout, ldg, att, rstd_q, rstd_k, a);
}

#define T2M_HEADS_INSTANTIATE(T)                                                                                   \
  template void check_attention_heads<T>(const char*, const AttentionHeads<T>&, bool);                            \
  template void attention_heads_forward<T>(T*, int64_t, T*, T*, T*, const AttentionHeads<T>&);                   \
  template void attention_heads_backward<T>(T*, int64_t, T*, int64_t, T*, int64_t, T*, T*, const T*, int64_t,     \
                                            const T*, const T*, const T*, const AttentionHeads<T>&);
T2M_HEADS_INSTANTIATE(float)
T2M_HEADS_INSTANTIATE(double)
#undef T2M_HEADS_INSTANTIATE

template void attention_forward<float>(float*, float*, const float*, const float*, const float*, const float*,
                                       const AttentionShape&);
template void attention_forward<double>(double*, double*, const double*, const double*, const double*,
                                        const double*, const AttentionShape&);
template void attention_backward<float>(float*, float*, float*, const float*, const float*, const float*,
                                        const float*, const float*, const AttentionShape&);
template void attention_backward<double>(double*, double*, double*, const double*, const double*, const double*,
                                         const double*, const double*, const AttentionShape&);

}  // namespace t2m::fused

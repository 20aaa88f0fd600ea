// ops_attention.cpp — forward/backward pairs of attention and rope over the fused kernels. The ops only check
// shapes, make the operands contiguous (no copy when they already are) and dispatch on the dtype.
#include "autograd/ops_attention.h"

#include <string>

#include "autograd/node.h"
#include "tensor/fused/attention.h"
#include "tensor/fused/rope.h"

namespace t2m::ag {

namespace {

bool is_float(DType d) { return d == DType::f32 || d == DType::f64; }

fused::AttentionShape attention_shape(const Tensor& q, const Tensor& k, const Tensor& v, const Tensor& mask,
                                      bool causal) {
  auto fail = [&](const std::string& what) {
    throw Error("attention: " + what + " (q " + shape_str(q.shape()) + ", k " + shape_str(k.shape()) + ", v " +
                shape_str(v.shape()) + (mask.defined() ? ", key_mask " + shape_str(mask.shape()) : "") + ")");
  };
  if (q.dim() != 4 || k.dim() != 4 || v.dim() != 4) fail("q, k, v must be 4-D (B, H, T, d)");
  if (k.shape() != v.shape()) fail("k and v must have the same shape");
  if (q.size(0) != k.size(0) || q.size(1) != k.size(1) || q.size(3) != k.size(3))
    fail("q and k must agree in B, H and d");
  if (!is_float(q.dtype()) || q.dtype() != k.dtype() || q.dtype() != v.dtype())
    fail(std::string("q, k, v must share a float dtype, got ") + dtype_name(q.dtype()) + ", " +
         dtype_name(k.dtype()) + ", " + dtype_name(v.dtype()));
  fused::AttentionShape s;
  s.B = q.size(0);
  s.H = q.size(1);
  s.Tq = q.size(2);
  s.Tk = k.size(2);
  s.d = q.size(3);
  s.causal = causal;
  if (mask.defined() && (mask.dim() != 2 || mask.size(0) != s.B || mask.size(1) != s.Tk))
    fail("key_mask must be (B, Tk) = [" + std::to_string(s.B) + ", " + std::to_string(s.Tk) + "]");
  if (causal && s.Tq != s.Tk) fail("causal attention needs Tq == Tk");
  if (s.H < 1 || s.Tq < 1 || s.Tk < 1 || s.d < 1) fail("H, Tq, Tk and d must be >= 1");
  return s;
}

template <typename T>
void attention_fwd(Tensor& out, Tensor& att, const Tensor& q, const Tensor& k, const Tensor& v, const Tensor& mask,
                   const fused::AttentionShape& s) {
  fused::attention_forward<T>(out.data<T>(), att.data<T>(), q.data<T>(), k.data<T>(), v.data<T>(),
                              mask.defined() ? mask.data<T>() : nullptr, s);
}

template <typename T>
void attention_bwd(Tensor& dq, Tensor& dk, Tensor& dv, const Tensor& g, const Tensor& att, const Tensor& q,
                   const Tensor& k, const Tensor& v, const fused::AttentionShape& s) {
  auto ptr = [](Tensor& t) { return t.defined() ? t.data<T>() : nullptr; };
  fused::attention_backward<T>(ptr(dq), ptr(dk), ptr(dv), g.data<T>(), att.data<T>(), q.data<T>(), k.data<T>(),
                               v.data<T>(), s);
}

template <typename T>
void rope_apply(Tensor& out, const Tensor& in, int64_t N, int64_t Tlen, int64_t d, double base, int64_t pos0,
                bool inverse) {
  Tensor cos_tab = Tensor::empty({Tlen, d / 2}, in.dtype()), sin_tab = Tensor::empty({Tlen, d / 2}, in.dtype());
  fused::rope_table<T>(cos_tab.data<T>(), sin_tab.data<T>(), Tlen, d, base, pos0);
  if (inverse)
    fused::rope_backward<T>(out.data<T>(), in.data<T>(), cos_tab.data<T>(), sin_tab.data<T>(), N, Tlen, d);
  else
    fused::rope_forward<T>(out.data<T>(), in.data<T>(), cos_tab.data<T>(), sin_tab.data<T>(), N, Tlen, d);
}

// in (N, T, d) contiguous -> out (N, T, d): rotation by +angle (forward) or -angle (inverse = backward).
Tensor rope_rotate(const Tensor& in, int64_t pos0, double base, bool inverse) {
  const int64_t d = in.size(-1), Tlen = in.size(-2);
  Tensor out = Tensor::empty(in.shape(), in.dtype());
  if (in.numel() == 0) return out;
  const int64_t N = in.numel() / (Tlen * d);
  if (in.dtype() == DType::f32)
    rope_apply<float>(out, in, N, Tlen, d, base, pos0, inverse);
  else
    rope_apply<double>(out, in, N, Tlen, d, base, pos0, inverse);
  return out;
}

}  // namespace

// q (B,H,Tq,d), k/v (B,H,Tk,d), mask (B,Tk) -> out (B,H,Tq,d); att (B,H,Tq,Tk) saved.
// dq = dS k, dk = dS^T q, dv = P^T g with dS = P * (g v^T - rowsum(P * g v^T)) / sqrt(d)   (in the kernel)
Variable attention(const Variable& q, const Variable& k, const Variable& v, const Tensor& key_mask, bool causal) {
  const fused::AttentionShape s = attention_shape(q.data(), k.data(), v.data(), key_mask, causal);
  const Tensor qc = q.data().contiguous(), kc = k.data().contiguous(), vc = v.data().contiguous();
  const DType dt = qc.dtype();
  Tensor mask;
  if (key_mask.defined()) mask = key_mask.to(dt).contiguous();
  Tensor out = Tensor::empty({s.B, s.H, s.Tq, s.d}, dt);
  Tensor att = Tensor::empty({s.B, s.H, s.Tq, s.Tk}, dt);
  if (dt == DType::f32)
    attention_fwd<float>(out, att, qc, kc, vc, mask, s);
  else
    attention_fwd<double>(out, att, qc, kc, vc, mask, s);
  return record("attention", out, {q, k, v},
                [qc, kc, vc, att, s](const Tensor& grad, const std::vector<bool>& need) {
                  const Tensor g = grad.contiguous();
                  Tensor dq, dk, dv;
                  if (need[0]) dq = Tensor::empty(qc.shape(), qc.dtype());
                  if (need[1]) dk = Tensor::empty(kc.shape(), kc.dtype());
                  if (need[2]) dv = Tensor::empty(vc.shape(), vc.dtype());
                  if (g.dtype() == DType::f32)
                    attention_bwd<float>(dq, dk, dv, g, att, qc, kc, vc, s);
                  else
                    attention_bwd<double>(dq, dk, dv, g, att, qc, kc, vc, s);
                  return std::vector<Tensor>{dq, dk, dv};
                });
}

// x (..., T, d) -> out (..., T, d): y[i] = x[i] cos - x[i+d/2] sin, y[i+d/2] = x[i] sin + x[i+d/2] cos;
// dx = the same with -angle.
Variable rope(const Variable& x, int64_t pos0, double base) {
  const Tensor& xd = x.data();
  if (xd.dim() < 2 || xd.size(-1) % 2 != 0 || xd.size(-1) < 2)
    throw Error("rope: x must be (..., T, d) with an even d >= 2, got " + shape_str(xd.shape()));
  if (!is_float(xd.dtype()))
    throw Error(std::string("rope: x must be float32 or float64, got ") + dtype_name(xd.dtype()));
  if (pos0 < 0) throw Error("rope: pos0 must be >= 0, got " + std::to_string(pos0));
  if (!(base > 0.0)) throw Error("rope: base must be > 0, got " + std::to_string(base));
  Tensor out = rope_rotate(xd.contiguous(), pos0, base, /*inverse=*/false);
  return record("rope", out, {x}, [pos0, base](const Tensor& g, const std::vector<bool>&) {
    return std::vector<Tensor>{rope_rotate(g.contiguous(), pos0, base, /*inverse=*/true)};
  });
}

}  // namespace t2m::ag

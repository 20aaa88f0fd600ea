// ops_conv.cpp — forward/backward pairs of conv1d (fused im2col + GEMM kernel) and upsample_nearest1d, plus the
// explicit zero-pad step for asymmetric zero padding.
#include "autograd/ops_conv.h"

#include <cstring>
#include <string>

#include "autograd/node.h"
#include "tensor/fused/conv1d.h"
#include "tensor/fused/upsample_nearest1d.h"

namespace t2m::ag {

namespace {

bool is_float(DType d) { return d == DType::f32 || d == DType::f64; }

template <typename T>
T* ptr(Tensor& t) { return t.defined() ? t.data<T>() : nullptr; }
template <typename T>
const T* cptr(const Tensor& t) { return t.defined() ? t.data<T>() : nullptr; }

// x (N, T) rows -> out (N, left + T + right) with zero frames around; backward: the middle columns of g.
Variable pad_zeros_time(const Variable& x, int64_t left, int64_t right) {
  const Tensor xc = x.data().contiguous();
  const int64_t T = xc.size(-1), N = xc.numel() / T, To = left + T + right;
  const size_t es = dtype_size(xc.dtype());
  Shape os = xc.shape();
  os.back() = To;
  Tensor out = Tensor::zeros(os, xc.dtype());
  if (N == 0) return record("conv1d_pad_zeros", out, {x}, [xs = xc.shape()](const Tensor& g, const std::vector<bool>&) {
    return std::vector<Tensor>{Tensor::zeros(xs, g.dtype())};
  });
  const char* src = static_cast<const char*>(xc.storage()->data) + xc.offset() * es;
  char* dst = static_cast<char*>(out.storage()->data);
  for (int64_t n = 0; n < N; ++n) std::memcpy(dst + (n * To + left) * es, src + n * T * es, (size_t)T * es);
  return record("conv1d_pad_zeros", out, {x}, [left, T](const Tensor& g, const std::vector<bool>&) {
    return std::vector<Tensor>{g.narrow(-1, left, T).contiguous()};
  });
}

template <typename T>
void conv_fwd(Tensor& out, const Tensor& x, const Tensor& w, const Tensor& b, const fused::Conv1dShape& s) {
  fused::conv1d_forward<T>(out.data<T>(), x.data<T>(), w.data<T>(), cptr<T>(b), s);
}

template <typename T>
void conv_bwd(Tensor& dx, Tensor& dw, Tensor& db, const Tensor& g, const Tensor& x, const Tensor& w,
              const fused::Conv1dShape& s) {
  fused::conv1d_backward<T>(ptr<T>(dx), ptr<T>(dw), ptr<T>(db), g.data<T>(), cptr<T>(x), cptr<T>(w), s);
}

}  // namespace

// x (B, Cin, T), w (Cout, Cin, K), b (Cout) -> out (B, Cout, To). Saves x when w needs a gradient, w when x does.
Variable conv1d(const Variable& x, const Variable& weight, const Variable& bias, int64_t stride, int64_t dilation,
                Conv1dPadding padding) {
  auto fail = [&](const std::string& what) {
    throw Error("conv1d: " + what + " (x " + shape_str(x.shape()) + ", weight " + shape_str(weight.shape()) +
                (bias.defined() ? ", bias " + shape_str(bias.shape()) : "") + ")");
  };
  if (x.dim() != 3) fail("x must be 3-D (B, Cin, T)");
  if (weight.dim() != 3) fail("weight must be 3-D (Cout, Cin, K)");
  if (weight.size(1) != x.size(1)) fail("weight's Cin differs from x's");
  if (bias.defined() && (bias.dim() != 1 || bias.size(0) != weight.size(0))) fail("bias must be (Cout)");
  const DType dt = x.dtype();
  if (!is_float(dt) || weight.dtype() != dt || (bias.defined() && bias.dtype() != dt))
    fail(std::string("x, weight, bias must share a float dtype, got ") + dtype_name(dt) + " and " +
         dtype_name(weight.dtype()));
  if (stride < 1 || dilation < 1)
    fail("stride and dilation must be >= 1, got " + std::to_string(stride) + ", " + std::to_string(dilation));
  const bool causal = padding.mode == Conv1dPadding::Mode::causal_replicate;
  if ((!causal && padding.left < 0) || padding.right < 0)
    fail("padding must be >= 0, got left " + std::to_string(padding.left) + ", right " +
         std::to_string(padding.right));
  if (causal && padding.right != 0) fail("causal padding has no right side, got right " + std::to_string(padding.right));
  Variable xin = x;
  fused::Conv1dShape s;
  const int64_t K = weight.size(2);
  if (causal) {
    const int64_t left = padding.left < 0 ? (K - 1) * dilation : padding.left;
    if (left > 0) {
      s.causal = true;  // the kernel's own replicate padding
      s.causal_left = left;
      s.exact_causal = padding.exact;
    }
  } else if (padding.left == padding.right) {
    s.pad = padding.left;
  } else if (x.size(2) >= 1) {
    xin = pad_zeros_time(x, padding.left, padding.right);
  }
  s.B = xin.size(0);
  s.Cin = xin.size(1);
  s.T = xin.size(2);
  s.Cout = weight.size(0);
  s.K = K;
  s.stride = stride;
  s.dilation = dilation;
  int64_t To = 0;
  try {
    To = s.out_len();
  } catch (const Error& e) {
    std::string why = e.what();
    if (why.rfind("conv1d: ", 0) == 0) why = why.substr(8);
    fail(why + ", stride " + std::to_string(stride) + ", dilation " + std::to_string(dilation));
  }
  const Tensor xc = xin.data().contiguous(), wc = weight.data().contiguous();
  const Tensor bc = bias.defined() ? bias.data().contiguous() : Tensor();
  Tensor out = Tensor::empty({s.B, s.Cout, To}, dt);
  if (s.B > 0) {
    if (dt == DType::f32)
      conv_fwd<float>(out, xc, wc, bc, s);
    else
      conv_fwd<double>(out, xc, wc, bc, s);
  }
  std::vector<Variable> vars{xin, weight};
  if (bias.defined()) vars.push_back(bias);
  const Tensor sx = weight.requires_grad() ? xc : Tensor(), sw = xin.requires_grad() ? wc : Tensor();
  const bool has_bias = bias.defined();
  return record("conv1d", out, vars, [sx, sw, s, has_bias, dt](const Tensor& grad, const std::vector<bool>& need) {
    const Tensor g = grad.contiguous();
    Tensor dx, dw, db;
    if (need[0]) dx = Tensor::empty({s.B, s.Cin, s.T}, dt);
    if (need[1]) dw = Tensor::zeros({s.Cout, s.Cin, s.K}, dt);
    if (has_bias && need[2]) db = Tensor::zeros({s.Cout}, dt);
    if (s.B > 0) {
      if (dt == DType::f32)
        conv_bwd<float>(dx, dw, db, g, sx, sw, s);
      else
        conv_bwd<double>(dx, dw, db, g, sx, sw, s);
    }
    std::vector<Tensor> r{dx, dw};
    if (has_bias) r.push_back(db);
    return r;
  });
}

// x (B, C, T) -> out (B, C, T*scale).
Variable upsample_nearest1d(const Variable& x, int64_t scale) {
  if (x.dim() != 3 || x.size(2) < 1)
    throw Error("upsample_nearest1d: x must be (B, C, T) with T >= 1, got " + shape_str(x.shape()));
  if (!is_float(x.dtype()))
    throw Error(std::string("upsample_nearest1d: x must be f32 or f64, got ") + dtype_name(x.dtype()));
  if (scale < 1) throw Error("upsample_nearest1d: scale must be >= 1, got " + std::to_string(scale));
  const Tensor xc = x.data().contiguous();
  const int64_t B = xc.size(0), C = xc.size(1), T = xc.size(2), N = B * C;
  Tensor out = Tensor::empty({B, C, T * scale}, xc.dtype());
  if (N > 0) {
    if (xc.dtype() == DType::f32)
      fused::upsample_nearest1d_forward<float>(out.data<float>(), xc.data<float>(), N, T, scale);
    else
      fused::upsample_nearest1d_forward<double>(out.data<double>(), xc.data<double>(), N, T, scale);
  }
  return record("upsample_nearest1d", out, {x}, [B, C, T, N, scale](const Tensor& grad, const std::vector<bool>&) {
    const Tensor g = grad.contiguous();
    Tensor dx = Tensor::empty({B, C, T}, g.dtype());
    if (N == 0) return std::vector<Tensor>{dx};
    if (g.dtype() == DType::f32)
      fused::upsample_nearest1d_backward<float>(dx.data<float>(), g.data<float>(), N, T, scale);
    else
      fused::upsample_nearest1d_backward<double>(dx.data<double>(), g.data<double>(), N, T, scale);
    return std::vector<Tensor>{dx};
  });
}

}  // namespace t2m::ag

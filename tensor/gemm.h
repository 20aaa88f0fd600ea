// gemm.h — general matrix multiply, row-major: C = alpha * op(A) * op(B) + beta * C.
//
// op(A) is M×K (A is M×K, or K×M when trans_a), op(B) is K×N (B is K×N, or N×K when trans_b); lda/ldb/ldc are
// row strides in elements. float: our packed-panel kernel with an AVX-512 micro-kernel chosen at run time
// (AVX2+FMA fallback), OpenMP across blocks with work stealing between the threads (a thread that finishes its
// share takes the others' remaining panels). Results are bit-identical for any thread count and any steal order:
// every C tile is computed by one kernel call per K block from the same packed data. double: a blocked kernel
// (used by gradchecks; speed secondary).
// beta == 0 means C is written without being read (NaNs in C do not propagate).
#pragma once
#include <cstdint>

namespace t2m {

void gemm(bool trans_a, bool trans_b, int64_t M, int64_t N, int64_t K, float alpha, const float* A, int64_t lda,
          const float* B, int64_t ldb, float beta, float* C, int64_t ldc);
void gemm(bool trans_a, bool trans_b, int64_t M, int64_t N, int64_t K, double alpha, const double* A, int64_t lda,
          const double* B, int64_t ldb, double beta, double* C, int64_t ldc);

// C = alpha * op(A) op(B) + 1 bias^T: bias (length N) added to every row of C, C written without being read (the
// forward of a linear layer, with the bias joining in the GEMM's final store instead of a pass of its own). Each
// element is fma(alpha, acc, bias[j]) where acc is the element's dot product, the same bits as filling C with the
// bias rows and calling gemm with beta = 1 (alpha = 1). bias may be null (then it is gemm with beta = 0).
void gemm_bias(bool trans_a, bool trans_b, int64_t M, int64_t N, int64_t K, float alpha, const float* A, int64_t lda,
               const float* B, int64_t ldb, const float* bias, float* C, int64_t ldc);
void gemm_bias(bool trans_a, bool trans_b, int64_t M, int64_t N, int64_t K, double alpha, const double* A,
               int64_t lda, const double* B, int64_t ldb, const double* bias, double* C, int64_t ldc);

// C = max(alpha * op(A) op(B) + 1 bias^T, 0): gemm_bias followed by a ReLU (x < 0 ? 0 : x, so NaN and -0 stay),
// applied to each C tile as its last K block is stored, while the tile is still in L1 (the forward of a linear
// layer followed by ReLU). The same bits as gemm_bias then a ReLU pass. bias may be null.
void gemm_bias_relu(bool trans_a, bool trans_b, int64_t M, int64_t N, int64_t K, float alpha, const float* A,
                    int64_t lda, const float* B, int64_t ldb, const float* bias, float* C, int64_t ldc);
void gemm_bias_relu(bool trans_a, bool trans_b, int64_t M, int64_t N, int64_t K, double alpha, const double* A,
                    int64_t lda, const double* B, int64_t ldb, const double* bias, double* C, int64_t ldc);

// C = alpha * op(A) op(B) (beta = 0) for a C written once and not read again soon, e.g. a weight gradient, next
// read by the optimizer after the whole backward pass. When C is at least as large as the L2, K fits one kernel
// block (512) and C's rows are 64-byte aligned (float only), its full tiles go to memory with non-temporal stores: no
// read for ownership of C's lines, and the operands stay in cache. Otherwise it is gemm. The same bits as gemm with
// beta = 0. Returns whether the non-temporal stores were used.
bool gemm_stream(bool trans_a, bool trans_b, int64_t M, int64_t N, int64_t K, float alpha, const float* A,
                 int64_t lda, const float* B, int64_t ldb, float* C, int64_t ldc);
// The L2 size the GEMM's choices go by (sysconf, at least 256 KB): the C size from which gemm_stream streams, and
// (from 2 MB) the two-K-block packing of large float products.
int64_t gemm_l2_bytes();
bool gemm_stream(bool trans_a, bool trans_b, int64_t M, int64_t N, int64_t K, double alpha, const double* A,
                 int64_t lda, const double* B, int64_t ldb, double* C, int64_t ldc);

// Batched: for b in [0, batch): C_b = alpha * op(A_b) op(B_b) + beta * C_b with A_b = A + b*stride_a, etc.
// A stride of 0 broadcasts one matrix over the batch. Threads split across the batch or within each GEMM.
void gemm_batched(bool trans_a, bool trans_b, int64_t batch, int64_t M, int64_t N, int64_t K, float alpha,
                  const float* A, int64_t lda, int64_t stride_a, const float* B, int64_t ldb, int64_t stride_b,
                  float beta, float* C, int64_t ldc, int64_t stride_c);
void gemm_batched(bool trans_a, bool trans_b, int64_t batch, int64_t M, int64_t N, int64_t K, double alpha,
                  const double* A, int64_t lda, int64_t stride_a, const double* B, int64_t ldb, int64_t stride_b,
                  double beta, double* C, int64_t ldc, int64_t stride_c);

// Columns stored in segments: column c of a matrix lies at column (c / len) * stride + c % len of its row (the row
// stride ld applies within a segment); len == 0: plain, column c at c. E.g. a (B, C, T) tensor read as one
// C x (B T) matrix, column b T + t: ld T, len T, stride C T. A convolution multiplies every sample's (C, T) slice
// at once this way, without copying the samples side by side first.
struct GemmColumns {
  int64_t len = 0, stride = 0;
};

// gemm where each stored matrix may keep its columns in segments: A's stored columns are op(A)'s K (its M when
// trans_a), B's are op(B)'s N (its K when trans_b), C's are N. The same packed data and kernel calls as gemm on
// the gathered plain matrices, so the same bits, except for the shapes gemm computes without packing (a dimension
// <= 2, or M N K <= 24^3), which run packed here. lda/ldb/ldc must hold one segment's row (>= len when len < the
// column count). Errors: as gemm, plus len < 0, or len > 0 with stride < 1.
void gemm_segmented(bool trans_a, bool trans_b, int64_t M, int64_t N, int64_t K, float alpha, const float* A,
                    int64_t lda, GemmColumns a_cols, const float* B, int64_t ldb, GemmColumns b_cols, float beta,
                    float* C, int64_t ldc, GemmColumns c_cols);
void gemm_segmented(bool trans_a, bool trans_b, int64_t M, int64_t N, int64_t K, double alpha, const double* A,
                    int64_t lda, GemmColumns a_cols, const double* B, int64_t ldb, GemmColumns b_cols, double beta,
                    double* C, int64_t ldc, GemmColumns c_cols);

// Which float micro-kernel the dispatcher picked on this CPU: "avx512" or "avx2".
const char* gemm_kernel_name();
// Force a kernel (for tests/benchmarks): "avx512", "avx2" or "auto". Throws Error if the CPU lacks it.
void gemm_force_kernel(const char* name);
// How many of the kernel's K blocks are packed at once (float): when 0 (the default) 1, or 2 for products of more
// than one row block on a CPU with 2 MB of L2 or more; else `blocks` (1-8; Error otherwise). It changes no bit of
// any result (each K block is still one kernel call with the same C update); tests and benchmarks compare depths.
// Returns the automatic depth of products of more than one row block on this CPU.
int gemm_force_pack_depth(int blocks);
// How the float kernel reads op(A) = A (not transposed, not in segments): "auto" (the default: in place when each
// thread meets at most 512 columns of C, there is more than one row block and A's rows are not a multiple of 4 KB
// apart, else packed), "packed" or "in_place" (wherever possible); Error for any other mode. It changes no bit of
// any result (the same FMAs in the same order); tests and benchmarks compare the modes. Returns how many products
// have read A in place so far.
int64_t gemm_force_read_a(const char* mode);

}  // namespace t2m

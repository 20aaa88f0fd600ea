// parallel.cpp — process-wide thread count over OpenMP.
#include "tensor/parallel.h"

#include <omp.h>

#include "tensor/tensor.h"

namespace t2m {

void set_num_threads(int n) {
  if (n < 1) throw Error("set_num_threads: thread count must be >= 1, got " + std::to_string(n));
  omp_set_num_threads(n);
}

int get_num_threads() { return omp_get_max_threads(); }

}  // namespace t2m

// no_grad.cpp — the thread-local grad-mode flag.
#include "autograd/no_grad.h"

namespace t2m::ag {

namespace {
thread_local bool g_grad_enabled = true;
}

bool GradMode::is_enabled() { return g_grad_enabled; }
void GradMode::set_enabled(bool enabled) { g_grad_enabled = enabled; }

}  // namespace t2m::ag

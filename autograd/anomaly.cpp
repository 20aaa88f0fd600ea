// anomaly.cpp — the thread-local anomaly-mode flag (the checks themselves are in engine.cpp).
#include "autograd/anomaly.h"

namespace t2m::ag {

namespace {
thread_local bool g_anomaly_enabled = false;
}

bool AnomalyMode::is_enabled() { return g_anomaly_enabled; }
void AnomalyMode::set_enabled(bool enabled) { g_anomaly_enabled = enabled; }

}  // namespace t2m::ag

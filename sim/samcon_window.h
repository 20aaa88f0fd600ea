// samcon_window.h — internal to sim/samcon*.cpp: what a SAMCON candidate does in one control step and how a
// simulated frame is scored against the reference (shared by the beam search and the receding-horizon search).
#pragma once
#include <vector>

#include "sim/balance_tracker.h"
#include "sim/env.h"

namespace t2m::sim::samcon_detail {

// One control step towards reference frame t: the balance expert's targets plus `offset` [nu] (rad), clamped to
// the actuator ranges and written to ctrl [nu]; the env advances.
void step_with_offset(Env& env, const QposTrajectory& ref, const BalanceReference& bref, const BalanceOptions& bo,
                      int t, const double* offset, double* ctrl);

// mean_j |p_sim,j - p_ref,j|² over the tracked bodies of the env's current state against ref_pos [J, 3] (one
// reference frame); the largest |p_sim,j - p_ref,j| in *worst.
double frame_cost(const mjData* d, const std::vector<int>& bodies, const float* ref_pos, double* worst);

}  // namespace t2m::sim::samcon_detail

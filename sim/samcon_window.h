// samcon_window.h — internal to sim/samcon*.cpp: what the beam search (samcon.h) and the receding-horizon search
// (samcon_mpc.h) share: the search context, one candidate's simulation through a window, one control step with a
// target offset (all defined in samcon.cpp).
#pragma once
#include <memory>
#include <vector>

#include "sim/balance_tracker.h"
#include "sim/env.h"

namespace t2m::sim::samcon_detail {

// What every candidate reads: the reference's balance quantities and body positions, the expert's options (its
// action noise cleared) and one env per thread (t2m::get_num_threads()) to simulate candidates in.
struct SearchContext {
  BalanceReference bref;
  std::vector<float> ref_pos;  // [T, J, 3]
  std::vector<int> bodies;     // the J tracked bodies
  BalanceOptions bo;
  std::vector<std::unique_ptr<Env>> envs;
};

// Checks that h is our humanoid and ref matches it (errors name `who`), then builds the context.
SearchContext make_search_context(const char* who, const std::shared_ptr<const Humanoid>& h,
                                  const QposTrajectory& ref, const BalanceOptions& bo);

// A candidate: `steps` control steps from the env's current state towards frames t+1 .. t+steps with the offset
// [nu] held. Returns the sum over steps of mean_j |p_sim,j - p_ref,j|² (the tracked bodies); *worst = the largest
// body error on any step (infinite on divergence).
double simulate_candidate(Env& env, const SearchContext& c, const QposTrajectory& ref, int t, int steps,
                          const double* offset, double* worst);

// One control step towards reference frame t: the balance expert's targets plus `offset` [nu] (rad), clamped to
// the actuator ranges and written to ctrl [nu]; the env advances.
void step_with_offset(Env& env, const QposTrajectory& ref, const BalanceReference& bref, const BalanceOptions& bo,
                      int t, const double* offset, double* ctrl);

}  // namespace t2m::sim::samcon_detail

// position_ik.h — joint rotations of the canonical skeleton from joint positions (inverse kinematics by bone
// directions), for motions known only by their positions (e.g. generated pose features whose rotation channels
// cannot be trusted, see docs/CASIM.md "Known defect").
//
// Input: pos [T, 21, 3] world joint positions (metres, Z up), offsets [21, 3] rest offsets of the skeleton the
// rotations are for (sim::Motion convention: pos_child = pos_j + W_j offset_child, W_j = W_parent rot_j).
// Per frame and joint j, in joint order, the world rotation W_j is chosen to point j's bones at its children:
//   >= 2 children (Hips, Chest): W_j = argmin_W sum_c |W ô_c - d̂_c|^2 over rotations (Kabsch/Wahba on unit
//                                 vectors ô_c = offsets[c] / |.|, d̂_c = (pos_c - pos_j) / |.|);
//   1 child:                      W_j = S W_prior, S the smallest rotation taking W_prior ô_c to d̂_c, with
//                                 W_prior = W_parent Wref_parent^-1 Wref_j (the reference pose's local rotation;
//                                 identity when no reference is given: no twist relative to the parent's frame);
//   no child (Head, Hands, Toes): W_j = W_prior.
// Output: local rotations [T, 21, 4] (w, x, y, z), w >= 0: rot_0 = W_0, rot_j = W_parent^-1 W_j.
// For positions made by FK of the same offsets (bone lengths may differ), FK of the result reproduces every bone
// direction of joints with one child exactly and of multi-child joints in the least-squares sense. Twist about a
// single bone is not observable from positions: it is the parent's.
// Errors: t2m::Error on sizes (pos not T*63 with T >= 1, offsets not 63) or non-finite positions.
#pragma once
#include <vector>

namespace t2m::sim {

// ref_world_rot: optional [21, 4] (w, x, y, z) world rotations of the joints in a reference pose (the humanoid's:
// sim::rest_world_rot), which sets the twist of single-child joints; empty = identity local rotations.
std::vector<float> rotations_from_positions(const std::vector<float>& pos, const std::vector<float>& offsets,
                                            const std::vector<float>& ref_world_rot = {});

}  // namespace t2m::sim

// replay_buffer.h — the FB agent's transition store: a fixed-capacity ring of float32 rows
//   obs [D], action [A], next_obs [D], not_done (1 = s' continues the episode, 0 = terminal), plus where the
//   transition came from: clip index and frame index of the reference motion (-1 when none), so z can be
//   inferred from the reference window that the transition was tracking (Eq 2).
// Optional expert labels (with_expert_labels): per row also the action the expert tracker would take in that
// state (models/bfm/collect.h), the behaviour-cloning target for states the policy visited (DAgger).
// Once full, new rows overwrite the oldest (ring cursor). Sampling is uniform over the rows held, with indices
// drawn from a t2m::Generator (Philox: the same seed and state give the same batch for any thread count).
//
//   ReplayBuffer buf(200000, 313, 60);
//   buf.add(obs, act, next_obs, 1.0f, clip, frame);             // copies one row
//   ReplayBatch b = buf.sample(256, gen);                        // obs [256, D], action [256, A], ...
//   buf.save(path); ReplayBuffer r = ReplayBuffer::load(path);   // atomic (nn::Checkpoint, CRC-checked)
//
// Storage is preallocated in the constructor (Tensors [capacity, ...]); add() and sample_into() allocate nothing.
// File: nn::Checkpoint with tensors obs, action, next_obs [size, D|A] f32, not_done [size] f32, clip, frame [size]
// i64, expert_action [size, A] f32 when labelled, and meta {"format": "t2m-replay-1", "capacity", "size", "cursor",
// "obs_dim", "action_dim", "added", "expert_labels"} ("expert_labels" absent = false).
// Errors (t2m::Error, "replay buffer: ..." / "replay buffer PATH: ..."): capacity < 1 or dims < 1; a sample from an
// empty buffer or n < 1; a non-finite value in add(); on load: a missing/corrupt file, wrong format tag, sizes that
// do not agree (size > capacity, cursor out of range, tensor shapes), non-finite values, not_done outside {0, 1}.
#pragma once
#include <cstdint>
#include <functional>
#include <string>

#include "tensor/rng.h"
#include "tensor/tensor.h"

namespace t2m::bfm {

struct ReplayBatch {
  Tensor obs;       // [n, D] f32
  Tensor action;    // [n, A] f32
  Tensor next_obs;  // [n, D] f32
  Tensor not_done;  // [n, 1] f32
  Tensor clip;      // [n] i64
  Tensor frame;     // [n] i64
  Tensor expert_action;  // [n, A] f32, filled (allocated on first use) only by a buffer with expert labels
};

class ReplayBuffer {
 public:
  ReplayBuffer(int64_t capacity, int obs_dim, int action_dim, bool with_expert_labels = false);
  ReplayBuffer(ReplayBuffer&&) = default;
  ReplayBuffer& operator=(ReplayBuffer&&) = default;
  ReplayBuffer(const ReplayBuffer&) = delete;  // the storage tensors are handles: a copy would alias
  ReplayBuffer& operator=(const ReplayBuffer&) = delete;

  int64_t capacity() const { return capacity_; }
  int64_t size() const { return size_; }
  int64_t cursor() const { return cursor_; }   // the row the next add() writes
  int64_t added() const { return added_; }     // rows ever added (>= size once full)
  int obs_dim() const { return obs_dim_; }
  int action_dim() const { return action_dim_; }
  bool has_expert_labels() const { return labels_; }

  // expert_action [A]: required by a buffer with expert labels, refused (Error) by one without.
  void add(const float* obs, const float* action, const float* next_obs, float not_done, int64_t clip = -1,
           int64_t frame = -1, const float* expert_action = nullptr);
  void clear();

  // n rows drawn uniformly with replacement (one randint draw of n counters' worth from gen).
  ReplayBatch sample(int64_t n, Generator& gen) const;
  // The same into preallocated tensors of the right shapes (reuses their storage).
  void sample_into(int64_t n, Generator& gen, ReplayBatch& out) const;
  // n rows drawn uniformly with replacement among the rows with keep(row) true: rounds of n draws as in
  // sample_into, the accepted rows kept in draw order until n are accepted. Gives up (returns false, out
  // unchanged) after 64 rounds in a row without an accepted row.
  bool sample_where_into(int64_t n, Generator& gen, const std::function<bool(int64_t row)>& keep,
                         ReplayBatch& out) const;
  // Rows by index (each in [0, size)), e.g. for tests.
  void gather(const int64_t* index, int64_t n, ReplayBatch& out) const;

  // Row views (read-only use): row i of each array.
  const float* obs_row(int64_t i) const;
  const float* action_row(int64_t i) const;
  const float* next_obs_row(int64_t i) const;
  float not_done_at(int64_t i) const;
  int64_t clip_at(int64_t i) const;
  int64_t frame_at(int64_t i) const;
  const float* expert_action_row(int64_t i) const;  // Error without expert labels

  void save(const std::string& path) const;
  static ReplayBuffer load(const std::string& path);

 private:
  void check_row(int64_t i) const;
  void draw_rows(int64_t n, Generator& gen, int64_t* idx) const;  // n uniform row indices (checks n, size)
  int64_t capacity_;
  int obs_dim_, action_dim_;
  int64_t size_ = 0, cursor_ = 0, added_ = 0;
  bool labels_ = false;
  Tensor obs_, action_, next_obs_, not_done_, clip_, frame_, expert_action_;
};

// Allocates the tensors of a batch of n rows.
ReplayBatch make_replay_batch(int64_t n, int obs_dim, int action_dim);

}  // namespace t2m::bfm

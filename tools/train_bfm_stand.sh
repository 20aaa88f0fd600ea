#!/usr/bin/env bash
# Reproduces models/checkpoints/bfm_stand.t2mckpt, the pipeline's BFM (docs/BFM.md "Session 47"): the shipped
# bfm_distill fine-tuned on z searches that start STANDING (qpos0 at rest, where every generation starts;
# `t2m train bfm-distill --standing-start`), in DAgger rounds on disjoint sixths of the raise-up training clips:
# s1 searches bfm_distill on every 6th clip from 0 and fits on its rows; s2 searches s1's policy on every 6th clip
# from 3 and fits s1's actor on the rows of both. Anchor rows (400 train clips of the other contents, plain rollouts
# from their first state) keep the rest as it was. B is untouched: the latent space, and so the VBB and generators
# trained on bfm_distill, stay valid.
# Resumable: run it again after a stop (search chunks and round policies under $T2M_CACHE/bfm/distill_rounds,
# default ~/.cache/t2m). Deterministic for the thread count (2 here). About 20-25 min of search per round on 2 cores.
# Usage: bash tools/train_bfm_stand.sh [OUT (default models/checkpoints/bfm_stand.t2mckpt)] [ROUNDS (default 2; 1..2)]
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-models/checkpoints/bfm_stand.t2mckpt}
rounds=${2:-2}
if ! [[ "$rounds" =~ ^[1-2]$ ]]; then echo "train_bfm_stand.sh: ROUNDS must be 1 or 2, got '$rounds'" >&2; exit 2; fi
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
bash tools/setup.sh >/dev/null
dir=${T2M_CACHE:-$HOME/.cache/t2m}/bfm/distill_rounds
mkdir -p "$dir"
policy=models/checkpoints/bfm_distill.t2mckpt
with=()
offsets=(0 3)
for ((k = 1; k <= rounds; ++k)); do
  name=s$k
  if [[ ! -f "$dir/$name.t2mckpt" ]]; then
    # A round whose search stops early (a cut-off session) writes no policy; running the script again resumes it.
    ./build/t2m train bfm-distill --policy "$policy" --out "$dir/$name" --contents raise-up --every 6 \
      --offset "${offsets[k - 1]}" --standing-start --threads 2 "${with[@]}" --export "$dir/$name.t2mckpt"
  fi
  [[ -f "$dir/$name.t2mckpt" ]] || { echo "train_bfm_stand.sh: round $name did not finish" >&2; exit 1; }
  policy=$dir/$name.t2mckpt
  with+=(--with-rows "$dir/$name")
done
cp "$policy" "$out.tmp" && mv "$out.tmp" "$out"
echo "wrote $out ($rounds standing rounds; rows and round policies in $dir)"

#!/usr/bin/env bash
# Reproduces models/checkpoints/bfm_distill.t2mckpt: rounds of `t2m train bfm-distill` (docs/BFM.md, sessions 27-28).
# Round 1 searches bfm_track on every 6th raise-up / wave training clip and fits the actor to the searched actions;
# each later round searches with the previous round's policy on another disjoint sixth of those clips (the
# student's own states, DAgger) and fits on the rows of every round so far. Resumable: run it again after a stop;
# finished search chunks and rounds are kept under $T2M_CACHE/bfm/distill_rounds (default ~/.cache/t2m).
# Deterministic for the thread count (2 here). About 40-100 min of search per round on 2 cores.
# Wave rounds (session 29) follow: the same, on every 3rd wave training clip only (offsets 0, 1, 2), which weights the
# clips the policy still falls on most. Raise rounds (session 31) follow those: every 6th raise-up training clip
# (offsets 2, 4, 0 of the raise-up clips alone). Late rounds (session 32) alternate after those: w4 = every 6th wave
# clip from 0, ra4 = every 6th raise-up clip from 1, w5 = every 6th wave clip from 3.
# Usage: bash tools/train_bfm_distill.sh [OUT (default models/checkpoints/bfm_distill.t2mckpt)] [ROUNDS (default 3)]
#            [LAST_CHUNKS (default 0: all; the last round run, wave and raise rounds included, searches and fits only
#             its first LAST_CHUNKS chunks of 40)] [WAVE_ROUNDS (default 0; at most 3)] [RAISE_ROUNDS (default 0; at
#             most 3; they need ROUNDS 4 and WAVE_ROUNDS 3)] [LATE_ROUNDS (default 0; at most 3; they need
#             RAISE_ROUNDS 3)]
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-models/checkpoints/bfm_distill.t2mckpt}
rounds=${2:-3}
last_chunks=${3:-0}
wave_rounds=${4:-0}
raise_rounds=${5:-0}
late_rounds=${6:-0}
offsets=(0 3 1 5 2 4)  # round k searches clips offsets[k-1], offsets[k-1] + 6, ... of the name-ordered selection
if ! [[ "$rounds" =~ ^[1-6]$ ]]; then echo "train_bfm_distill.sh: ROUNDS must be 1..6, got '$rounds'" >&2; exit 2; fi
if ! [[ "$last_chunks" =~ ^[0-6]$ ]]; then
  echo "train_bfm_distill.sh: LAST_CHUNKS must be 0..6, got '$last_chunks'" >&2
  exit 2
fi
if ! [[ "$wave_rounds" =~ ^[0-3]$ ]]; then
  echo "train_bfm_distill.sh: WAVE_ROUNDS must be 0..3, got '$wave_rounds'" >&2
  exit 2
fi
if ! [[ "$raise_rounds" =~ ^[0-3]$ ]] || ((raise_rounds > 0 && (rounds != 4 || wave_rounds != 3))); then
  echo "train_bfm_distill.sh: RAISE_ROUNDS must be 0..3, and 1..3 only after 4 rounds and 3 wave rounds, got" \
    "'$raise_rounds'" >&2
  exit 2
fi
if ! [[ "$late_rounds" =~ ^[0-3]$ ]] || ((late_rounds > 0 && raise_rounds != 3)); then
  echo "train_bfm_distill.sh: LATE_ROUNDS must be 0..3, and 1..3 only after 3 raise rounds, got '$late_rounds'" >&2
  exit 2
fi
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
bash tools/setup.sh >/dev/null
dir=${T2M_CACHE:-$HOME/.cache/t2m}/bfm/distill_rounds
mkdir -p "$dir"
policy=models/checkpoints/bfm_track.t2mckpt
with=()
total=$((rounds + wave_rounds + raise_rounds + late_rounds)) run=0
# next_round NAME FLAGS...: the next round in order (search, then fit on its rows and every earlier round's; rows in
# $dir/NAME). The last one run takes LAST_CHUNKS (its policy file is then NAME_cN).
next_round() {
  local name=$1 file=$1
  shift
  run=$((run + 1))
  local part=()
  if ((run == total && last_chunks > 0)); then part=(--max-chunks "$last_chunks") file=${name}_c$last_chunks; fi
  if [[ ! -f "$dir/$file.t2mckpt" ]]; then
    # A round whose search stops early (a cut-off session) writes no policy; running the script again resumes it.
    ./build/t2m train bfm-distill --policy "$policy" --out "$dir/$name" "$@" "${part[@]}" "${with[@]}" --threads 2 \
      --export "$dir/$file.t2mckpt"
  fi
  [[ -f "$dir/$file.t2mckpt" ]] || { echo "train_bfm_distill.sh: round $name did not finish" >&2; exit 1; }
  policy=$dir/$file.t2mckpt
  with+=(--with-rows "$dir/$name")
}
# (--offset 0 is the default and stays out of a round's config.json, so passing it changes nothing.)
for ((k = 1; k <= rounds; ++k)); do
  next_round "r$k" --every 6 --offset "${offsets[k - 1]}"
done
for ((w = 1; w <= wave_rounds; ++w)); do
  next_round "w$w" --contents wave --every 3 --offset $((w - 1))
done
raise_offsets=(2 4 0)
for ((r = 1; r <= raise_rounds; ++r)); do
  next_round "ra$r" --contents raise-up --every 6 --offset "${raise_offsets[r - 1]}"
done
late=("w4 --contents wave --every 6 --offset 0" "ra4 --contents raise-up --every 6 --offset 1"
  "w5 --contents wave --every 6 --offset 3")
for ((l = 0; l < late_rounds; ++l)); do
  # shellcheck disable=SC2086  # the entries are word lists: NAME FLAGS...
  next_round ${late[l]}
done
cp "$policy" "$out.tmp" && mv "$out.tmp" "$out"
echo "wrote $out ($rounds rounds, $wave_rounds wave rounds, $raise_rounds raise rounds, $late_rounds late rounds; rows and round policies in $dir)"

#!/usr/bin/env python3
"""side_by_side_rounds.py — optional measuring aid (never run by tests or CI): runs one of the side-by-side scripts
(torch_fm_side_by_side.sh, torch_vae_side_by_side.sh, torch_fb_side_by_side.sh) several times back to back and
summarises, per config, the wall-clock ratio torch / ours of every round with its median, minimum and maximum.

Why: on the 2-vCPU VM the speed of either side drifts by +-20-30 % from minute to minute, so one round decides
nothing (fm-paper B256 Tm8 read 1.41x and 0.95x in consecutive rounds on 2026-12-03). Each round runs ours and then
PyTorch within a minute or two; the median over rounds is the figure the issue targets are judged by.

Usage: /usr/bin/python3 bench/side_by_side_rounds.py --rounds 5 -- bash bench/torch_fb_side_by_side.sh --threads 2
       (everything after -- is the round's command; T2M_OPENBLAS_ROOT and the like pass through the environment)
Prints each round's table as it comes, then the summary (with the fm table's FLOP bound: the ratio at which the
step's FLOPs alone, at this host's FMA peak, would run; a target above it cannot be met here); exits non-zero if a
round fails.
"""
import argparse, statistics, subprocess, sys, time


def parse_row(line):
    """(config, threads, ours_ms, torch_ms, ratio, bound) of one table row (bound: the fm table's FLOP bound, else
    None), or None for any other line."""
    tok = line.split()
    if len(tok) < 5 or not tok[0].startswith(("fm-", "vae", "fb-")) or not tok[3].isdigit():
        return None
    config, threads = " ".join(tok[:3]), int(tok[3])
    bound = None
    if "|" in line:  # fm / vae layout: config thr | ours ms ... | torch ms ... | ratio wall ratio cpu | ...
        parts = line.split("|")
        ours, torch, ratio = parts[1].split()[0], parts[2].split()[0], parts[3].split()[0]
        if len(parts) > 5:  # fm: ... | peak GF bound
            try:
                bound = float(parts[5].split()[1].rstrip("x"))
            except (IndexError, ValueError):
                bound = None
    else:  # fb layout: config thr ours_ms ours_cpu GF/s %peak torch_ms torch_cpu speed-up (no FLOP bound: the
        # anchor counts every forward FLOP x3 under grad, also for the critic parts that get no weight gradient)
        ours, torch, ratio = tok[4], tok[8], tok[10]
    try:
        return config, threads, float(ours), float(torch), float(ratio.rstrip("x")), bound
    except ValueError:  # a side that did not run prints nan or "-"
        return None


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--rounds", type=int, default=5)
    p.add_argument("cmd", nargs=argparse.REMAINDER, help="-- then the side-by-side command")
    a = p.parse_args()
    cmd = a.cmd[1:] if a.cmd[:1] == ["--"] else a.cmd
    if a.rounds < 1 or not cmd:
        p.error("need --rounds >= 1 and a command after --")
    rows = {}  # (config, threads) -> list of (ours, torch, ratio)
    for r in range(a.rounds):
        print(f"# round {r + 1}/{a.rounds} at {time.strftime('%H:%M:%S', time.gmtime())} UTC: {' '.join(cmd)}",
              flush=True)
        out = subprocess.run(cmd, stdout=subprocess.PIPE, text=True)
        sys.stdout.write(out.stdout)
        if out.returncode != 0:
            sys.exit(f"side_by_side_rounds.py: round {r + 1} failed with exit status {out.returncode}")
        for line in out.stdout.splitlines():
            row = parse_row(line)
            if row:
                rows.setdefault(row[:2], []).append(row[2:])
    if not rows:
        sys.exit("side_by_side_rounds.py: no table rows found in the command's output")
    print(f"\n# summary over {a.rounds} rounds: wall ms per step, ratio = torch / ours (> 1: ours faster)")
    print("%-22s %3s | %-28s | %-28s | %-30s | %6s %6s %6s | %s" % ("config", "thr", "ours ms per round",
          "torch ms per round", "ratio per round", "median", "min", "max", "FLOP bound (median)"))
    for (config, th), v in rows.items():
        ratios = [x[2] for x in v]
        bounds = [x[3] for x in v if x[3] is not None and x[3] == x[3]]
        print("%-22s %3d | %-28s | %-28s | %-30s | %5.2fx %5.2fx %5.2fx | %s" % (
            config, th, " / ".join("%.1f" % x[0] for x in v), " / ".join("%.1f" % x[1] for x in v),
            " / ".join("%.2f" % x for x in ratios), statistics.median(ratios), min(ratios), max(ratios),
            "%.2fx" % statistics.median(bounds) if bounds else "-"))


if __name__ == "__main__":
    main()

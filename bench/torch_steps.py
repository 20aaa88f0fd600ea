#!/usr/bin/python3
"""torch_steps.py — measuring aid for bench/torch_{fm,vae}_side_by_side.sh (never run by tests or CI): times
torch_ref.py's own training steps (imported, not copied) the way torch_ref.py does: one model per config, `warmup`
untimed steps (the first is torch_ref's FLOP-counting step), then `steps` timed ones, wall and process CPU clocks.

    /usr/bin/python3 bench/torch_steps.py TORCH_REF THREADS STEPS WARMUP fm small:32x8,paper:32x16
    /usr/bin/python3 bench/torch_steps.py TORCH_REF THREADS STEPS WARMUP vae 32x64,256x128

Prints one line per config: "torch <config fields> <threads> <median wall ms> <median cpu ms> <GFLOP/s at the
median> <min wall ms>", the config fields being "size B Tm" (fm) or "B T" (vae). The caller sets the --best
environment (bench/torch_env.sh).
"""
import importlib.util
import sys
import time


def main():
    if len(sys.argv) != 7 or sys.argv[5] not in ("fm", "vae"):
        sys.exit("usage: torch_steps.py TORCH_REF THREADS STEPS WARMUP fm|vae CONFIGS")
    path, threads, steps, warmup, kind, configs = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), \
        int(sys.argv[4]), sys.argv[5], sys.argv[6].split(",")
    if steps < 1 or warmup < 1:
        sys.exit("torch_steps.py: STEPS and WARMUP must be >= 1")
    sys.argv = [path]
    spec = importlib.util.spec_from_file_location("torch_ref", path)
    tr = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tr)
    import torch
    torch.set_num_threads(threads)
    for c in configs:
        if kind == "fm":
            size, bt = c.split(":")
            b, tm = map(int, bt.split("x"))
            fields, make = [size, b, tm], lambda: tr.fm_case(size, b, tm)
        else:
            b, t = map(int, c.split("x"))
            fields, make = [b, t], lambda: tr.vae_case(b, t)
        torch.manual_seed(0)
        _, step = make()
        flops = tr.count_step_flops(step)  # the first warm-up step
        for _ in range(warmup - 1):
            step()
        cpu, wall = [], []
        for _ in range(steps):
            c0, w0 = time.process_time(), time.perf_counter()
            step()
            cpu.append(time.process_time() - c0)
            wall.append(time.perf_counter() - w0)
        cpu.sort()
        wall.sort()
        med = wall[len(wall) // 2]
        print("torch", *fields, threads, "%.2f" % (1e3 * med), "%.2f" % (1e3 * cpu[len(cpu) // 2]),
              "%.1f" % (flops / med * 1e-9), "%.2f" % (1e3 * wall[0]), flush=True)


if __name__ == "__main__":
    main()

#!/usr/bin/python3
"""torch_fb_cputime.py — measuring aid for bench/torch_fb_side_by_side.sh --mode cpu (never run by tests): times
the anchor's own fb_case (../shared/anchor/torch_ref.py, imported, not copied) by PROCESS CPU time per step
(all threads), which is far less inflated than wall time when other jobs share the machine.

    /usr/bin/python3 bench/torch_fb_cputime.py --threads 1 --configs 256:256:fb,1024:1024:both --steps 5

Prints one line per config: "fb-w256 B256 fb <threads> <median cpu_ms> <median wall_ms>". Run it with the --best
environment (OpenBLAS SkylakeX + tcmalloc) set by the caller.
"""
import argparse
import importlib.util
import os
import statistics
import sys
import time


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--configs", default="256:256:fb,256:256:actor,256:256:both")
    p.add_argument("--steps", type=int, default=5)
    p.add_argument("--warmup", type=int, default=2)
    args = p.parse_args()
    path = os.environ.get("TORCH_REF", "/work/shared/anchor/torch_ref.py")
    os.environ["ANCHOR_REEXEC"] = "1"  # the caller sets the library environment
    argv, sys.argv = sys.argv, [path]
    spec = importlib.util.spec_from_file_location("torch_ref", path)
    ref = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(ref)
    sys.argv = argv
    import torch
    torch.set_num_threads(args.threads)
    for cfg in args.configs.split(","):
        w, b, part = cfg.split(":")
        torch.manual_seed(0)
        _, step = ref.fb_case(int(w), int(b), part)
        for _ in range(args.warmup):
            step()
        cpu, wall = [], []
        for _ in range(args.steps):
            c0, w0 = time.process_time(), time.perf_counter()
            step()
            cpu.append(time.process_time() - c0)
            wall.append(time.perf_counter() - w0)
        print(f"fb-w{w} B{b} {part} {args.threads} {1e3 * statistics.median(cpu):.2f} {1e3 * statistics.median(wall):.2f}",
              flush=True)


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""peak_rss.py — optional measuring aid (never run by tests): peak resident set size (getrusage ru_maxrss of the
child, i.e. the process high-water mark) of one training-step config, ours vs PyTorch, each in its own fresh
process: ours runs the config's benchmark with --benchmark_min_time=0 (warm-up + at least 1 timed step),
torch_ref.py's case runs 2 steps.

Usage: OMP_WAIT_POLICY=passive [T2M_OPENBLAS_ROOT=DIR] python3 bench/peak_rss.py --build-dir build-perf \
           [--threads 2] [--only vae,fm,fb]
Prints one line per config: ours MiB, torch MiB, ours/torch.
"""
import argparse, os, subprocess, sys

p = argparse.ArgumentParser()
p.add_argument("--build-dir", default="build")
p.add_argument("--threads", type=int, default=2)
p.add_argument("--only", default="vae,fm,fb")
p.add_argument("--torch-ref", default=os.environ.get("TORCH_REF", "/work/shared/anchor/torch_ref.py"))
a = p.parse_args()

LIB = "/usr/lib/x86_64-linux-gnu"
root = os.environ.get("T2M_OPENBLAS_ROOT", "")
if os.path.isdir(LIB + "/openblas-openmp") and os.path.isfile(LIB + "/libtcmalloc_minimal.so.4"):
    R = LIB
elif root:
    R = root + LIB
else:
    sys.exit("peak_rss.py: OpenBLAS/tcmalloc not installed; set T2M_OPENBLAS_ROOT")
torch_env = dict(os.environ, ANCHOR_REEXEC="1", LD_LIBRARY_PATH=R + "/openblas-openmp", OPENBLAS_CORETYPE="SkylakeX",
                 LD_PRELOAD=R + "/libtcmalloc_minimal.so.4", OMP_NUM_THREADS=str(a.threads))
ours_env = dict(os.environ, OMP_NUM_THREADS=str(a.threads))

TORCH = """
import importlib.util, sys
path, kind, args = sys.argv[1], sys.argv[2], sys.argv[3:]
sys.argv = [path]
spec = importlib.util.spec_from_file_location("torch_ref", path); tr = importlib.util.module_from_spec(spec)
spec.loader.exec_module(tr)
import torch
torch.set_num_threads(%d); torch.manual_seed(0)
if kind == "vae": _, step = tr.vae_case(int(args[0]), int(args[1]))
elif kind == "fm": _, step = tr.fm_case(args[0], int(args[1]), int(args[2]))
else: _, step = tr.fb_case(int(args[0]), int(args[1]), args[2])
step(); step()
""" % a.threads

def maxrss_mib(cmd, env):
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _, status, ru = os.wait4(proc.pid, 0)
    if status != 0:
        return float("nan")
    return ru.ru_maxrss / 1024.0  # KiB -> MiB

cases = []
if "vae" in a.only:
    for b, t in [(32, 64), (256, 64), (32, 128), (256, 128)]:
        cases.append((f"vae B{b} T{t}", ["bench_train_vae", f"--benchmark_filter=B:{b}/T:{t}/"], ["vae", b, t]))
if "fm" in a.only:
    for size, b, t in [("small", 32, 8), ("small", 256, 8), ("small", 32, 16), ("small", 256, 16),
                       ("paper", 32, 8), ("paper", 32, 16), ("paper", 256, 8)]:
        flt = f"--benchmark_filter=BM_train_fm/fm_{size}/B:{b}/Tm:{t}/"
        cases.append((f"fm-{size} B{b} Tm{t}", ["bench_train_fm", flt], ["fm", size, b, t]))
if "fb" in a.only:
    for w, b in [(256, 256), (1024, 1024)]:
        for part in ["fb", "actor", "both"]:
            cases.append((f"fb-w{w} B{b} {part}", ["bench_train_fb", f"--benchmark_filter=^fb-w{w} B{b} {part}/"],
                          ["fb", w, b, part]))
print(f"# peak RSS (MiB), {a.threads} threads, load average {open('/proc/loadavg').read().split()[:3]}")
print("%-22s %10s %10s %8s" % ("config", "ours MiB", "torch MiB", "ours/torch"))
for name, ours, torch in cases:
    o = maxrss_mib([os.path.join(a.build_dir, ours[0]), ours[1], "--benchmark_min_time=0"], ours_env)
    t = maxrss_mib(["/usr/bin/python3", "-c", TORCH, a.torch_ref] + [str(x) for x in torch], torch_env)
    print("%-22s %10.0f %10.0f %8.2f" % (name, o, t, o / t), flush=True)

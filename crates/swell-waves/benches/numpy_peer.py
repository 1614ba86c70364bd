#!/usr/bin/env python3
"""The numpy peer of Swell's FFT frame, timed beside the Rust bench in one run.

Swell's frame (`fft_frame/portable_256_all_fields` in benches/waves.rs): evolve h~(k, t) from h0
and the dispersion relation, then one inverse real 2-D FFT for each of the 8 fields (height,
Dx, Dz, two slopes, three Jacobian terms), f64 throughout. The peer does the same work the way a
numpy user would: complex128 arrays in rfft layout, `exp` for the phases, one `irfft2` per field.

The Rust bench and the numpy peer alternate (numpy, Rust, numpy, Rust, numpy), so that load from
other work on a shared machine hits both; the ratios use the median numpy times and the median of
the Rust bench's criterion estimates. The headline ratio takes numpy's best case: its 8 irfft2
calls alone, on spectra made beforehand (the Rust frame also evolves and multiplies); the
full-frame ratio is printed beside it.

    python3 crates/swell-waves/benches/numpy_peer.py            # N = 256, 2 Rust runs
    python3 crates/swell-waves/benches/numpy_peer.py --runs 3 --quick

numpy is installed into target/numpy-venv with pip if `import numpy` fails.
"""

import argparse
import os
import re
import statistics
import subprocess
import sys
import time

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))


def ensure_numpy():
    """Re-executes this script under a venv with numpy if the current Python lacks it."""
    try:
        import numpy  # noqa: F401

        return
    except ImportError:
        pass
    venv = os.path.join(ROOT, "target", "numpy-venv")
    py = os.path.join(venv, "bin", "python3")
    if os.environ.get("SWELL_NUMPY_VENV"):
        sys.exit("numpy still missing inside " + venv)
    if not os.path.exists(py):
        subprocess.check_call([sys.executable, "-m", "venv", venv])
    subprocess.check_call([py, "-m", "pip", "install", "--quiet", "numpy"])
    os.environ["SWELL_NUMPY_VENV"] = "1"
    os.execv(py, [py] + sys.argv)


def numpy_frame_ms(n, iters):
    """Median times (ms) of numpy's frame of an n x n tile: (irfft2 only, full frame).

    irfft2 only: the 8 `irfft2` calls on spectra made beforehand, numpy's best case and the
    peer the ratio uses (the Rust frame also evolves the spectrum and applies the multipliers).
    Full frame: evolution with `exp`, the 8 multipliers and the 8 `irfft2`.
    """
    import numpy as np

    rng = np.random.default_rng(1)
    tile = 256.0
    dk = 2.0 * np.pi / tile
    kz = np.fft.fftfreq(n, 1.0 / n) * dk  # rows: kz, all n
    kx = np.fft.rfftfreq(n, 1.0 / n) * dk  # columns: kx >= 0, n/2 + 1
    KX, KZ = np.meshgrid(kx, kz)
    k = np.hypot(KX, KZ)
    k[0, 0] = 1.0
    omega = np.floor(np.sqrt(9.81 * k) / (2 * np.pi / 200.0)) * (2 * np.pi / 200.0)
    h0 = rng.standard_normal((n, n // 2 + 1)) + 1j * rng.standard_normal((n, n // 2 + 1))
    h0m = np.conj(h0[(-np.arange(n)) % n, :])  # conj(h0(-k)) on the half plane (a peer's shortcut)
    lam = 1.0
    mults = [1.0, -1j * lam * KX / k, -1j * lam * KZ / k, 1j * KX, 1j * KZ,
             lam * KX * KX / k, lam * KZ * KZ / k, lam * KX * KZ / k]

    def spectra(t):
        e = np.exp(-1j * omega * t)
        ht = h0 * e + h0m * np.conj(e)
        return [c * ht for c in mults]

    def transforms(fields):
        return [np.fft.irfft2(f, s=(n, n)) for f in fields]

    ready = spectra(10.0)
    for _ in range(5):
        transforms(spectra(10.0))
    only, full = [], []
    for i in range(iters):
        t0 = time.perf_counter()
        transforms(ready)
        t1 = time.perf_counter()
        transforms(spectra(10.0 + i * 1e-3))
        t2 = time.perf_counter()
        only.append(t1 - t0)
        full.append(t2 - t1)
    return 1e3 * statistics.median(only), 1e3 * statistics.median(full)


UNITS = {"ns": 1e-6, "µs": 1e-3, "us": 1e-3, "ms": 1.0, "s": 1e3}


def rust_frame_ms(n, quick):
    """Criterion's estimate (ms) for fft_frame/portable_{n}_all_fields, from `cargo bench`."""
    name = f"fft_frame/portable_{n}_all_fields"
    cmd = ["cargo", "bench", "-p", "swell-waves", "--bench", "waves", "--", "--noplot", f"^{name}$"]
    if quick:
        cmd.insert(-1, "--quick")
    out = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, check=True).stdout
    m = re.search(re.escape(name) + r"\s+time:\s+\[\S+ \S+ (\S+) (\S+) \S+ \S+\]", out)
    if not m:
        sys.exit("could not find the bench line in cargo's output:\n" + out)
    return float(m.group(1)) * UNITS[m.group(2)]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=256, help="grid side (the bench has 64, 128, 256, 512)")
    ap.add_argument("--runs", type=int, default=2, help="Rust bench runs (numpy runs one more)")
    ap.add_argument("--iters", type=int, default=100, help="numpy frames per numpy run")
    ap.add_argument("--quick", action="store_true", help="criterion --quick")
    args = ap.parse_args()
    ensure_numpy()
    import numpy as np

    py, full, rs = [], [], []
    for _ in range(args.runs):
        a, b = numpy_frame_ms(args.n, args.iters)
        py.append(a)
        full.append(b)
        rs.append(rust_frame_ms(args.n, args.quick))
    a, b = numpy_frame_ms(args.n, args.iters)
    py.append(a)
    full.append(b)
    py_ms, full_ms, rs_ms = statistics.median(py), statistics.median(full), statistics.median(rs)
    fmt = lambda vs: ", ".join(f"{v:.3f}" for v in vs)
    print(f"numpy {np.__version__}, {args.n}², 8 fields, f64:")
    print(f"  8 x irfft2, spectra ready: {fmt(py)} ms (median {py_ms:.3f})")
    print(f"  full frame (exp + multipliers + irfft2): {fmt(full)} ms (median {full_ms:.3f})")
    print(f"swell fft_frame/portable_{args.n}_all_fields: {fmt(rs)} ms (median {rs_ms:.3f})")
    print(f"ratio numpy (irfft2 only) / swell: {py_ms / rs_ms:.2f}x")
    print(f"ratio numpy (full frame) / swell:  {full_ms / rs_ms:.2f}x")


if __name__ == "__main__":
    main()

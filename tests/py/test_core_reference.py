"""The firmware mixer (firmware/core/mixer_setup.c, mixer.c) against independent numpy references.

The C side runs as build/probe-mixer (float) and build/probe-mixer-fixed (Q16.16), see
tests/core/probe_mixer.c and tests/core/probe.mk; when the Makefile does not build them, they
are compiled here from the sources with the system C compiler.

References:
- Gamma of eq. (14) from the parameters the probe actually used (Q16.16-rounded in the fixed build);
- numpy.linalg.pinv (SVD in double) for the pseudo-inverse, scipy-free null-space checks;
- the box-constrained allocation: the unique minimiser of |f - Gamma^+ w| subject to Gamma f = w,
  f_lo <= f <= f_hi, found by brute force over all 3^n active sets (an exhaustive, exact method
  that shares nothing with the firmware's facet/active-set algorithm).
"""

import itertools
import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("OCTO_BUILD", REPO / "build"))
S = np.sqrt(2) / 2


def gamma14(l, kf, ktau, mask=0xFF):
    k = ktau / kf
    g = np.array([[1.0] * 8,
                  [0, -S * l, -l, -S * l, 0, S * l, l, S * l],
                  [-l, -S * l, 0, S * l, l, S * l, 0, -S * l],
                  [k, -k, k, -k, k, -k, k, -k]])
    for j in range(8):
        if not (mask >> j) & 1:
            g[:, j] = 0
    return g


def _compile(fixed, out):
    cc = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if not cc:
        pytest.skip("no C compiler to build the mixer probe")
    core = REPO / "firmware" / "core"
    cmd = [cc, "-std=c11", "-O2", "-I", str(core), "-o", str(out),
           str(REPO / "tests" / "core" / "probe_mixer.c"), str(core / "mixer_setup.c"), str(core / "mixer.c"),
           "-lm"]
    if fixed:
        cmd.insert(1, "-DOCTO_FIXED=1")
    subprocess.run(cmd, check=True)
    return out


class Probe:
    def __init__(self, exe):
        self.p = subprocess.Popen([str(exe)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)

    def ask(self, line):
        self.p.stdin.write(line + "\n")
        self.p.stdin.flush()
        return json.loads(self.p.stdout.readline())

    def init(self, l, kf, ktau, mask=0xFF, tmin=0.0, tmax=1.0, mode=1):
        return self.ask(f"init {l!r} {kf!r} {ktau!r} {mask} {tmin!r} {tmax!r} {mode}")

    def mix(self, w):
        return self.ask("mix " + " ".join(repr(float(x)) for x in w))

    def close(self):
        self.p.stdin.close()
        self.p.wait(timeout=10)


@pytest.fixture(params=["float", "fixed"], scope="module")
def probe(request, tmp_path_factory):
    fixed = request.param == "fixed"
    exe = BUILD / ("probe-mixer-fixed" if fixed else "probe-mixer")
    if not exe.exists():
        exe = _compile(fixed, tmp_path_factory.mktemp("probe") / exe.name)
    p = Probe(exe)
    p.fixed = fixed
    yield p
    p.close()


CASES = [(0.35, 28.0269, 0.3869, 0xFF), (0.25, 10.0, 0.2, 0xFF), (0.5, 40.0, 1.0, 0xFF),
         (0.35, 28.0269, 0.3869, 0xFE), (0.25, 12.0, 0.15, 0xF7), (0.6, 15.0, 0.1, 0xFF & ~0x21),
         (0.35, 28.0269, 0.0, 0xFF)]  # the last: k = 0, rank 3


@pytest.mark.parametrize("case", CASES)
def test_pinv_matches_numpy(probe, case):
    l, kf, kt, mask = case
    used = probe.init(l, kf, kt, mask)
    g = probe.ask("gamma")
    gam = np.array(g["gamma"])
    # Gamma is eq. (14) built from the parameters the firmware holds
    np.testing.assert_allclose(gam, gamma14(used["l"], used["kf"], used["ktau"], mask), atol=1e-7)
    ref = np.linalg.pinv(gam.astype(np.float64), rcond=1e-5)
    pinv = np.array(g["pinv"])
    scale = np.abs(ref).max()
    np.testing.assert_allclose(pinv, ref, atol=2e-6 * scale)
    np.testing.assert_allclose(np.array(g["pinv_scalar"]), ref,
                               atol=(1e-4 if probe.fixed else 2e-6) * scale)
    rank = np.linalg.matrix_rank(gam, tol=1e-5 * np.linalg.svd(gam, compute_uv=False)[0])
    assert g["rank"] == rank
    if rank == 4:
        # 1e-6 for the paper's geometry (|pinv| <= 10); float32 storage limits it to about
        # 1e-7 of the largest entry for weaker yaw authority (case 5: |pinv| ~ 50)
        np.testing.assert_allclose(gam @ pinv, np.eye(4), atol=max(1e-6, 1.2e-7 * scale))
    null = np.array(g["null"])
    assert null.shape == (8, 8 - rank)
    np.testing.assert_allclose(gam @ null, 0, atol=1e-6)
    np.testing.assert_allclose(null.T @ null, np.eye(8 - rank), atol=1e-6)


def min_norm_box(gam, w, lo, hi, present):
    """argmin |f - pinv(gam) w| s.t. gam f = w, lo <= f <= hi (present rotors), exhaustively."""
    idx = [j for j in range(8) if present[j]]
    g = gam[:, idx]
    fref = np.linalg.pinv(g) @ w
    best, best_obj = None, np.inf
    for pattern in itertools.product((0, 1, 2), repeat=len(idx)):  # 0 free, 1 at lo, 2 at hi
        f = np.where(np.array(pattern) == 1, lo, np.where(np.array(pattern) == 2, hi, 0.0))
        free = np.array(pattern) == 0
        r = w - g[:, ~free] @ f[~free]
        gf = g[:, free]
        if gf.shape[1] == 0:
            x = np.zeros(0)
        else:
            c = r - gf @ fref[free]
            x = None
            if gf.shape[1] >= 4:  # minimum-norm correction, full row rank: the common case
                try:
                    x = fref[free] + gf.T @ np.linalg.solve(gf @ gf.T, c)
                except np.linalg.LinAlgError:
                    pass
            if x is None or np.abs(gf @ x - r).max() > 1e-9 * (1 + np.abs(w).max()):
                x = fref[free] + np.linalg.lstsq(gf, c, rcond=None)[0]
        if np.abs(gf @ x - r).max() > 1e-9 * (1 + np.abs(w).max()):
            continue
        f[free] = x
        if f.min() < lo - 1e-9 or f.max() > hi + 1e-9:
            continue
        obj = np.sum((f - fref) ** 2)
        if obj < best_obj:
            best, best_obj = f, obj
    out = np.zeros(8)
    out[idx] = best
    return out


@pytest.mark.parametrize("mask", [0xFF, 0xFE])
def test_allocation_matches_exhaustive_reference(probe, mask):
    used = probe.init(0.35, 28.0269, 0.3869, mask)
    gam = np.array(probe.ask("gamma")["gamma"], dtype=np.float64)
    lo, hi = used["f_lo"], used["f_hi"]
    present = [(mask >> j) & 1 for j in range(8)]
    rng = np.random.default_rng(4 + mask)
    tol_f = 0.05 if probe.fixed else 2e-3
    for n in range(6):
        # attainable demands (some rotors on the bounds) and unattainable ones
        f = rng.uniform(lo, hi, 8)
        f[rng.random(8) < 0.3] = lo
        f[rng.random(8) < 0.3] = hi
        f *= present
        w = gam @ f
        if n % 2:
            w = w + rng.normal(0, [30, 6, 6, 1.5])
        out = probe.mix(w)
        ach = np.array(out["achieved"])
        if n % 2 == 0:  # attainable: reproduced exactly
            np.testing.assert_allclose(ach, w, atol=(6e-3 if probe.fixed else 2e-4))
        # rotors: the minimum-norm feasible allocation of what was achieved
        ref = min_norm_box(gam, ach, lo, hi, present)
        np.testing.assert_allclose(np.array(out["f"]), ref, atol=tol_f)


def test_unconstrained_is_eq15(probe):
    probe.init(0.35, 28.0269, 0.3869)
    gam = np.array(probe.ask("gamma")["gamma"], dtype=np.float64)
    rng = np.random.default_rng(15)
    for _ in range(50):
        w = np.array([rng.uniform(40, 180), *rng.uniform(-2, 2, 2), rng.uniform(-0.2, 0.2)])
        out = probe.mix(w)
        assert out["limits"] == 0
        np.testing.assert_allclose(out["f"], np.linalg.pinv(gam) @ w, atol=(2e-3 if probe.fixed else 1e-4))

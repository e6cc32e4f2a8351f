#!/usr/bin/env python3
"""A real peer for shellwarp's modal analysis: SciPy's eigsh on exactly the same eigenproblem.

For benchmarks only (tests never need Python). Usage, from the repository root:

    python3 -m venv /tmp/venv && /tmp/venv/bin/pip install scipy numpy
    # optional, the stronger factorisation (CHOLMOD; Debian 12's SuiteSparse 5 needs this version):
    apt-get install libsuitesparse-dev && /tmp/venv/bin/pip install cython setuptools wheel \
        && /tmp/venv/bin/pip install --no-build-isolation "scikit-sparse==0.4.12"
    cargo build --release
    SHELLWARP_CACHE_DIR=$(mktemp -d) taskset -c 1 target/release/shellwarp modes --scene creature \
        --modes 4 --json --export /tmp/creature-4 > /dev/null
    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 taskset -c 1 /tmp/venv/bin/python benches/eigsh_peer.py /tmp/creature-4

`shellwarp modes --export DIR` writes K.mtx and M.mtx (the free DOFs' exact rest stiffness and lumped
mass) and shellwarp.json (its shift σ, tolerances, eigenvalues and stage times). This script runs
`scipy.sparse.linalg.eigsh` in shift-invert mode with the same σ and number of modes, to the tolerance
shellwarp's Lanczos uses, with the inverse of K − σM given by SciPy's sparse LU (SuperLU) and, when
scikit-sparse is installed, by CHOLMOD's supernodal Cholesky; checks that the eigenvalues agree; and
prints the times (factorisation + eigen solve) and the ratio to shellwarp's own (its factorisation
and eigen stages; its assembly is shown apart, as reading the files is not counted for SciPy).
"""

import json
import sys
import time

import numpy as np
import scipy.io
import scipy.sparse.linalg as sla


def superlu(a):
    """SuperLU with its default column ordering (COLAMD; minimum degree on AᵀA + A was slower here)."""
    lu = sla.splu(a.tocsc())
    return lu.solve


def cholmod(a):
    """CHOLMOD's supernodal Cholesky (scikit-sparse), or None if it is not installed."""
    try:
        from sksparse.cholmod import cholesky
    except ImportError:
        return None
    factor = cholesky(a.tocsc())
    return factor


def peer(name, factorise, k, m, info):
    sigma, wanted = info["shift"], len(info["eigenvalues"])
    start = time.perf_counter()
    solve = factorise((k - sigma * m).tocsc())
    if solve is None:
        return None
    factorised = time.perf_counter()
    op = sla.LinearOperator(k.shape, matvec=solve, dtype=float)
    values, vectors = sla.eigsh(k, k=wanted, M=m, sigma=sigma, which="LM", OPinv=op, tol=info["lanczos_tolerance"])
    solved = time.perf_counter()
    residual = max(np.linalg.norm(k @ v - lam * (m @ v)) / np.linalg.norm(k @ v) for lam, v in zip(values, vectors.T))
    ours = np.array(info["eigenvalues"])
    agree = np.max(np.abs(np.sort(values) - ours) / np.abs(ours))
    total = solved - start
    own = info["seconds"]["factorisation"] + info["seconds"]["eigen"]
    print(
        f"{name:>16}: factorisation {factorised - start:.3f} s, eigsh {solved - factorised:.3f} s, total {total:.3f} s; "
        f"eigenvalues agree to {agree:.1e}, worst residual {residual:.1e}; ratio to shellwarp {total / own:.2f}"
    )
    return total


def main(directory: str) -> None:
    info = json.load(open(f"{directory}/shellwarp.json"))
    k = scipy.io.mmread(f"{directory}/K.mtx").tocsc()
    m = scipy.io.mmread(f"{directory}/M.mtx").tocsc()
    s = info["seconds"]
    print(f"dofs {info['dofs']}, modes {info['modes']}, shift {info['shift']:.4g}")
    print(
        f"{'shellwarp':>16}: factorisation {s['factorisation']:.3f} s, eigen {s['eigen']:.3f} s, "
        f"total {s['factorisation'] + s['eigen']:.3f} s (assembly {s['assembly']:.3f} s apart)"
    )
    peer("SciPy + SuperLU", superlu, k, m, info)
    if peer("SciPy + CHOLMOD", cholmod, k, m, info) is None:
        print(f"{'SciPy + CHOLMOD':>16}: scikit-sparse is not installed")


if __name__ == "__main__":
    main(sys.argv[1])

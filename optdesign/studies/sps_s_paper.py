"""The 3-SPS-S paper's section 4 (seed paper 004): the stiffness, dexterity and
driving-index ranges it reports on slices of the +-10 deg cube, ours for any
design, and how far apart they are (``docs/sps_s_scan.py`` scans h_o and delta
with them; ``docs/mechanisms/sps_s.md`` reports the result)."""
from __future__ import annotations

import numpy as np

from ..indices import local_index
from ..mechanisms.sps_s import SpsS, _p

__all__ = ["PAPER_STIFFNESS", "PAPER_DEXTERITY", "PAPER_DRIVING", "slice_poses", "paper_ranges", "paper_targets",
           "log_misfit", "scan_paper_ranges"]

#: section 4 of the paper: stiffness ranges (N m / rad) per direction at phi = 0 and -10 deg
PAPER_STIFFNESS = {
    ("phi", 0.0): {"psi": (100, 170), "theta": (130, 200), "phi": (0.6, 2.5)},
    ("phi", -10.0): {"psi": (90, 160), "theta": (130, 190), "phi": (0.5, 2.3)},
}
#: section 4.2: dexterity ranges on the slices phi = 10, psi = 10, theta = 10 deg
PAPER_DEXTERITY = {("phi", 10.0): (0.1, 0.161), ("psi", 10.0): (0.02, 0.15), ("theta", 10.0): (0.02, 0.16)}
#: Table 1: driving index ranges on the slices (axis, value in deg)
PAPER_DRIVING = {
    ("psi", -10.0): (0.002, 0.014), ("psi", 0.0): (0.001, 0.012), ("psi", 10.0): (0.001, 0.011),
    ("theta", -10.0): (0.002, 0.011), ("theta", 0.0): (0.001, 0.012), ("theta", 10.0): (0.001, 0.014),
    ("phi", -10.0): (0.007, 0.013), ("phi", 0.0): (0.0003, 0.0180), ("phi", 10.0): (0.008, 0.014),
}


# ---------------------------------------------------------------------- section 4 ranges
def slice_poses(axis: str, value_deg: float, resolution: int = 21, half_range_deg: float = 10.0) -> np.ndarray:
    """Poses (n^2, 3) of a slice of the +-10 deg cube: ``axis`` fixed at
    ``value_deg``, the other two angles on an n x n grid."""
    g = np.radians(np.linspace(-half_range_deg, half_range_deg, resolution))
    i = SpsS.pose_names.index(axis)
    A, B = np.meshgrid(g, g, indexing="ij")
    cols = [A.ravel(), B.ravel()]
    cols.insert(i, np.full(A.size, np.radians(value_deg)))
    return np.stack(cols, -1)


def paper_ranges(mech: SpsS, resolution: int = 21, jacobian: str = "omega") -> dict[str, np.ndarray]:
    """Our (min, max) of every range section 4 reports, for a (population of)
    design(s): ``stiffness`` (design..., 2 slices, 3 directions, 2), ``dexterity``
    (design..., 3, 2), ``driving`` (design..., 9, 2), in the order of
    PAPER_STIFFNESS, PAPER_DEXTERITY, PAPER_DRIVING.  ``jacobian="omega"``: eq. 10;
    ``"euler"``: the Jacobian for the RPY rates, J E (the other reading of
    "the directions psi, theta, phi")."""
    def J_of(X):
        return mech.jacobian(X) if jacobian == "omega" else mech.jacobian_euler(X)

    def rng_(v):
        return np.stack([v.min(axis=-1), v.max(axis=-1)], -1)

    st = []
    for axis, val in PAPER_STIFFNESS:
        J = J_of(slice_poses(axis, val, resolution))
        K = _p(mech.k, 1) * np.sum(J * J, axis=-2)                    # (D.., N, 3)
        st.append(rng_(np.moveaxis(K, -1, -2)))                        # (D.., 3, 2)
    dx = [rng_(local_index("dexterity", J=J_of(slice_poses(a, v, resolution)))) for a, v in PAPER_DEXTERITY]
    dr = [rng_(local_index("driving", J=J_of(slice_poses(a, v, resolution)))) for a, v in PAPER_DRIVING]
    return {"stiffness": np.stack(st, -3), "dexterity": np.stack(dx, -2), "driving": np.stack(dr, -2)}


def paper_targets() -> dict[str, np.ndarray]:
    """The paper's ranges, shaped as :func:`paper_ranges`."""
    st = np.array([[v[d] for d in ("psi", "theta", "phi")] for v in PAPER_STIFFNESS.values()], float)
    return {"stiffness": st, "dexterity": np.array(list(PAPER_DEXTERITY.values()), float),
            "driving": np.array(list(PAPER_DRIVING.values()), float)}


def log_misfit(ours: dict[str, np.ndarray], groups=("stiffness", "dexterity", "driving"),
               fit_k: bool = True, ends=(0, 1)) -> tuple[np.ndarray, np.ndarray]:
    """The factor by which our ranges miss the paper's, exp(max |log(ours / paper)|)
    over the range ends of ``groups`` (``ends``: 0 the lower, 1 the upper ends),
    and the factor by which k must be scaled to reach it (stiffness is
    proportional to k, so the best scale is the midpoint of the log ratios).
    Returns (factor (design...), k_scale (design...))."""
    tgt = paper_targets()
    logs_k, logs = [], []
    for gname in groups:
        t = np.take(tgt[gname], ends, axis=-1)
        o = np.take(ours[gname], ends, axis=-1)
        dshape = o.shape[:o.ndim - t.ndim]
        with np.errstate(divide="ignore", invalid="ignore"):
            r = (np.log(t) - np.log(o)).reshape(dshape + (-1,))
        (logs_k if gname == "stiffness" else logs).append(r)
    with np.errstate(invalid="ignore"):
        shift = np.zeros(())
        if logs_k:
            lk = np.concatenate(logs_k, -1)
            shift = 0.5 * (lk.max(-1) + lk.min(-1)) if fit_k else np.zeros(lk.shape[:-1])
            shift = np.where(np.isfinite(shift), shift, 0.0)
            logs.append(lk - shift[..., None])
        allr = np.concatenate(logs, -1)
        allr = np.where(np.isfinite(allr), allr, np.inf)
        return np.exp(np.abs(allr).max(-1)), np.exp(shift)


def scan_paper_ranges(h_o_values, delta_values, resolution: int = 21, jacobian: str = "omega",
                      chunk: int = 400, **params) -> dict[str, np.ndarray]:
    """:func:`paper_ranges` over the grid h_o x delta (k = 1, so stiffness
    ranges are per unit leg stiffness), vectorized over the designs in chunks.
    Returns ``h_o``, ``delta`` (G,) and the ranges with a leading axis G."""
    H, D = np.meshgrid(np.asarray(h_o_values, float), np.asarray(delta_values, float), indexing="ij")
    H, D = H.ravel(), D.ravel()
    parts = []
    for a in range(0, H.size, chunk):
        mech = SpsS(h_o=H[a:a + chunk, None], delta=D[a:a + chunk, None], k=1.0, **params)
        parts.append(paper_ranges(mech, resolution, jacobian))
    out = {k: np.concatenate([p[k] for p in parts], 0) for k in parts[0]}
    out.update(h_o=H, delta=D)
    return out

"""Tables 1 and 2 of the UPS+UPR+S paper (seed 000) against eq. 12 and the
certified forward kinematics (docs/reproduction.md, section UPS+UPR+S).

    python docs/ups_upr_s_tables.py
"""
from __future__ import annotations

import numpy as np

from optdesign.mechanisms import get
from optdesign.mechanisms.ups_upr_s import PAPER_TABLE1, PAPER_TABLE2, solve_all

MM = 1e-3


def main():
    mech = get("ups_upr_s")()
    print("Table 1: eq. 12 at the printed poses (mm)")
    print("| row | sin theta, sin psi | paper q2, q3 | eq. 12 | paper - eq. 12 | root of the paper's q |")
    print("|---|---|---|---|---|---|")
    ours = mech.inverse(PAPER_TABLE1[:, :2]) / MM
    roots = solve_all(mech, PAPER_TABLE1[:, 2:] * MM).roots
    for i, (row, q, r) in enumerate(zip(PAPER_TABLE1, ours, roots), 1):
        near = r[np.all(np.abs(r) < 0.5, axis=1)]
        print(f"| {i} | {row[0]:g}, {row[1]:g} | {row[2]:.4f}, {row[3]:.4f} | {q[0]:.4f}, {q[1]:.4f} | "
              f"{row[2] - q[0]:+.3f}, {row[3] - q[1]:+.3f} | " + "; ".join(f"({a:.5f}, {b:.5f})" for a, b in near) + " |")
    print()
    print("Table 2: every root in the domain and the paper's GA answers")
    print("| q2, q3 / mm | paper | all roots | paper - nearest root | eq. 12 at paper - q / mm | certified |")
    print("|---|---|---|---|---|---|")
    sol = solve_all(mech, PAPER_TABLE2[:, :2] * MM)
    for row, r, unres in zip(PAPER_TABLE2, sol.roots, sol.unresolved):
        paper = row[2:]
        d = np.min(np.max(np.abs(r - paper), axis=1))
        res = mech.inverse(paper[None])[0] / MM - row[:2]
        print(f"| {row[0]:g}, {row[1]:g} | {paper[0]:g}, {paper[1]:g} | "
              + "; ".join(f"({a:.6f}, {b:.6f})" for a, b in r)
              + f" | {d:.1e} | {res[0]:+.3f}, {res[1]:+.3f} | {'yes' if not unres else 'no'} |")


if __name__ == "__main__":
    main()

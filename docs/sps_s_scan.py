"""The scan of docs/reproduction.md, section 3-SPS-S: how close can any leg
stiffness k, platform offset h_o and triangle turn delta bring the 3-SPS-S
ranges of section 4 to the paper's?  Prints the table of best misfit factors.

    python docs/sps_s_scan.py            # h_o -0.25..1.00 m, delta 0..118 deg (about 2 min)
    python docs/sps_s_scan.py --coarse   # h_o step 0.05 m, delta step 6 deg (seconds)
"""
from __future__ import annotations

import sys

import numpy as np

from optdesign.studies.sps_s_paper import log_misfit, scan_paper_ranges

GROUPS = [("stiffness", "dexterity", "driving"), ("stiffness",), ("dexterity",), ("driving",),
          ("stiffness", "dexterity"), ("stiffness", "driving"), ("dexterity", "driving")]


def main(argv):
    coarse = "--coarse" in argv
    jac = "euler" if "--euler" in argv else "omega"
    ho = np.round(np.arange(-0.25, 1.0001, 0.05 if coarse else 0.01), 3)
    de = np.radians(np.arange(0.0, 120.0, 6.0 if coarse else 2.0))
    r = scan_paper_ranges(ho, de, jacobian=jac)
    H, D = r["h_o"], r["delta"]
    print(f"{H.size} geometries, Jacobian {jac}; factor = exp(max |log(ours / paper)|), k fitted")
    print("| ranges | all ends | where | upper ends only | where |")
    print("|---|---:|---|---:|---|")
    for g in GROUPS:
        cells = []
        for ends in ((0, 1), (1,)):
            f, ks = log_misfit(r, g, ends=ends)
            ks = np.broadcast_to(ks, f.shape)
            i = int(np.argmin(f))
            where = f"h_o = {H[i]:.2f} m, delta = {np.degrees(D[i]):.0f} deg"
            if "stiffness" in g:
                where += f", k = {ks[i]:.0f} N/m"
            cells += [f"{f[i]:.2f}", where]
        print(f"| {' + '.join(g)} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main(sys.argv[1:])

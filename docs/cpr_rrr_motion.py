"""Write docs/figures/cpr_rrr_motion.png: the 2-CPR/RRR motion example of the
paper's section 5 (its figure 4), for the default design of configs/cpr_rrr.yaml.

    python docs/cpr_rrr_motion.py [OUT.png]
"""
import sys
from pathlib import Path

import numpy as np

from optdesign.studies.cpr_rrr_motion import plot_motion_example

out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).parent / "figures" / "cpr_rrr_motion.png"
out.parent.mkdir(parents=True, exist_ok=True)
mp = plot_motion_example(out, n=0.1, f=0.02, w=0.02)
print(f"wrote {out}")
for k, unit in (("X", "mm"), ("V", "mm/s"), ("A", "mm/s^2")):
    v = 1e3 * mp[k]
    print(f"{k}: x in [{v[:, 0].min():.3f}, {v[:, 0].max():.3f}] {unit}, y in [{v[:, 1].min():.3f}, {v[:, 1].max():.3f}] {unit}")
print("theta2 in [%.3f, %.3f] deg, theta1 in [%.3f, %.3f] deg" % (
    *np.degrees([mp["theta"][:, 0].min(), mp["theta"][:, 0].max()]),
    *np.degrees([mp["theta"][:, 1].min(), mp["theta"][:, 1].max()])))
print("max |V - V from rotary| = %.2e m/s, max |A - A from rotary| = %.2e m/s^2" % (
    np.abs(mp["V"] - mp["V_from_rotary"]).max(), np.abs(mp["A"] - mp["A_from_rotary"]).max()))

"""The memory layout of the described mechanisms' compiled kernel (:mod:`._kernels`)
and the constants its generated code (:mod:`._codegen`) is written with: plain
numbers, no numba, so that the generators can be read, run and tested alone.

numba freezes these values into the cached kernels, whose cache only watches
``_kernels.py``: that file records a digest of this one, of ``_codegen.py``
and of ``optdesign/formulas.py`` (whose value ids are imported here)
(``_kernels.GENERATOR_DIGEST``), which changes with them.
"""
from __future__ import annotations

from ..formulas import COL0, DET, DYN, FRO, IFRO, NVAL, SMIN, SMIN2, TWO  # noqa: F401 (the value ids)

#: points per task: the unit of the reductions and of parallel work
CHUNK = 256
#: points per structure-of-arrays block (rows of the scratch arrays)
BLK = 64
#: cond_F(J) = ||J||_F ||J^-1||_F from which a point is left to LAPACK (the
#: numpy path), for n >= 4 (Householder QR: its R^-1 loses eps cond(J));
#: for n <= 3 (the adjugate with compensated minors, exact to a few ulps at
#: any conditioning, and closed-form eigenvalues) only beyond HARD_SMALL: the
#: numpy path's SVD is no more accurate there, and the optima of constrained
#: runs lie on the singularity limit (cond = 1000 by default), where a search
#: would otherwise hand nearly every pose it tries to the numpy path
HARD = 1000.0
HARD_SMALL = 1e12
#: local values (rows of the kernel's output): DYN, SMIN2, SMIN, FRO, TWO, DET,
#: IFRO, COL0 + a (squared norm of column a of J: axis stiffness), NVAL, the ids
#: of the table of local values optdesign.formulas (imported above)
#: layout of the per-leg constants L (D, n, NL)
LA, LP, LU, LR0, LS0 = 0, 3, 6, 9, 12
LLA, LLR, LMACT, LMROD, LIROD, LFROD, LM1, LE1, LM2, LE2, LI12, LSG = range(15, 27)
NL = 27
#: layout of the per-design constants F (D, NF)
FCEN, FFIX, FMP, FIP, FCOM = 0, 3, 6, 7, 16
NF = 19
#: columns of the per-point frame data FR (Dr, N, FR_ROWS[ptype]), rows of a
#: block's frame data (rows, BLK): the origin from the pose (0 for rotation
#: poses), R row-major (not for translation poses), the Euler columns' entries
#: (cos yaw cos pitch, sin yaw cos pitch, -sin pitch, -sin yaw, cos yaw;
#: rotation and spatial poses); their number per pose type
FRO_, FRR, FRE = 0, 3, 12
NFR = 17
FR_ROWS = (3, 12, 17, 17)
#: pose-column kinds (ct): 0..5 a twist component; roll's and pitch's Euler columns
CT_ROLL, CT_PITCH = 6, 7
#: the largest size n (legs = pose coordinates) of the engine: a pose has at most six coordinates
NMAX = 6
#: rows of the per-leg scratch (n, NLG BLK)
GR, GG, GK, GAL, GGA, GDE = 0, 3, 9, 15, 16, 17
NLG = 18
#: rows of the per-point vector scratch ((NVS + 3 n) BLK)
VOK, VDET, VF2, VI2, VLJ, VLU, VLW, VBETA, VV0, VX, VMASK, VS = range(12)
NVS = 12
#: rows of the rigid-body matrix B (_rigid): mass, first moment, angular block
BA, BS, BW = 0, 1, 4
NB = 10
#: the Newton steps of lambda_max for n >= 4 (J^T J and J^-1 J^-T; W^T W of
#: the dynamic index), and the relative half-width of their check: points not
#: certified are bisected, correct but slower, so the counts are a trade-off
#: (measured on the Gough-Stewart platform: 4 steps certify 90 % of its
#: W^T W, 5 steps 99.99 %)
NEWTON = 5
NEWTON_DYN = 5
TAU = 1e-13
#: scratch rows of the dense routines (rows of BLK): the most of eigen's
#: tridiagonalization (the Gram matrix n n, six vectors of NMAX rows and six
#: single rows), mass.dyn (B s_b: 6 n; M_p, P, D and U^T K^T: n n each) and
#: inverse's QR (R: n n and four rows)
SROWS = max(NMAX * NMAX + 6 * NMAX + 6, 6 * NMAX + 4 * NMAX * NMAX, NMAX * NMAX + 4)

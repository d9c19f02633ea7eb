"""The layout of the chain mechanisms' arrays for the engine's chain kernel
(:mod:`.chain_kernels`): plain numbers, no numba, so that the packing
(:mod:`optdesign.mechanisms.described.chain_compiled`) reads them without
loading the kernels.  numba freezes them into the cached kernels: the chain
kernels' file records a digest of this one (``CHAIN_DIGEST``).

Integer arrays (one per mechanism shape, the same for all designs):

* ``hdr`` (NH,): the sizes below;
* ``roles`` (dof,): each pose coordinate's role (0..5: x, y, z, roll, pitch, yaw);
* ``cidx`` (dof,): per pose coordinate its place among the independent
  coordinates (i >= 0) or, as ``-1 - k``, the k-th parasitic one (the unknown
  ``nvar + k``);
* ``legs`` (nleg, NLEG): per chain leg its variables' count, closure (0
  position, 1 frame), actuated variable (-1: a passive leg), first variable
  (its columns among the unknowns) and first closure row;
* ``vcode`` (nvar,): each variable's code (0 rotation, 1 slide, 2 parallelogram);
* ``acts`` (n, 2): per actuator its source (0 a chain leg, 1 a shorthand
  leg) and that leg's index;
* ``sh`` (nsh, 2): per shorthand leg its kind (0 prismatic, 1 revolute, 2
  strut) and branch (0 minus, 1 plus, 2 outer, 3 inner);
* ``bod`` (nbody, 2): per link with a mass its chain leg and the last
  variable that moves it (in the leg).

Float arrays per design (first axis D):

* ``VF`` (D, nvar, NVF): axis, point, side, offset of each variable;
* ``LF`` (D, nleg, NLF): end point (reference configuration) and platform point;
* ``SF`` (D, nsh, NSF): A, P, U, R0, S0, La, Lr, sign of each shorthand leg;
* ``BF`` (D, nbody, NBF): mass, centre, inertia (row-major) of each link;
* ``GF`` (D, NGF): the length scale, the rotation pose's centre, the fixed
  angles, the platform's mass, centre of mass and inertia, the home pose's
  independent coordinates;
* ``UH`` (D, nu): the home configuration (the unknowns; NaN: no home);
* the points ``PX`` (1 or D, N, n + n n): the independent pose coordinates
  (through the declared map, if any) and the map's derivative Df (row-major;
  the identity without a map).
"""
from __future__ import annotations

#: hdr entries
H_PTYPE, H_DOF, H_N, H_NPAR, H_NLEG, H_NVAR, H_NU, H_NEQ, H_NSH, H_NBODY = range(10)
NH = 10
#: legs columns
G_K, G_CLOSURE, G_ACT, G_VOFF, G_ROFF = range(5)
NLEG = 5
#: VF columns
V_AXIS, V_POINT, V_SIDE, V_OFFSET = 0, 3, 6, 9
NVF = 10
#: LF columns
E_END, E_P = 0, 3
NLF = 6
#: SF columns
S_A, S_P, S_U, S_R0, S_S0, S_LA, S_LR, S_SIGN = 0, 3, 6, 9, 12, 15, 16, 17
NSF = 18
#: BF columns
B_M, B_C, B_I = 0, 1, 4
NBF = 13
#: GF columns
F_L, F_CEN, F_FIX, F_MP, F_COM, F_IP, F_P0 = 0, 1, 4, 7, 8, 11, 20
NGF = 26
#: the continuation (the numpy path's, optdesign.mechanisms.described.chain_solve):
#: a solution's residual, the polish target, the intermediate steps' tolerance
#: (relative to the length scale), the smallest step, Newton's iterations
TOL, POLISH, TOL_STEP, H_MIN, ITERS = 1e-11, 1e-14, 1e-8, 1.0 / 256, 8
#: the singularity tests of the least-squares solves (chain_poe.lsq): a square
#: matrix is singular where |det| <= HADAMARD prod |row_i|, a tall one where
#: min |R_ii| <= RCOND max |R_jj| of its QR
HADAMARD, RCOND = 1e-14, 1e-13

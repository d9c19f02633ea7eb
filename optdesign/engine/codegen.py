"""The generated fixed-size routines of the described mechanisms' kernel, as
text, from plain Python (no numba here).

Routines whose loops over matrix indices would otherwise run with run-time
bounds are written out as straight-line code for the size n: one loop over a
block's points, every matrix entry a local variable (``a2_3``: entry (2, 3) of
A).  :mod:`._kernels` compiles the text into its kernels (an ``@overload`` of a
stub per routine, see :data:`ROUTINES`); ``optdesign kernel-source`` prints it.
:class:`KernelSpec` holds the compile-time choices and makes the numba
arguments that carry them.

Two points at once: the heavy bodies (QR, lambda_max for n >= 4) are written
for the points j and j2 = j + BLK / 2 of the block, statement by statement
interleaved, so that the processor overlaps their dependency chains (sqrt,
division, the recurrences).  A body is a function ``body(sx, j)`` of the point:
its index variable ``j`` and the suffix ``sx`` of every local variable ("" in
the first copy, "_b" in the second), so both copies come from the same code.
"""
from __future__ import annotations

from .layout import BA, BLK, BS, BW, CT_ROLL, FRE, GDE, GGA, NEWTON, NEWTON_DYN
from .spec import KernelSpec, size_of_type  # noqa: F401 (the spec of the routines, read here)

#: the names the generated code uses besides its arguments (the kernel binds them)
GLOBALS = ("math", "np", "_u", "BLK", "TAU", "VDET", "VI2", "VBETA", "VV0", "VMASK", "_lmax3_point", "_bisect_flagged")


# ---------------------------------------------------------------------- helpers
def _one_point(body):
    """The loop over the block's m points, the body written for the point j."""
    return ["    for j in range(m):"] + body("", "j")


def _two_points(body):
    """The loop over the block's points two at a time, j and j2 (the second
    half of the block), the two copies' statements interleaved.  The distance
    between the points is a constant (half the block), so that LLVM sees the
    copies do not overlap; the whole block is computed (columns from m on are
    scratch, never read)."""
    first, second = body("", "j"), body("_b", "j2")
    return ([f"    for j in range({BLK // 2}):", f"        j2 = j + {BLK // 2}"]
            + [x for pair in zip(first, second) for x in pair])


def _rows(name, n, sx="", j="j"):
    """Load statements of the n x n matrix in the rows of the array ``name`` into x_r_c."""
    return [f"        {name.lower()}{r}_{c}{sx} = {name}[_u({(r * n + c)} * BLK + {j})]"
            for r in range(n) for c in range(n)]


def _sym(a, b, sx=""):   # entry (a, b) of the symmetric g (its upper triangle is stored)
    return f"g{min(a, b)}_{max(a, b)}{sx}"


# ---------------------------------------------------------------------- QR and R^-1
def qr_inverse_source(n, name="impl"):
    """R of the Householder QR of A, then U = R^-1 (upper triangle stored), |det A| = prod |R_kk|
    and ||U||_F^2 into V's rows VDET, VI2 (n >= 4)."""

    def body(sx, j):
        L = _rows("A", n, sx, j)
        L.append(f"        dt{sx} = 1.0")
        for k in range(n):
            tail = " + ".join(f"a{i}_{k}{sx} * a{i}_{k}{sx}" for i in range(k + 1, n)) or "0.0"
            L += [f"        s{sx} = {tail}", f"        x0{sx} = a{k}_{k}{sx}", f"        nr{sx} = x0{sx} * x0{sx} + s{sx}",
                  f"        r{sx} = math.sqrt(nr{sx})", f"        al{sx} = -r{sx} if x0{sx} >= 0.0 else r{sx}",
                  f"        den{sx} = nr{sx} - al{sx} * x0{sx}",
                  f"        beta{sx} = 1.0 / den{sx} if den{sx} > 0.0 else 0.0", f"        v0{sx} = x0{sx} - al{sx}",
                  f"        a{k}_{k}{sx} = al{sx}", f"        dt{sx} *= r{sx}"]
            for c in range(k + 1, n):
                dot = "".join(f" + a{i}_{k}{sx} * a{i}_{c}{sx}" for i in range(k + 1, n))
                L.append(f"        s{sx} = (v0{sx} * a{k}_{c}{sx}{dot}) * beta{sx}")
                L.append(f"        a{k}_{c}{sx} -= s{sx} * v0{sx}")
                L += [f"        a{i}_{c}{sx} -= s{sx} * a{i}_{k}{sx}" for i in range(k + 1, n)]
        # U = R^-1, column by column from the diagonal up
        L += [f"        u{k}_{k}{sx} = 1.0 / a{k}_{k}{sx}" for k in range(n)]
        for c in range(n):
            for r in range(c - 1, -1, -1):
                terms = " + ".join(f"a{r}_{k}{sx} * u{k}_{c}{sx}" for k in range(r + 1, c + 1))
                L.append(f"        u{r}_{c}{sx} = -({terms}) * u{r}_{r}{sx}")
        sq = " + ".join(f"u{r}_{c}{sx} * u{r}_{c}{sx}" for r in range(n) for c in range(r, n))
        L += [f"        V[_u(VDET * BLK + {j})] = dt{sx}", f"        V[_u(VI2 * BLK + {j})] = {sq}"]
        L += [f"        U[_u({r * n + c} * BLK + {j})] = u{r}_{c}{sx}" for r in range(n) for c in range(r, n)]
        return L

    return _source([f"def {name}(A, U, V, nt, m):"] + _two_points(body))


# ---------------------------------------------------------------------- lambda_max of a Gram matrix
def _gram(n, mode, sx=""):
    """Statements g_a_b (a <= b) of the Gram matrix of x: X^T X (cols), X X^T (rows)
    or U U^T for the upper triangular U (urows)."""
    L = []
    for a in range(n):
        for b in range(a, n):
            if mode == "cols":
                t = " + ".join(f"x{k}_{a}{sx} * x{k}_{b}{sx}" for k in range(n))
            elif mode == "rows":
                t = " + ".join(f"x{a}_{k}{sx} * x{b}_{k}{sx}" for k in range(n))
            else:
                t = " + ".join(f"x{a}_{k}{sx} * x{b}_{k}{sx}" for k in range(b, n))
            L.append(f"        g{a}_{b}{sx} = {t}")
    return L


def _tridiag_lmax(n, iters, sx=""):
    """Straight-line statements: Householder tridiagonalization of the symmetric
    g (upper triangle), the scaled tridiagonal t0..t(n-1), c0..c(n-2)
    (squared off-diagonal), iters quadratic-model steps from an upper bound
    (Gershgorin, Frobenius, and mean + sqrt(n - 1) standard deviation of the
    eigenvalues: Wolkowicz-Styan), the Sturm check (``good``)."""
    def g(a, b):
        return _sym(a, b, sx)

    L = []
    for k in range(n - 2):
        rest = " + ".join(f"{g(i, k)} * {g(i, k)}" for i in range(k + 2, n)) or "0.0"
        L += [f"        s{sx} = {rest}", f"        x1{sx} = {g(k + 1, k)}", f"        nr{sx} = x1{sx} * x1{sx} + s{sx}",
              f"        r{sx} = math.sqrt(nr{sx})", f"        al{sx} = -r{sx} if x1{sx} >= 0.0 else r{sx}",
              f"        den{sx} = nr{sx} - al{sx} * x1{sx}", f"        beta{sx} = 1.0 / den{sx} if den{sx} > 0.0 else 0.0",
              f"        e{k}{sx} = al{sx}", f"        v{k + 1}{sx} = x1{sx} - al{sx}"]
        L += [f"        v{i}{sx} = {g(i, k)}" for i in range(k + 2, n)]
        for r in range(k + 1, n):
            t = " + ".join(f"{g(r, c)} * v{c}{sx}" for c in range(k + 1, n))
            L.append(f"        p{r}{sx} = beta{sx} * ({t})")
        t = " + ".join(f"v{r}{sx} * p{r}{sx}" for r in range(k + 1, n))
        L.append(f"        h{sx} = 0.5 * beta{sx} * ({t})")
        L += [f"        w{r}{sx} = p{r}{sx} - h{sx} * v{r}{sx}" for r in range(k + 1, n)]
        for r in range(k + 1, n):
            for c in range(k + 1, r + 1):
                L.append(f"        {g(r, c)} = {g(r, c)} - (v{r}{sx} * w{c}{sx} + w{r}{sx} * v{c}{sx})")
    L += [f"        t{k}{sx} = {g(k, k)}" for k in range(n)]
    L.append(f"        e{n - 2}{sx} = {g(n - 1, n - 2)}")
    # upper bound: min(Gershgorin, Frobenius, Wolkowicz-Styan); scale to it
    gs = [f"t{k}{sx}" + (f" + abs(e{k - 1}{sx})" if k > 0 else "") + (f" + abs(e{k}{sx})" if k < n - 1 else "")
          for k in range(n)]
    L.append(f"        gb{sx} = " + gs[0])
    L += [f"        gb{sx} = max(gb{sx}, {t})" for t in gs[1:]]
    L.append(f"        fr{sx} = " + " + ".join([f"t{k}{sx} * t{k}{sx}" for k in range(n)]
                                         + [f"2.0 * (e{k}{sx} * e{k}{sx})" for k in range(n - 1)]))
    L.append(f"        mu{sx} = (" + " + ".join(f"t{k}{sx}" for k in range(n)) + f") * {1.0 / n!r}")
    L.append(f"        sd2{sx} = fr{sx} * {1.0 / n!r} - mu{sx} * mu{sx}")
    L += [f"        ws{sx} = mu{sx} + math.sqrt((sd2{sx} if sd2{sx} > 0.0 else 0.0) * {float(n - 1)!r})",
          f"        x0{sx} = min(min(gb{sx}, math.sqrt(fr{sx})), ws{sx})", f"        sc{sx} = x0{sx} if x0{sx} > 0.0 else 0.0",
          f"        s{sx} = 1.0 / x0{sx} if x0{sx} > 0.0 else 0.0"]
    L += [f"        t{k}{sx} = t{k}{sx} * s{sx}" for k in range(n)]
    L += [f"        c{k}{sx} = (e{k}{sx} * s{sx}) * (e{k}{sx} * s{sx})" for k in range(n - 1)]
    L.append(f"        x{sx} = 1.0")
    for _ in range(iters):
        # the characteristic polynomial f and its derivatives d, h at x (three-term recurrences)
        L += [f"        f0{sx} = 1.0", f"        f1{sx} = x{sx} - t0{sx}", f"        d0{sx} = 0.0", f"        d1{sx} = 1.0",
              f"        h0{sx} = 0.0", f"        h1{sx} = 0.0"]
        for k in range(1, n):
            L += [f"        z{sx} = x{sx} - t{k}{sx}", f"        f2{sx} = z{sx} * f1{sx} - c{k - 1}{sx} * f0{sx}",
                  f"        d2{sx} = f1{sx} + z{sx} * d1{sx} - c{k - 1}{sx} * d0{sx}",
                  f"        h2{sx} = 2.0 * d1{sx} + z{sx} * h1{sx} - c{k - 1}{sx} * h0{sx}",
                  f"        f0{sx} = f1{sx}", f"        f1{sx} = f2{sx}", f"        d0{sx} = d1{sx}", f"        d1{sx} = d2{sx}",
                  f"        h0{sx} = h1{sx}", f"        h1{sx} = h2{sx}"]
        # larger root of f + f' h + f'' h^2 / 2: h = -2 f / (f' + sqrt(f'^2 - 2 f f''))
        L += [f"        disc{sx} = d1{sx} * d1{sx} - 2.0 * f1{sx} * h1{sx}",
              f"        den{sx} = d1{sx} + math.sqrt(disc{sx} if disc{sx} > 0.0 else 0.0)",
              f"        x{sx} = x{sx} + (-2.0 * f1{sx} / den{sx} if den{sx} != 0.0 else 0.0)"]
    # Sturm counts at x (1 +- TAU): x certified within TAU of lambda_max
    for tag, y in (("hi", f"x{sx} * (1.0 + TAU)"), ("lo", f"x{sx} * (1.0 - TAU)")):
        L += [f"        y{sx} = {y}", f"        q0{sx} = 1.0", f"        q1{sx} = t0{sx} - y{sx}",
              f"        n{tag}{sx} = 1 if q1{sx} < 0.0 else 0"]
        for k in range(1, n):
            L += [f"        q2{sx} = (t{k}{sx} - y{sx}) * q1{sx} - c{k - 1}{sx} * q0{sx}",
                  f"        n{tag}{sx} += 1 if (q2{sx} < 0.0) != (q1{sx} < 0.0) else 0", f"        q0{sx} = q1{sx}",
                  f"        q1{sx} = q2{sx}"]
    L.append(f"        good{sx} = (nhi{sx} == {n}) & (nlo{sx} < {n})")
    return L


def lmax_source(n, mode, iters=NEWTON, name="impl"):
    """lambda_max of the Gram matrix (mode: cols, rows, urows) of X's n x n matrix
    into out; for n >= 4 the scaled tridiagonal into T and the points to bisect
    (not certified, V's VMASK nonzero) flagged in V's row VV0, then bisected."""

    def body(sx, j):
        if mode == "urows":
            L = [f"        x{r}_{c}{sx} = X[_u({r * n + c} * BLK + {j})]" for r in range(n) for c in range(r, n)]
        else:
            L = _rows("X", n, sx, j)
        L += _gram(n, mode, sx)
        if n == 1:
            L.append(f"        out[{j}] = g0_0{sx}")
        elif n == 2:
            L += [f"        hh{sx} = 0.5 * (g0_0{sx} - g1_1{sx})",
                  f"        out[{j}] = 0.5 * (g0_0{sx} + g1_1{sx}) + math.sqrt(hh{sx} * hh{sx} + g0_1{sx} * g0_1{sx})"]
        elif n == 3:
            L.append(f"        out[{j}] = _lmax3_point(g0_0{sx}, g1_1{sx}, g2_2{sx}, g0_1{sx}, g0_2{sx}, g1_2{sx})")
        else:
            L += _tridiag_lmax(n, iters, sx)
            flag = f"0.0 if good{sx} or V[_u(VMASK * BLK + {j})] == 0.0 or not sc{sx} > 0.0 else 1.0"
            L += [f"        out[{j}] = x{sx} * sc{sx}", f"        V[_u(VBETA * BLK + {j})] = sc{sx}",
                  f"        V[_u(VV0 * BLK + {j})] = {flag}"]
            L += [f"        T[_u({k} * BLK + {j})] = t{k}{sx}" for k in range(n)]
            L += [f"        T[_u({n + k} * BLK + {j})] = c{k}{sx}" for k in range(n - 1)]
        return L

    head = [f"def {name}(X, out, T, V, nt, m):"]
    if n <= 3:
        return _source(head + _one_point(body))
    return _source(head + _two_points(body) + ["    _bisect_flagged(T, out, V, nt, m)"])


# ---------------------------------------------------------------------- the dynamic index
def _column_vector(kind):
    """The pose column s (twist component -> coefficient expression, None for 1)."""
    if kind < 6:
        return {kind: None}
    if kind == CT_ROLL:
        return {3: "e0", 4: "e1", 5: "e2"}
    return {3: "e3", 4: "e4"}


def _times(coef, expr):
    return expr if coef is None else f"{coef} * {expr}"


def _b_entry(k, l):
    """Entry (k, l), k <= l, of the rigid-body matrix from its ten rows (_rigid):
    a I, -[s]x and the angular block."""
    if l < 3:
        return f"B[_u({BA} * BLK + j)]" if k == l else "0.0"
    if k < 3:
        # -[s]x = [[0, s2, -s1], [-s2, 0, s0], [s1, -s0, 0]]
        c = l - 3
        sign, comp = {(0, 1): (1, 2), (0, 2): (-1, 1), (1, 0): (-1, 2), (1, 2): (1, 0), (2, 0): (1, 1),
                      (2, 1): (-1, 0)}.get((k, c), (0, 0))
        if not sign:
            return "0.0"
        return ("" if sign > 0 else "-") + f"B[_u({BS + comp} * BLK + j)]"
    row = {(3, 3): 0, (4, 4): 1, (5, 5): 2, (3, 4): 3, (3, 5): 4, (4, 5): 5}[(k, l)]
    return f"B[_u({BW + row} * BLK + j)]"


def dyn_source(spec: KernelSpec, mass_only=False, name="impl"):
    """W = U^T M_p without M_p stored: M_p = S^T B S + sum_i [gamma_i J_i^T J_i +
    delta_i (J_i^T K_i + K_i^T J_i)] written as s_a.(B s_b) + sum_i (J_ia P_ib +
    K_ia D_ib), P_ib = gamma_i J_ib + delta_i K_ib, D_ib = delta_i J_ib; the
    pose columns s of the spec's kinds (a selection or the Euler columns) are
    expanded in the code, so only the entries of B they meet are read.
    For n <= 3 (U = J^-1) the legs' terms enter W through J U = I, without
    M_p: W = U^T S^T B S + diag(gamma) J + diag(delta) K + (U^T K^T) diag(delta) J
    (no cancellation of the gamma J^T J terms near a singular pose).
    mass_only: store M_p itself (full) into W instead (U is not read)."""
    n, kinds, rods = spec.n, spec.kinds, spec.rods
    upper = n >= 4
    L = [f"def {name}(B, Lg, J, Kp, FRb, U, W, nt, cspec, m):", "    for j in range(m):"]
    if any(k >= 6 for k in kinds):
        L += [f"        e{k} = FRb[_u({FRE + k} * BLK + j)]" for k in range(5)]
    svec = [_column_vector(k) for k in kinds]
    need = set()
    for b in range(n):
        for l in svec[b]:
            for a in range(n):
                for k in svec[a]:
                    need.add((min(k, l), max(k, l)))
    L += [f"        b{k}_{l} = {_b_entry(k, l)}" for k, l in sorted(need)]
    # T_b[k] = (B s_b)_k for the components k the columns meet
    comps = sorted({k for sv in svec for k in sv})
    for b in range(n):
        for k in comps:
            t = " + ".join(_times(cf, f"b{min(k, l)}_{max(k, l)}") for l, cf in svec[b].items())
            L.append(f"        tb{b}_{k} = {t}")
    L += _rows("J", n)
    if rods:
        L += [f"        kp{r}_{c} = Kp[_u({r * n + c} * BLK + j)]" for r in range(n) for c in range(n)]
    for i in range(n):
        L.append(f"        ga{i} = Lg[{i}, {GGA} * BLK + j]")
        if rods:
            L.append(f"        de{i} = Lg[{i}, {GDE} * BLK + j]")
        for b in range(n):
            if rods:
                L.append(f"        p{i}_{b} = ga{i} * j{i}_{b} + de{i} * kp{i}_{b}")
                L.append(f"        q{i}_{b} = de{i} * j{i}_{b}")
            else:
                L.append(f"        p{i}_{b} = ga{i} * j{i}_{b}")
    small = n <= 3 and not mass_only
    for a in range(n):
        for b in range(a, n):
            sbs = " + ".join(_times(cf, f"tb{b}_{k}") for k, cf in svec[a].items())
            if small:   # T = S^T B S only: the legs enter W directly (below)
                L.append(f"        m{a}_{b} = ({sbs})")
                continue
            legs = " + ".join(f"j{i}_{a} * p{i}_{b}" + (f" + kp{i}_{a} * q{i}_{b}" if rods else "") for i in range(n))
            L.append(f"        m{a}_{b} = ({sbs}) + ({legs})")
    if small:
        # W = U^T T + diag(gamma) J + diag(delta) K + (U^T K^T) diag(delta) J: U^T J_i^T = e_i (U = J^-1)
        L += [f"        u{r}_{c} = U[_u({r * n + c} * BLK + j)]" for r in range(n) for c in range(n)]
        if rods:
            for i in range(n):
                for k in range(n):
                    t = " + ".join(f"u{l}_{i} * kp{k}_{l}" for l in range(n))
                    L.append(f"        v{i}_{k} = {t}")
        for i in range(n):
            for b in range(n):
                t = " + ".join(f"u{k}_{i} * m{min(k, b)}_{max(k, b)}" for k in range(n))
                t = f"({t}) + ga{i} * j{i}_{b}"
                if rods:
                    v = " + ".join(f"v{i}_{k} * q{k}_{b}" for k in range(n))
                    t += f" + de{i} * kp{i}_{b} + ({v})"
                L.append(f"        W[_u({i * n + b} * BLK + j)] = {t}")
        return _source(L)
    if mass_only:
        L += [f"        W[_u({a * n + b} * BLK + j)] = m{min(a, b)}_{max(a, b)}" for a in range(n) for b in range(n)]
        return _source(L)
    L += [f"        u{r}_{c} = U[_u({r * n + c} * BLK + j)]" for r in range(n) for c in range(n) if not (upper and c < r)]
    for i in range(n):
        for b in range(n):
            t = " + ".join(f"u{k}_{i} * m{min(k, b)}_{max(k, b)}" for k in range(n) if not (upper and k > i))
            L.append(f"        W[_u({i * n + b} * BLK + j)] = {t}")
    return _source(L)


# ---------------------------------------------------------------------- the routines of a kernel
def _source(lines):
    return "\n".join(lines) + "\n"


#: the stubs of _kernels whose code is generated, in the order of routine_source
ROUTINES = ("_inverse", "_lmax_cols", "_lmax_rows", "_lmax_dyn", "_dyn_w", "_mass_p")


def routine_source(stub, n, spec=None, name="impl"):
    """The source of the kernel's routine ``stub`` for size n (spec: needed by
    _dyn_w and _mass_p only): _inverse (R^-1 of A = QR for n >= 4; None for
    n <= 3, where the kernel runs its hand-written adjugate _inverse_small),
    _lmax_cols (lambda_max(X^T X), X = J), _lmax_rows (lambda_max(X X^T) for X
    from _inverse, upper triangular for n >= 4), _lmax_dyn (lambda_max(W^T W),
    NEWTON_DYN steps), _dyn_w (W = U^T M_p), _mass_p (M_p, full)."""
    if stub == "_inverse":
        return qr_inverse_source(n, name) if n >= 4 else None
    if stub in ("_lmax_cols", "_lmax_rows", "_lmax_dyn"):
        mode = ("urows" if n >= 4 else "rows") if stub == "_lmax_rows" else "cols"
        return lmax_source(n, mode, NEWTON_DYN if stub == "_lmax_dyn" else NEWTON, name)
    if stub in ("_dyn_w", "_mass_p"):
        return dyn_source(spec, stub == "_mass_p", name)
    raise KeyError(stub)


def routines(spec: KernelSpec) -> dict[str, str]:
    """{stub: the source of a function of that name} for each routine generated for spec."""
    out = {s: routine_source(s, spec.n, spec, s) for s in ROUTINES}
    return {k: v for k, v in out.items() if v is not None}


def module_source(spec: KernelSpec, title: str) -> str:
    """The generated routines for spec as one module (``optdesign kernel-source``):
    a header that says what they are for (``title``: the mechanism and config),
    the names they use, then the routines."""
    from . import layout as _layout

    rs = routines(spec)
    hand = "" if "_inverse" in rs else "; _inverse is hand-written for n <= 3 (_inverse_small)"
    head = [f"# The generated routines of the described mechanisms' kernel for {title}:",
            f"# {spec!r}",
            f"# (n = {spec.n}; pose-column kinds: 0..5 twist components vx vy vz wx wy wz, 6 and 7 roll's",
            "# and pitch's Euler columns; rods: a leg has a rod; rot: the pose has angles).",
            "# Each function is what numba compiles for the stub of the same name in",
            "# optdesign/engine/kernels.py (there named impl), as written by optdesign/engine/codegen.py;",
            "# matrices are rows of BLK points: entry (r, c) of point j at [(r n + c) BLK + j].",
            f"# Routines: {', '.join(rs)}{hand}.",
            "import math", "", "from numba import uint64 as _u", "",
            "from optdesign.engine.kernels import _bisect_nt as _bisect_flagged",
            "from optdesign.fast._jit import lambda_max_psd as _lmax3_point", ""]
    head += [f"{k} = {getattr(_layout, k)!r}" for k in GLOBALS if hasattr(_layout, k)]
    return "\n".join(head) + "\n" + "".join(f"\n\n{src}" for src in rs.values())

"""
beadmob -- Python reference implementation of the multipole (Galerkin single-layer) method
for the friction of N equal spheres in Stokes flow, plus RPY, exact two-sphere values and
the lubrication (superposition) correction for rigid bodies.

See docs/theory.md for the equations; section numbers "T<n>" below refer to it.

Units: viscosity eta = 1, bead radius a = 1/2 (diameter 1) unless an argument says otherwise.
A single sphere has zeta_tt = 6 pi a = 3 pi, zeta_rr = 8 pi a^3 = pi.

Conventions
-----------
* Unknowns per sphere: coefficients of the induced surface force density f_i (force exerted
  by the sphere on the fluid) in an L2(S)-orthonormal basis of real vector spherical harmonics
  of degree n (= multipole order l) and three families sigma (T2):
      sigma = 0 : grad R_nk                  (orbital degree n-1; n=1 -> uniform density = force)
      sigma = 1 : x  cross grad R_nk         (orbital degree n  ; n=1 -> rigid-rotation density = torque)
      sigma = 2 : grad (R_nk / r^(2n+1))     (orbital degree n+1; n=1 -> potential (source) dipole)
  R_nk are real regular solid harmonics (k = -n..n).  Truncation at order L keeps
  sigma = 0, 1 for n <= L and sigma = 2 for n <= L2 (default L2 = L - 1, see theory.md T3).
* Galerkin matrix  A[(i,alpha),(j,beta)] = <f_alpha^i , S f_beta^j>  (S: Stokes single layer),
  symmetric positive definite; friction  zeta = B^T A^{-1} B, B = projections of rigid motions.
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from numpy.polynomial.legendre import leggauss

A_BEAD = 0.5


# ----------------------------------------------------------------------------------------------
# Solid harmonics (T1)
# ----------------------------------------------------------------------------------------------
def solid_table(X, N):
    """Complex regular solid harmonics R_n^m(X) = r^n P_n^m(cos th) e^{i m phi} / (n+m)!
    (Condon-Shortley phase), n <= N, |m| <= n.  Returns T[n, m+N+1, p] (zero outside |m|<=n).
    Recurrences: R_m^m = -(x+iy)/(2m) R_{m-1}^{m-1};
    (n-m+1)(n+m+1) R_{n+1}^m = (2n+1) z R_n^m - r^2 R_{n-1}^m;  R_n^{-m} = (-1)^m conj(R_n^m)."""
    x, y, z = X[:, 0], X[:, 1], X[:, 2]
    r2 = x * x + y * y + z * z
    off = N + 1
    T = np.zeros((N + 1, 2 * N + 3, X.shape[0]), complex)
    T[0, off] = 1.0
    xy = x + 1j * y
    for m in range(N + 1):
        if m > 0:
            T[m, off + m] = -xy / (2 * m) * T[m - 1, off + m - 1]
        for n in range(m, N):
            T[n + 1, off + m] = ((2 * n + 1) * z * T[n, off + m] - r2 * T[n - 1, off + m]) / (
                (n - m + 1) * (n + m + 1))
    for n in range(N + 1):
        for m in range(1, n + 1):
            T[n, off - m] = (-1) ** m * np.conj(T[n, off + m])
    return T


def d_table(T, c):
    """Cartesian derivative d/dx_c of every entry of a solid-harmonic table (ladder identities
    d_z R_n^m = R_{n-1}^m, (d_x + i d_y) R_n^m = R_{n-1}^{m+1}, (d_x - i d_y) R_n^m = -R_{n-1}^{m-1})."""
    D = np.zeros_like(T)
    if c == 2:
        D[1:] = T[:-1]
    elif c == 0:
        D[1:, 1:-1] = 0.5 * (T[:-1, 2:] - T[:-1, :-2])
    else:
        D[1:, 1:-1] = (T[:-1, 2:] + T[:-1, :-2]) / 2j
    return D


def _real(T, N):
    """Real solid harmonics table Rr[n, k+N, p]: k=0 -> R_n^0, k>0 -> Re R_n^k, k<0 -> Im R_n^|k|."""
    off = N + 1
    out = np.zeros((N + 1, 2 * N + 1) + T.shape[2:])
    for k in range(-N, N + 1):
        src = T[:, off + abs(k)]
        out[:, k + N] = src.imag if k < 0 else src.real
    return out


def harmonic_data(X, N, hessian=False):
    """Real R, grad R (and Hessian) tables at points X (p,3)."""
    T = solid_table(X, N)
    D = [d_table(T, c) for c in range(3)]
    R = _real(T, N)
    G = np.stack([_real(Dc, N) for Dc in D], axis=2)  # (N+1, 2N+1, 3, p)
    if not hessian:
        return R, G
    H = np.stack([np.stack([_real(d_table(D[c], e), N) for e in range(3)], axis=2)
                  for c in range(3)], axis=2)  # (N+1,2N+1,3,3,p)
    return R, G, H


# ----------------------------------------------------------------------------------------------
# Lamb's solution (T1): exterior / interior velocity fields built on a harmonic h
# ----------------------------------------------------------------------------------------------
def lamb_AB(n, exterior):
    """u_P = A r^2 grad h + B x h, p = h (eta = 1). Interior h = r^n Y, exterior h = r^{-n-1} Y."""
    if exterior:
        return (2.0 - n) / (2.0 * n * (2 * n - 1)), (n + 1.0) / (n * (2 * n - 1))
    return (n + 3.0) / (2.0 * (n + 1) * (2 * n + 3)), -n / ((n + 1.0) * (2 * n + 3))


def _ext_h(R, G, X, n, H=None):
    """h = R/r^(2n+1) with gradient (and Hessian) for one degree n; R (..,p), G (..,3,p)."""
    r2 = (X ** 2).sum(1)
    q = 2 * n + 1
    rho = r2 ** (-q / 2)
    drho = -q * X.T * r2 ** (-(q + 2) / 2)  # (3,p)
    h = R * rho
    gh = G * rho + R[..., None, :] * drho
    if H is None:
        return h, gh
    I3 = np.eye(3)[:, :, None]
    ddrho = -q * r2 ** (-(q + 2) / 2) * I3 + q * (q + 2) * np.einsum('pi,pj->ijp', X, X) * r2 ** (-(q + 4) / 2)
    hh = (H * rho + G[..., :, None, :] * drho[None, :, :] + G[..., None, :, :] * drho[:, None, :]
          + R[..., None, None, :] * ddrho)
    return h, gh, hh


def _lamb_u(h, gh, X, A, B):
    """velocities of the three Lamb fields (P, Phi, chi) -> (...,3 types,3,p)."""
    r2 = (X ** 2).sum(1)
    uP = A * r2 * gh + B * X.T * h[..., None, :]
    uF = gh
    uC = np.cross(gh, X.T, axis=-2)
    return np.stack([uP, uF, uC], axis=-3)


def _lamb_traction(h, gh, hh, X, A, B):
    """tractions sigma.n (n = x/|x|) of the three Lamb fields; eta = 1."""
    r = np.sqrt((X ** 2).sum(1))
    nrm = X.T / r
    r2 = r * r
    I3 = np.eye(3)[:, :, None]
    # grad u [k, i] = d_k u_i
    gP = A * (2 * X.T[:, None, :] * gh[..., None, :, :] + r2 * hh) + B * (I3 * h[..., None, None, :]
                                                                          + X.T[None, :, :] * gh[..., :, None, :])
    gF = hh
    eps = np.zeros((3, 3, 3))
    eps[0, 1, 2] = eps[1, 2, 0] = eps[2, 0, 1] = 1
    eps[0, 2, 1] = eps[2, 1, 0] = eps[1, 0, 2] = -1
    gC = np.einsum('ijl,...kjp,lp->...kip', eps, hh, X.T) + np.einsum('ijk,...jp->...kip', eps, gh)
    out = []
    for gu, p in ((gP, h), (gF, 0 * h), (gC, 0 * h)):
        sym = gu + np.swapaxes(gu, -3, -2)
        t = np.einsum('...kip,kp->...ip', sym, nrm) - p[..., None, :] * nrm
        out.append(t)
    return np.stack(out, axis=-3)


@lru_cache(maxsize=None)
def single_layer_coeffs(n, a=A_BEAD):
    """Closed form (theory.md T2) of the exterior Lamb coefficients (cP, cPhi, cchi) of the
    single-layer field of the density families sigma = 0, 1, 2 of degree n on a sphere of radius a:
      sigma=0: cP = n a^(2n), cPhi = n a^(2n+2) / (2(2n+1));   sigma=1: cchi = -a^(2n+2)/(2n+1);
      sigma=2: cPhi = a n / ((2n+1)(2n+3)).
    Verified against the numerical jump problem `single_layer_coeffs_numeric` in the tests."""
    C = np.zeros((3, 3))
    C[0, 0] = n * a ** (2 * n)
    C[0, 1] = n * a ** (2 * n + 2) / (2.0 * (2 * n + 1))
    C[1, 2] = -a ** (2 * n + 2) / (2.0 * n + 1)
    C[2, 1] = a * n / ((2.0 * n + 1) * (2 * n + 3))
    return C


def single_layer_coeffs_numeric(n, a=A_BEAD):
    """Exterior Lamb coefficients (cP, cPhi, cchi) of the single-layer field of each density family
    sigma = 0, 1, 2 of degree n on a sphere of radius a (T2).  Solved from: velocity continuous,
    traction jump  t_in - t_out = f  (f = force density on the fluid).  Returns array (3 sigma, 3)."""
    rng = np.random.default_rng(1234 + n)
    P = 8 * n + 24
    Y = rng.normal(size=(P, 3))
    Y = a * Y / np.linalg.norm(Y, axis=1)[:, None]
    R, G, H = harmonic_data(Y, n, hessian=True)
    k = n + 1  # real index k = 1 (Re R_n^1): generic, non-axisymmetric
    R, G, H = R[n, k], G[n, k], H[n, k]
    he, ghe, hhe = _ext_h(R, G, Y, n, H)
    Ae, Be = lamb_AB(n, True)
    Ai, Bi = lamb_AB(n, False)
    ue = _lamb_u(he, ghe, Y, Ae, Be)  # (3 types,3,P)
    ui = _lamb_u(R, G, Y, Ai, Bi)
    te = _lamb_traction(he, ghe, hhe, Y, Ae, Be)
    ti = _lamb_traction(R, G, H, Y, Ai, Bi)
    dens = [G, np.cross(Y.T, G, axis=0), ghe]
    M = np.zeros((6 * P, 6))
    for t in range(3):
        M[:3 * P, t] = ue[t].ravel()
        M[:3 * P, 3 + t] = -ui[t].ravel()
        M[3 * P:, t] = -te[t].ravel()
        M[3 * P:, 3 + t] = ti[t].ravel()
    C = np.zeros((3, 3))
    for s in range(3):
        rhs = np.concatenate([np.zeros(3 * P), dens[s].ravel()])
        cs = np.linalg.norm(M, axis=0)  # column equilibration (columns scale like a^(+-n))
        sol, res, rank, _ = np.linalg.lstsq(M / cs, rhs, rcond=None)
        sol = sol / cs
        assert rank == 6
        assert np.linalg.norm(M @ sol - rhs) < 1e-9 * np.linalg.norm(rhs), 'jump problem not consistent'
        C[s] = sol[:3]
    return C


# ----------------------------------------------------------------------------------------------
# Basis bookkeeping
# ----------------------------------------------------------------------------------------------
def basis_list(L, L2=None, kset=None):
    """List of (n, sigma, k) kept at truncation order L (sigma=2 only for n <= L2)."""
    if L2 is None:
        L2 = L - 1
    out = []
    for n in range(1, L + 1):
        for s in (0, 1, 2):
            if s == 2 and n > L2:
                continue
            for k in range(-n, n + 1):
                if kset is not None and abs(k) not in kset:
                    continue
                out.append((n, s, k))
    return out


def sphere_quadrature(center, axis, a, nt, nphi):
    """Gauss-Legendre (in cos theta about `axis`) x trapezoid (phi) rule on a sphere."""
    e3 = np.asarray(axis, float)
    e3 = e3 / np.linalg.norm(e3)
    tmp = np.array([1.0, 0, 0]) if abs(e3[0]) < 0.9 else np.array([0, 1.0, 0])
    e1 = np.cross(e3, tmp)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(e3, e1)
    t, wt = leggauss(nt)
    phi = 2 * np.pi * np.arange(nphi) / nphi
    st = np.sqrt(1 - t * t)
    nh = (st[:, None, None] * (np.cos(phi)[None, :, None] * e1 + np.sin(phi)[None, :, None] * e2)
          + t[:, None, None] * e3).reshape(-1, 3)
    w = (wt[:, None] * np.ones(nphi)[None, :] * (2 * np.pi / nphi) * a * a).ravel()
    return np.asarray(center) + a * nh, w


def _densities(Y, basis, N, a, norms=None):
    """Densities of the basis functions at points Y (relative to own centre, |Y| = a): (nb,3,p)."""
    R, G = harmonic_data(Y, N)
    out = np.zeros((len(basis), 3, Y.shape[0]))
    for b, (n, s, k) in enumerate(basis):
        if s == 0:
            out[b] = G[n, k + N]
        elif s == 1:
            out[b] = np.cross(Y.T, G[n, k + N], axis=0)
        else:
            out[b] = _ext_h(R[n, k + N], G[n, k + N], Y, n)[1]
    if norms is not None:
        out /= norms[:, None, None]
    return out


def _fields(X, basis, N, a, norms):
    """Single-layer (exterior) velocity fields of the normalized basis densities at X (relative to the
    source centre, |X| >= a): (nb,3,p)."""
    R, G = harmonic_data(X, N)
    out = np.zeros((len(basis), 3, X.shape[0]))
    cache = {}
    for b, (n, s, k) in enumerate(basis):
        key = (n, k)
        if key not in cache:
            h, gh = _ext_h(R[n, k + N], G[n, k + N], X, n)
            cache[key] = _lamb_u(h, gh, X, *lamb_AB(n, True))
        C = single_layer_coeffs(n, a)[s]
        u = cache[key]
        out[b] = (C[0] * u[0] + C[1] * u[1] + C[2] * u[2]) / norms[b]
    return out


@lru_cache(maxsize=None)
def _norms(basis_key, a):
    basis = list(basis_key)
    N = max(n for n, _, _ in basis)
    Y, w = sphere_quadrature(np.zeros(3), [0, 0, 1], a, N + 4, 2 * N + 6)
    d = _densities(Y, basis, N, a)
    return np.sqrt(np.einsum('bip,bip,p->b', d, d, w))


def _nquad(L, r, a):
    """Quadrature sizes for a pair at centre distance r (T4): Gauss-Legendre in cos(theta) about the
    pair axis converges like rho^(-2 nt), rho the Bernstein-ellipse parameter of the pole of
    |x - R_j|^(-1) at t0 = (a^2 + r^2)/(2 a r)."""
    if r < 1e-12:
        return L + 4, 2 * L + 6
    t0 = (a * a + r * r) / (2 * a * r)
    rho = t0 + math.sqrt(t0 * t0 - 1)
    nt = int(math.ceil((40.0 + 1.5 * (L + 3)) / math.log(rho) / 1.0)) // 2 + L + 8
    return min(max(nt, L + 8), 400), 2 * L + 8


# ----------------------------------------------------------------------------------------------
# Galerkin operator and friction (T3, T5, T6)
# ----------------------------------------------------------------------------------------------
def pair_block(Ri, Rj, basis, a=A_BEAD):
    """A_ij[alpha, beta] = int_{S_i} f_alpha^i . (S f_beta^j) dS  (T4).  Also used for i = j."""
    N = max(n for n, _, _ in basis)
    norms = _norms(tuple(basis), a)
    d = np.asarray(Rj, float) - np.asarray(Ri, float)
    r = np.linalg.norm(d)
    nt, nphi = _nquad(N, r, a)
    axis = d if r > 1e-12 else np.array([0, 0, 1.0])
    Xq, w = sphere_quadrature(Ri, axis, a, nt, nphi)
    dens = _densities(Xq - Ri, basis, N, a, norms)
    fld = _fields(Xq - Rj, basis, N, a, norms)
    return np.einsum('aip,bip,p->ab', dens, fld, w)


def rigid_projection(Ri, basis, a=A_BEAD):
    """B_i[alpha, mode]: projections of unit translations (0..2) and rotations about R_i (3..5)."""
    N = max(n for n, _, _ in basis)
    norms = _norms(tuple(basis), a)
    Xq, w = sphere_quadrature(Ri, [0, 0, 1.0], a, N + 4, 2 * N + 6)
    Y = Xq - Ri
    dens = _densities(Y, basis, N, a, norms)
    B = np.zeros((len(basis), 6))
    for c in range(3):
        e = np.zeros(3)
        e[c] = 1
        B[:, c] = np.einsum('aip,i,p->a', dens, e, w)
        u = np.cross(e, Y)  # Omega x (x - R_i)
        B[:, 3 + c] = np.einsum('aip,pi,p->a', dens, u, w)
    return B


def grand_operator(centers, L, L2=None, kset=None, a=A_BEAD):
    centers = np.asarray(centers, float)
    basis = basis_list(L, L2, kset)
    nb = len(basis)
    Ns = len(centers)
    A = np.zeros((Ns * nb, Ns * nb))
    self_blk = pair_block(centers[0], centers[0], basis, a)
    for i in range(Ns):
        A[i * nb:(i + 1) * nb, i * nb:(i + 1) * nb] = self_blk  # translation invariant
        for j in range(i + 1, Ns):
            blk = pair_block(centers[i], centers[j], basis, a)
            A[i * nb:(i + 1) * nb, j * nb:(j + 1) * nb] = blk
            A[j * nb:(j + 1) * nb, i * nb:(i + 1) * nb] = blk.T
    B = np.zeros((Ns * nb, 6 * Ns))
    Bi = rigid_projection(np.zeros(3), basis, a)  # translation invariant
    for i in range(Ns):
        B[i * nb:(i + 1) * nb, 6 * i:6 * i + 6] = Bi
    return A, B, basis


def friction_spheres(centers, L, L2=None, kset=None, a=A_BEAD):
    """6N x 6N order-L friction of N free spheres (rows/cols: F_i, T_i / U_i, Omega_i per sphere)."""
    A, B, _ = grand_operator(centers, L, L2, kset, a)
    c = np.linalg.cholesky(A)  # SPD check
    Y = np.linalg.solve(c, B)
    Z = Y.T @ Y
    return 0.5 * (Z + Z.T)


def rigid_transfer(centers, ref):
    """P (6N x 6): sphere velocities (U_i, Omega_i) from body (U, Omega) about ref."""
    centers = np.asarray(centers, float)
    P = np.zeros((6 * len(centers), 6))
    for i, c in enumerate(centers):
        d = c - ref
        P[6 * i:6 * i + 3, :3] = np.eye(3)
        # U_i = U + Omega x d = U - [d]x Omega
        P[6 * i:6 * i + 3, 3:] = -np.array([[0, -d[2], d[1]], [d[2], 0, -d[0]], [-d[1], d[0], 0]])
        P[6 * i + 3:6 * i + 6, 3:] = np.eye(3)
    return P


def friction_rigid(centers, L, ref=None, L2=None, a=A_BEAD):
    """6x6 order-L friction (no lubrication) of the rigid body made of the spheres."""
    centers = np.asarray(centers, float)
    ref = centers.mean(0) if ref is None else np.asarray(ref, float)
    P = rigid_transfer(centers, ref)
    return P.T @ friction_spheres(centers, L, L2, a=a) @ P


# ----------------------------------------------------------------------------------------------
# Rotne-Prager-Yamakawa grand mobility (T7)
# ----------------------------------------------------------------------------------------------
def rpy_mobility(centers, a=A_BEAD, eta=1.0):
    """6N x 6N RPY mobility (translation and rotation), non-overlapping spheres."""
    centers = np.asarray(centers, float)
    Ns = len(centers)
    M = np.zeros((6 * Ns, 6 * Ns))
    I = np.eye(3)
    for i in range(Ns):
        M[6 * i:6 * i + 3, 6 * i:6 * i + 3] = I / (6 * np.pi * eta * a)
        M[6 * i + 3:6 * i + 6, 6 * i + 3:6 * i + 6] = I / (8 * np.pi * eta * a ** 3)
        for j in range(Ns):
            if i == j:
                continue
            rv = centers[i] - centers[j]
            r = np.linalg.norm(rv)
            e = rv / r
            ee = np.outer(e, e)
            tt = ((1 + 2 * a * a / (3 * r * r)) * I + (1 - 2 * a * a / (r * r)) * ee) / (8 * np.pi * eta * r)
            rr = (3 * ee - I) / (16 * np.pi * eta * r ** 3)
            ex = np.array([[0, -e[2], e[1]], [e[2], 0, -e[0]], [-e[1], e[0], 0]])
            # Omega_i = (F_j x e)/(8 pi eta r^2) and U_i = (T_j x e)/(8 pi eta r^2), e = (R_i - R_j)/r
            rt = -ex / (8 * np.pi * eta * r * r)
            M[6 * i:6 * i + 3, 6 * j:6 * j + 3] = tt
            M[6 * i + 3:6 * i + 6, 6 * j + 3:6 * j + 6] = rr
            M[6 * i + 3:6 * i + 6, 6 * j:6 * j + 3] = rt
            M[6 * i:6 * i + 3, 6 * j + 3:6 * j + 6] = rt
    return M


# ----------------------------------------------------------------------------------------------
# Exact two-sphere values (T8)
# ----------------------------------------------------------------------------------------------
def _bisph_alpha(r, a):
    return math.acosh(r / (2 * a))


def stimson_jeffery(r, a=A_BEAD, tol=1e-15, nmax=2_000_000):
    """Drag per sphere / (6 pi eta a U) for two equal spheres translating with the same velocity
    along their line of centres (Stimson & Jeffery 1926; Happel & Brenner 1965, sec. 6.3); r = centre
    distance.  r = 2a (contact) is handled by the alpha -> 0 limit (see stimson_jeffery_contact)."""
    if r <= 2 * a * (1 + 1e-14):
        return stimson_jeffery_contact()
    al = _bisph_alpha(r, a)
    s = 0.0
    n = np.arange(1, nmax + 1, dtype=float)
    # term_n; numerically stable in terms of exponentials for large n*alpha
    for start in range(0, nmax, 20000):
        nn = n[start:start + 20000]
        x = (2 * nn + 1) * al
        with np.errstate(over='ignore', invalid='ignore'):
            num = 4 * np.sinh(x / 2) ** 2 - (2 * nn + 1) ** 2 * math.sinh(al) ** 2
            den = 2 * np.sinh(x) + (2 * nn + 1) * math.sinh(2 * al)
            frac = np.where(x < 600, num / den, 1.0 - 0.0)
        big = x >= 600
        frac = np.where(big, 1.0, frac)  # 4 sinh^2(x/2)/(2 sinh x) -> 1
        t = nn * (nn + 1) / ((2 * nn - 1) * (2 * nn + 3)) * (1 - frac)
        s += t.sum()
        if abs(t[-1]) < tol * abs(s) and (start > 0 or len(nn) > 10):
            break
    return 4.0 / 3.0 * math.sinh(al) * s


def maude_approach(r, a=A_BEAD, nmax=100000):
    """Drag per sphere / (6 pi eta a U) for two equal spheres approaching each other along the line of
    centres with speeds U (Maude 1961; Brenner 1961, two-sphere form; bispherical coordinates, cosh alpha
    = r/(2a)):  (4/3) sinh(alpha) sum_n n(n+1)/((2n-1)(2n+3)) *
      [ (4 cosh^2((n+1/2) alpha) + (2n+1)^2 sinh^2 alpha) / (2 sinh((2n+1) alpha) - (2n+1) sinh(2 alpha)) - 1 ].
    NB: the mid-plane is a symmetry (slip) plane here, NOT a wall: the sphere-wall formula does not apply."""
    al = _bisph_alpha(r, a)
    s = 0.0
    for n in range(1, nmax):
        x = (2 * n + 1) * al
        if x > 700:
            break
        num = 4 * math.cosh(x / 2) ** 2 + (2 * n + 1) ** 2 * math.sinh(al) ** 2
        den = 2 * math.sinh(x) - (2 * n + 1) * math.sinh(2 * al)
        t = n * (n + 1) / ((2 * n - 1) * (2 * n + 3)) * (num / den - 1)
        s += t
        if abs(t) < 1e-17 * abs(s):
            break
    return 4.0 / 3.0 * math.sinh(al) * s


def jeffery_counter_rotation(r, a=A_BEAD, tol=1e-16):
    """Torque per sphere / (8 pi eta a^3 Omega) for two equal spheres rotating about their line of centres
    with opposite angular velocities (mid-plane = no-slip wall): Jeffery (1915), sphere rotating about
    the normal of a plane wall,  T = 8 pi eta a^3 Omega sinh^3(alpha) sum_{n>=1} csch^3(n alpha)."""
    al = _bisph_alpha(r, a)
    s, n = 0.0, 1
    while True:
        t = 1.0 / math.sinh(n * al) ** 3
        s += t
        if t < tol * s:
            break
        n += 1
    return math.sinh(al) ** 3 * s


def stimson_jeffery_contact():
    """alpha -> 0 (contact) limit of the Stimson-Jeffery series (the series itself is 0/0 at alpha = 0):
    evaluated at alpha = 0.005 ... 0.02 and extrapolated with a cubic in alpha.  Result 0.6451414."""
    return _sj_contact_cached()


@lru_cache(maxsize=None)
def _sj_contact_cached():
    a = A_BEAD
    als = np.array([0.02, 0.015, 0.01, 0.0075, 0.005])
    vals = np.array([stimson_jeffery(2 * a * math.cosh(x), a) for x in als])
    # fit in powers of alpha (regular expansion: lambda(alpha) = l0 + l2 alpha^2 + ...); use degree 3 in alpha
    c = np.polyfit(als, vals, 3)
    return float(c[-1])


# ----------------------------------------------------------------------------------------------
# Two spheres on the z axis: resistance functions from the multipole method (T6, T8)
# ----------------------------------------------------------------------------------------------
def two_sphere_modes(r, L, L2=None, a=A_BEAD):
    """Order-L two-sphere friction in symmetric/antisymmetric modes (spheres at -r/2, +r/2 on z).
    Returns dict of normalized coefficients:
      XA_sym = force per sphere /(6 pi a U) (both move +U e_z)        [Stimson-Jeffery]
      XA_anti = same for approach (sphere 1 +U, sphere 2 -U)          [Maude 1961]
      XC_sym / XC_anti = torque per sphere /(8 pi a^3 Omega), axial co-/counter-rotation
      Y_sym (2x2), Y_anti (2x2): transverse translation (x) and rotation (y) blocks, rows/cols
                                  (F_x/(6 pi a), T_y/(8 pi a^3)) of sphere 1 for the mode."""
    c = np.array([[0, 0, -r / 2], [0, 0, r / 2]])
    out = {}
    z0 = friction_spheres(c, L, L2, kset={0}, a=a)
    z1 = friction_spheres(c, L, L2, kset={1}, a=a)
    st, sr = 6 * np.pi * a, 8 * np.pi * a ** 3
    out['XA_sym'] = (z0[2, 2] + z0[2, 8]) / st
    out['XA_anti'] = (z0[2, 2] - z0[2, 8]) / st
    out['XC_sym'] = (z0[5, 5] + z0[5, 11]) / sr
    out['XC_anti'] = (z0[5, 5] - z0[5, 11]) / sr
    idx1, idx2 = [0, 4], [6, 10]
    S = z1[np.ix_(idx1, idx1)] + z1[np.ix_(idx1, idx2)]
    D = z1[np.ix_(idx1, idx1)] - z1[np.ix_(idx1, idx2)]
    scale = np.array([st, sr])
    out['YA_sym'] = S[0, 0] / st
    out['YA_anti'] = D[0, 0] / st
    out['YB_sym'] = S[1, 0] / math.sqrt(st * sr)
    out['YB_anti'] = D[1, 0] / math.sqrt(st * sr)
    out['YC_sym'] = S[1, 1] / sr
    out['YC_anti'] = D[1, 1] / sr
    return out


def doublet_friction_axial(r, L, L2=None, a=A_BEAD):
    """Rigid-doublet 6x6 friction about the pair midpoint, pair axis = z, from the order-L method.
    Uses the exact symmetry reduction (|k| = 0 and |k| = 1 decouple for an axial pair)."""
    c = np.array([[0, 0, -r / 2], [0, 0, r / 2]])
    P = rigid_transfer(c, np.zeros(3))
    Z = np.zeros((6, 6))
    for ks in ({0}, {1}):
        Z += P.T @ friction_spheres(c, L, L2, kset=ks, a=a) @ P
    return 0.5 * (Z + Z.T)


def doublet_exact_axial(r, a=A_BEAD, Lref=None, L2=None):
    """'Exact' rigid-doublet 6x6 friction about the midpoint (axis z).  Axial translation from the
    Stimson-Jeffery series (independent, exact); all other entries from the multipole method at high
    order Lref = 30 (rigid-doublet modes converge to <~1e-8 even at contact, see theory.md T8)."""
    if Lref is None:
        Lref = 30
    Z = doublet_friction_axial(r, Lref, L2, a)
    Z[2, 2] = 2 * 6 * np.pi * a * stimson_jeffery(r, a)
    return Z


def rotate_6x6(Z, Rm):
    """Friction of the same doublet after rotating the body by Rm (3x3)."""
    Q = np.zeros((6, 6))
    Q[:3, :3] = Rm
    Q[3:, 3:] = Rm
    return Q @ Z @ Q.T


def rot_z_to(e):
    """Rotation matrix taking e_z to the unit vector e."""
    e = np.asarray(e, float) / np.linalg.norm(e)
    z = np.array([0, 0, 1.0])
    v = np.cross(z, e)
    c = z @ e
    if np.linalg.norm(v) < 1e-14:
        return np.eye(3) if c > 0 else np.diag([1, -1, -1.0])
    vx = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + vx + vx @ vx / (1 + c)


# ----------------------------------------------------------------------------------------------
# Lubrication-corrected rigid-body friction (T9)
# ----------------------------------------------------------------------------------------------
def friction_rigid_lubricated(centers, L, ref=None, cutoff=None, L2=None, a=A_BEAD, exact_table=None):
    """zeta = P^T zeta_L P + sum_{pairs, r < cutoff} T_p^T [Z_exact(r) - Z_L(r)]_rotated T_p.
    Z(r): rigid-doublet 6x6 about the pair midpoint (axis z), rotated to the pair direction;
    T_p maps body (U, Omega about ref) to pair-midpoint (U, Omega)."""
    centers = np.asarray(centers, float)
    ref = centers.mean(0) if ref is None else np.asarray(ref, float)
    cutoff = 4 * a * 1.0001 if cutoff is None else cutoff
    Z = friction_rigid(centers, L, ref, L2, a)
    cache = {} if exact_table is None else exact_table
    for i in range(len(centers)):
        for j in range(i + 1, len(centers)):
            d = centers[j] - centers[i]
            r = np.linalg.norm(d)
            if r >= cutoff:
                continue
            key = (round(r, 12), L, L2)
            if key not in cache:
                cache[key] = doublet_exact_axial(r, a) - doublet_friction_axial(r, L, L2, a)
            Dz = rotate_6x6(cache[key], rot_z_to(d))
            mid = 0.5 * (centers[i] + centers[j])
            T = rigid_transfer(mid[None, :], ref)
            Z += T.T @ Dz @ T
    return Z


# ----------------------------------------------------------------------------------------------
# Convergence table (deliverable 3)
# ----------------------------------------------------------------------------------------------
def convergence_table(path, distances=(2.5, 3.0, 4.0, 6.0), Ls=(1, 2, 3, 4, 6, 8, 10, 12), Lref=30):
    a = A_BEAD
    lines = ['# Two-sphere convergence of the order-L multipole (Galerkin) friction',
             '',
             'Generated by `multipole_reference.convergence_table` (docs/prototype). Units: eta = 1,',
             'a = 1/2; values normalised by the single-sphere 6 pi eta a (translation) and 8 pi eta a^3',
             '(rotation), sqrt of their product for the coupling Y^B.  Modes: sym = both spheres move',
             'the same way, anti = opposite.  Distances are centre-to-centre in units of a.',
             '',
             'References ("exact" row): XA_sym = Stimson & Jeffery (1926) series; XA_anti = Maude (1961) /',
             'Brenner (1961) two-sphere series; XC_anti = Jeffery (1915) series; all others = this method at L = %d (converged, see' % Lref,
             'the "L=%d - L=%d" row for the size of the last change).' % (Lref, Lref - 6),
             '']
    keys = ['XA_sym', 'XA_anti', 'XC_sym', 'XC_anti', 'YA_sym', 'YA_anti', 'YB_sym', 'YB_anti', 'YC_sym',
            'YC_anti']
    for rr in distances:
        r = rr * a
        ref = two_sphere_modes(r, Lref)
        ref6 = two_sphere_modes(r, Lref - 6)
        exact = dict(ref)
        exact['XA_sym'] = stimson_jeffery(r)
        exact['XA_anti'] = maude_approach(r)
        exact['XC_anti'] = jeffery_counter_rotation(r)
        lines.append('## r = %.1f a' % rr)
        lines.append('')
        lines.append('| L | ' + ' | '.join(keys) + ' |')
        lines.append('|---' * (len(keys) + 1) + '|')
        for L in Ls:
            m = two_sphere_modes(r, L)
            lines.append('| %d | ' % L + ' | '.join('%.9f' % m[k] for k in keys) + ' |')
        lines.append('| exact | ' + ' | '.join('%.9f' % exact[k] for k in keys) + ' |')
        lines.append('| L=%d - L=%d | ' % (Lref, Lref - 6) + ' | '.join('%.1e' % (ref[k] - ref6[k]) for k in keys) + ' |')
        m12 = two_sphere_modes(r, 12)
        lines.append('| err(L=12) | ' + ' | '.join('%.1e' % (m12[k] - exact[k]) for k in keys) + ' |')
        lines.append('')
    with open(path, 'w') as fh:
        fh.write('\n'.join(lines) + '\n')
    return '\n'.join(lines)


if __name__ == '__main__':
    import os
    here = os.path.dirname(os.path.abspath(__file__))
    print(convergence_table(os.path.join(here, 'two_sphere_convergence.md')))

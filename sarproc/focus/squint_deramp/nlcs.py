"""Modified nonlinear chirp scaling (NLCS) for the azimuth compression of flow 2 (An et al. 2012, sec. 4.2).

In the range-Doppler domain at range bin r (= r_LRWC = r_0 + x_n sin(theta), eq. 16) a target
at azimuth time t_n has, after the range-invariant higher-order compensation of eq. (22),

    Phi_1(f) = -2 pi f t_n - (pi / K) (1 - eps t_n) f^2 + pi p t_n f^3          (eq. 23)
    K = K_LRWC = -2 v^2 cos^2(theta) / (lambda r),   eps = v sin(theta) / r,
    p = psi'_{3,s} = v sin(theta) g_3 / pi,           g_3 = -2 pi sin(theta) / (lambda cos(theta) f_aM^3).

(The f^2 coefficient is exactly linear in t_n because r_0 = r - v t_n sin(theta); eq. (20)'s
second-order expansion of K_a is the same thing seen in the time domain.) The quartic filter
exp(j pi (Y3 f^3 + Y4 f^4)) (eq. 24), an azimuth IFFT, the scaling exp(j pi (q2 t^2 + q3 t^3 +
q4 t^4)) (eq. 27) and an FFT give a spectrum whose group delay is t(F; t_n). Requiring
t = a(F) + t_n / (2 alpha) + O(t_n^3) - the conditions of eq. (30) written on the group delay -
and solving order by order (our derivation, stationary phase, checked against point-target
simulations) gives

    q2 = K (2 alpha - 1)                         (eq. 31)
    q3 = eps q2 / 3 = eps K (2 alpha - 1) / 3    (eq. 31 with K_s read as eps)
    Y3 = eps (4 alpha - 1) / (3 K^2 (2 alpha - 1))  (eq. 31 with K_s read as eps K)
    q4, Y4: the 2 x 2 linear system of the third-order conditions (t_n F^2 and t_n^2 F terms),
            solved numerically per range bin (eq. 31's printed q4, Y4 are not dimensionally
            consistent, so they are not used).

The azimuth filter (eq. 33) is exp(-j Theta_0(F)) with Theta_0 the exact (numerical) double
stationary-phase transform at t_n = 0, so no truncation is made in the range-invariant part.
A target then lands at t_n / (2 alpha) + c3 t_n^3 (c3 reported by :func:`position_terms`).

Variants (the paper's special cases): ``modified`` (all of the above, with eq. 22),
``separated`` (two-dimension-separated: q2, q3, Y3 only, q4 = Y4 = 0, no eq. 22, filter up to the
cubic term), ``classic`` (q2 = q4 = Y3 = Y4 = 0, q3 = -eps K / 3 equalising the FM rate, alpha = 1/2,
no eq. 22; leaves the t_n^2 position distortion that classic NLCS corrects in the image domain).
"""

from __future__ import annotations

import numpy as np

VARIANTS = ("modified", "classic", "separated")


def nlcs_coefficients(
    K: np.ndarray | float, eps: np.ndarray | float, p: np.ndarray | float, alpha: float, variant: str = "modified"
) -> dict:
    """q2, q3, q4, Y3, Y4 (arrays like K) for scaling exp(j pi (q2 t^2 + q3 t^3 + q4 t^4)).

    K: FM rate at each range bin (Hz/s, negative), eps = v sin(theta) / r (1/s), p: cubic
    space-variant coefficient (s^2). Raises ValueError for alpha too close to 1/2.
    """
    K = np.asarray(K, float)
    eps = np.broadcast_to(np.asarray(eps, float), K.shape)
    p = np.broadcast_to(np.asarray(p, float), K.shape)
    if variant not in VARIANTS:
        raise ValueError(f"unknown NLCS variant {variant!r}; known: {VARIANTS}")
    zero = np.zeros_like(K)
    if variant == "classic":
        return {"q2": zero, "q3": -eps * K / 3.0, "q4": zero, "Y3": zero, "Y4": zero, "alpha": 0.5}
    a2 = 2.0 * alpha - 1.0
    if abs(a2) < 1e-3:
        raise ValueError(f"alpha = {alpha} is singular (eq. 31 divides by 2 alpha - 1)")
    q2 = K * a2
    q3 = eps * q2 / 3.0
    Y3 = eps * (4 * alpha - 1) / (3 * K**2 * a2)
    if variant == "separated":
        return {"q2": q2, "q3": q3, "q4": zero, "Y3": Y3, "Y4": zero, "alpha": alpha}
    D = K + q2
    beta = -1.5 * (q3 + K**3 * Y3) / D**3
    # third-order conditions (coefficients of t_n F^2 and t_n^2 F of the group delay, times D^3):
    #   c1 + a11 q4 + a12 Y4 = 0,   c2 + a21 q4 + a22 Y4 = 0
    c1 = (
        eps * q2 * beta * D**3
        - 3 * q3 * beta * K * D**2
        + 1.5 * eps * q3 * D
        - 3 * K**2 * Y3 * q2**2 * beta * D**2
        + 4.5 * K**2 * Y3 * q3 * (2 * K - q2)
        - 1.5 * K**3 * p * D
    )
    a11, a12 = -6 * K, 6 * K**4 * q2
    c2 = 3 * eps * q3 * K * D + 4.5 * K**2 * Y3 * q3 * (K**2 - 2 * K * q2) + 3 * K**3 * p * q2 * D
    a21, a22 = -6 * K**2, -6 * K**4 * q2**2
    det = a11 * a22 - a12 * a21
    q4 = (-c1 * a22 + c2 * a12) / det
    Y4 = (-a11 * c2 + a21 * c1) / det
    return {"q2": q2, "q3": q3, "q4": q4, "Y3": Y3, "Y4": Y4, "alpha": alpha}


def position_terms(K: np.ndarray | float, eps: np.ndarray | float, p: np.ndarray | float, co: dict) -> dict:
    """Image position t_img = a1 t_n + c2 t_n^2 + c3 t_n^3 (stationary phase, group delay at F = 0)."""
    K = np.asarray(K, float)
    q2, q3, q4, Y3, Y4 = (np.asarray(co[k], float) for k in ("q2", "q3", "q4", "Y3", "Y4"))
    D = K + q2
    a1 = K / D
    c2 = (eps * K * q2 / D - 1.5 * q3 * K**2 / D**2 - 1.5 * K**3 * Y3 * q2**2 / D**2) / D
    c3 = (
        1.5 * eps * q3 * K**2 * D
        - 2 * q4 * K**3
        - 4.5 * K**4 * Y3 * q3 * q2
        - 1.5 * K**3 * p * q2**2 * D
        + 2 * K**4 * Y4 * q2**3
    ) / D**4
    return {"a1": a1, "c2": c2, "c3": c3}


def _legendre(f: np.ndarray, K: np.ndarray | float, co: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """t(f), F(f), Theta_0(f), dF/df at t_n = 0 for Phi_1 = -(pi/K) f^2 + pi Y3 f^3 + pi Y4 f^4."""
    q2, q3, q4, Y3, Y4 = (co[k] for k in ("q2", "q3", "q4", "Y3", "Y4"))
    f2 = f * f
    phi = np.pi * f2 * (-1.0 / K + f * (Y3 + Y4 * f))
    t = f * (1.0 / K - f * (1.5 * Y3 + 2 * Y4 * f))
    dt = 1.0 / K - f * (3 * Y3 + 6 * Y4 * f)
    t2 = t * t
    psi = np.pi * t2 * (q2 + t * (q3 + q4 * t))
    dpsi = np.pi * t * (2 * q2 + t * (3 * q3 + 4 * q4 * t))
    d2psi = np.pi * (2 * q2 + t * (6 * q3 + 12 * q4 * t))
    F = f + dpsi / (2 * np.pi)
    theta = phi + psi - t * dpsi
    dF = 1 + d2psi / (2 * np.pi) * dt
    return t, F, theta, dF


def compression_phase(F: np.ndarray, K: np.ndarray | float, co: dict, iterations: int = 6) -> np.ndarray:
    """Theta_0(F): phase of a t_n = 0 target after filter + scaling, exact (Newton on F(f) = F).

    F: (n_f, 1) or (n_f, n_r) Hz; K and the coefficients (n_r,) or scalars. H_AC = exp(-j Theta_0).
    """
    F = np.asarray(F, float)
    D = K + co["q2"]
    f = F * K / D
    for _ in range(iterations):
        _, Fv, _, dF = _legendre(f, K, co)
        f = f - (Fv - F) / np.where(np.abs(dF) > 1e-6, dF, 1e-6)
    _, _, theta, _ = _legendre(f, K, co)
    return theta


def group_delay_span(f_lo: float, f_hi: float, co: dict) -> float:
    """Largest |1.5 Y3 f^2 + 2 Y4 f^3| over the band (s): how far the quartic filter spreads a pulse."""
    f = np.linspace(f_lo, f_hi, 65)[:, None]
    return float(np.max(np.abs(1.5 * np.asarray(co["Y3"]) * f**2 + 2 * np.asarray(co["Y4"]) * f**3)))

"""Numba kernels of the compiled GP formulation (:mod:`.gp_compiled`): one call runs a whole LM solve.

The factors of a problem arrive packed in two tables (built by :mod:`.gp_compiled` from the
:class:`~.gp_costs.CostTerm` objects, so the cost is still theirs):

* **linear factors** (GP prior, start / goal priors): error ``e = A [x_i0; x_i1] - c`` (4,),
  whitened ``r = W e``; the whitened Jacobian ``J = W A`` (4, 8) is constant and packed once.
  ``i1 = -1`` marks a factor of one state (the right half of ``A`` is then zero);
* **hinge factors** (obstacles on the SDF, other robots, the speed limit): a point
  ``p = M [x_i0; x_i1]`` (M is 2 x 8: a support position, a GP-interpolated position or a
  velocity), a distance ``d`` of it (``kind`` 0: bilinear SDF minus ``offset``; 1: distance to
  ``point`` minus ``offset``; 2: ``|p|`` for the speed limit) and the hinge of Eq. 21
  (``max(0, eps - d)``, active on the boundary; for the speed limit ``max(0, |p| - offset)``),
  whitened by the scalar ``w = 1 / sigma``.

Every evaluation computes residuals and Jacobians in the same pass (one SDF lookup per point and
iteration: the trial point's evaluation is the next linearisation). The normal equations are
block tridiagonal (4 x 4 blocks: factors only couple consecutive states), accumulated straight
into diagonal blocks ``D`` (n, 4, 4) and sub-diagonal blocks ``B`` (n - 1, 4, 4, ``B[k]`` is the
block of rows k + 1, columns k), and solved by block Cholesky. :func:`levenberg_marquardt` follows
:func:`.gp_vectorised.levenberg_marquardt` (gtsam's rules) step by step.

No ``fastmath``: the kernels round as numpy does, term by term.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

KIND_SDF = 0
KIND_POINT = 1
KIND_SPEED = 2

#: Status codes returned by :func:`levenberg_marquardt`.
STATUS_OK = 0
STATUS_NONFINITE_POINT = 1


@njit(cache=True)
def sdf_query(grid, origin_x, origin_y, resolution, px, py):
    """Bilinear SDF and its gradient at (px, py): :meth:`.sdf.SignedDistanceField.query`, one point."""
    ny, nx = grid.shape
    cx = (px - origin_x) / resolution - 0.5
    cy = (py - origin_y) / resolution - 0.5
    fx = min(max(cx, 0.0), nx - 1.0)
    fy = min(max(cy, 0.0), ny - 1.0)
    ix0 = min(int(math.floor(fx)), max(nx - 2, 0))
    iy0 = min(int(math.floor(fy)), max(ny - 2, 0))
    ix1 = min(ix0 + 1, nx - 1)
    iy1 = min(iy0 + 1, ny - 1)
    tx = fx - ix0
    ty = fy - iy0
    d00 = grid[iy0, ix0]
    d01 = grid[iy0, ix1]
    d10 = grid[iy1, ix0]
    d11 = grid[iy1, ix1]
    distance = (1 - ty) * ((1 - tx) * d00 + tx * d01) + ty * ((1 - tx) * d10 + tx * d11)
    gx = ((1 - ty) * (d01 - d00) + ty * (d11 - d10)) / resolution
    gy = ((1 - tx) * (d10 - d00) + tx * (d11 - d01)) / resolution
    ox = (cx - fx) * resolution
    oy = (cy - fy) * resolution
    return distance + (gx * ox + gy * oy), gx, gy


@njit(cache=True)
def _local(states, i0, i1, out):
    for c in range(4):
        out[c] = states[i0, c]
        out[4 + c] = states[i1, c] if i1 >= 0 else 0.0


@njit(cache=True)
def evaluate(states, lin_i0, lin_i1, lin_a, lin_c, lin_w, hin_i0, hin_i1, hin_map, hin_kind, hin_point,
             hin_offset, hin_eps, hin_w, grid, origin_x, origin_y, resolution, r_lin, r_hin, j_hin):
    """Cost ``0.5 sum r^2`` at ``states``; fills whitened residuals and the hinge Jacobians.

    Returns (cost, status); status is :data:`STATUS_NONFINITE_POINT` when an SDF point is not finite.
    """
    xl = np.empty(8)
    e = np.empty(4)
    cost = 0.0
    for f in range(lin_i0.shape[0]):
        _local(states, lin_i0[f], lin_i1[f], xl)
        for r in range(4):
            acc = 0.0
            for c in range(8):
                acc += lin_a[f, r, c] * xl[c]
            e[r] = acc - lin_c[f, r]
        for r in range(4):
            acc = 0.0
            for c in range(4):
                acc += lin_w[f, r, c] * e[c]
            r_lin[f, r] = acc
            cost += 0.5 * acc * acc
    status = STATUS_OK
    for f in range(hin_i0.shape[0]):
        _local(states, hin_i0[f], hin_i1[f], xl)
        px = 0.0
        py = 0.0
        for c in range(8):
            px += hin_map[f, 0, c] * xl[c]
            py += hin_map[f, 1, c] * xl[c]
        kind = hin_kind[f]
        if kind == KIND_SPEED:
            speed = math.sqrt(px * px + py * py)
            if speed >= hin_offset[f]:
                error = speed - hin_offset[f]
                gx = px / speed
                gy = py / speed
            else:
                error = 0.0
                gx = 0.0
                gy = 0.0
        else:
            if kind == KIND_SDF:
                if not (math.isfinite(px) and math.isfinite(py)):
                    status = STATUS_NONFINITE_POINT
                    px = 0.0
                    py = 0.0
                distance, dx, dy = sdf_query(grid, origin_x, origin_y, resolution, px, py)
            else:
                ox = px - hin_point[f, 0]
                oy = py - hin_point[f, 1]
                centre = math.sqrt(ox * ox + oy * oy)
                distance = centre
                if centre > 0.0:
                    dx = ox / centre
                    dy = oy / centre
                else:
                    dx = 1.0
                    dy = 0.0
            distance = distance - hin_offset[f]
            if distance <= hin_eps[f]:
                error = hin_eps[f] - distance
                gx = -dx
                gy = -dy
            else:
                error = 0.0
                gx = 0.0
                gy = 0.0
        whitened = error * hin_w[f]
        r_hin[f] = whitened
        cost += 0.5 * whitened * whitened
        for c in range(8):
            j_hin[f, c] = (gx * hin_map[f, 0, c] + gy * hin_map[f, 1, c]) * hin_w[f]
    return cost, status


@njit(cache=True)
def _add_outer(jac, res, i0, i1, diag, sub, grad):
    """Add one factor's ``J^T J`` and ``J^T r`` (J: rows x 8) to the block-tridiagonal system."""
    rows = jac.shape[0]
    for a in range(4):
        g0 = 0.0
        g1 = 0.0
        for r in range(rows):
            g0 += jac[r, a] * res[r]
            g1 += jac[r, 4 + a] * res[r]
        grad[i0, a] += g0
        if i1 >= 0:
            grad[i1, a] += g1
        for b in range(4):
            h00 = 0.0
            h11 = 0.0
            h10 = 0.0
            for r in range(rows):
                h00 += jac[r, a] * jac[r, b]
                if i1 >= 0:
                    h11 += jac[r, 4 + a] * jac[r, 4 + b]
                    h10 += jac[r, 4 + a] * jac[r, b]
            diag[i0, a, b] += h00
            if i1 >= 0:
                diag[i1, a, b] += h11
                sub[i0, a, b] += h10


@njit(cache=True)
def linear_hessian(lin_i0, lin_i1, lin_j, diag, sub):
    """``J^T J`` of the linear factors alone: constant, so computed once per solve (the band pattern
    and the prior's blocks are reused by every linearisation)."""
    diag[:] = 0.0
    sub[:] = 0.0
    grad = np.zeros((diag.shape[0], 4))
    zero = np.zeros(4)
    for f in range(lin_i0.shape[0]):
        _add_outer(lin_j[f], zero, lin_i0[f], lin_i1[f], diag, sub, grad)


@njit(cache=True)
def normal_equations(lin_i0, lin_i1, lin_j, r_lin, hin_i0, hin_i1, r_hin, j_hin, diag0, sub0, diag, sub, grad):
    """``J^T J`` (blocks ``diag``, ``sub``) and ``J^T r`` (``grad`` (n, 4)) of every factor, from the
    linear factors' constant blocks ``diag0``, ``sub0`` (:func:`linear_hessian`)."""
    diag[:] = diag0
    sub[:] = sub0
    grad[:] = 0.0
    for f in range(lin_i0.shape[0]):
        jac = lin_j[f]
        res = r_lin[f]
        i0 = lin_i0[f]
        i1 = lin_i1[f]
        for a in range(4):
            g0 = 0.0
            g1 = 0.0
            for r in range(4):
                g0 += jac[r, a] * res[r]
                g1 += jac[r, 4 + a] * res[r]
            grad[i0, a] += g0
            if i1 >= 0:
                grad[i1, a] += g1
    row = np.empty((1, 8))
    res = np.empty(1)
    for f in range(hin_i0.shape[0]):
        if r_hin[f] == 0.0:
            nonzero = False
            for c in range(8):
                if j_hin[f, c] != 0.0:
                    nonzero = True
            if not nonzero:
                continue                      # an inactive hinge adds nothing
        row[0, :] = j_hin[f]
        res[0] = r_hin[f]
        _add_outer(row, res, hin_i0[f], hin_i1[f], diag, sub, grad)


@njit(cache=True)
def _cholesky4(s, low):
    """Lower Cholesky factor of the 4 x 4 ``s`` into ``low``; False if not positive definite."""
    for j in range(4):
        acc = s[j, j]
        for k in range(j):
            acc -= low[j, k] * low[j, k]
        if not acc > 0.0:
            return False
        pivot = math.sqrt(acc)
        low[j, j] = pivot
        for i in range(j + 1, 4):
            value = s[i, j]
            for k in range(j):
                value -= low[i, k] * low[j, k]
            low[i, j] = value / pivot
        for i in range(j):
            low[i, j] = 0.0
    return True


@njit(cache=True)
def solve_damped(diag, sub, grad, damping, chol, coupling, delta):
    """``(J^T J + damping I) delta = -J^T r`` by block Cholesky; False if not positive definite."""
    n = diag.shape[0]
    s = np.empty((4, 4))
    y = delta                                  # forward substitution in place
    for k in range(n):
        for a in range(4):                     # the lower triangle is all _cholesky4 reads
            for b in range(a + 1):
                s[a, b] = diag[k, a, b]
            s[a, a] += damping
        if k > 0:
            # coupling[k-1] = B[k-1] L[k-1]^-T, S_k -= C C^T
            for a in range(4):
                for b in range(a + 1):
                    acc = 0.0
                    for c in range(4):
                        acc += coupling[k - 1, a, c] * coupling[k - 1, b, c]
                    s[a, b] -= acc
        if not _cholesky4(s, chol[k]):
            return False
        if k + 1 < n:
            for a in range(4):                 # row a of C = B L^-T: solve L c^T = b^T
                for b in range(4):
                    value = sub[k, a, b]
                    for c in range(b):
                        value -= coupling[k, a, c] * chol[k, b, c]
                    coupling[k, a, b] = value / chol[k, b, b]
        for a in range(4):
            value = -grad[k, a]
            if k > 0:
                for c in range(4):
                    value -= coupling[k - 1, a, c] * y[k - 1, c]
            for c in range(a):
                value -= chol[k, a, c] * y[k, c]
            y[k, a] = value / chol[k, a, a]
    for k in range(n - 1, -1, -1):              # backward: L_k^T x_k = y_k - C_k^T x_{k+1}
        for a in range(3, -1, -1):
            value = y[k, a]
            if k + 1 < n:
                for c in range(4):
                    value -= coupling[k, c, a] * delta[k + 1, c]
            for c in range(a + 1, 4):
                value -= chol[k, c, a] * delta[k, c]
            delta[k, a] = value / chol[k, a, a]
    for k in range(n):
        for a in range(4):
            if not math.isfinite(delta[k, a]):
                return False
    return True


@njit(cache=True)
def linearized_cost(delta, lin_i0, lin_i1, lin_j, r_lin, hin_i0, hin_i1, r_hin, j_hin):
    """``0.5 sum ||r + J delta||^2`` (gtsam's ``linear.error(delta)``)."""
    dl = np.empty(8)
    total = 0.0
    for f in range(lin_i0.shape[0]):
        _local(delta, lin_i0[f], lin_i1[f], dl)
        for r in range(4):
            acc = 0.0
            for c in range(8):
                acc += lin_j[f, r, c] * dl[c]
            value = r_lin[f, r] + acc
            total += 0.5 * value * value
    for f in range(hin_i0.shape[0]):
        _local(delta, hin_i0[f], hin_i1[f], dl)
        acc = 0.0
        for c in range(8):
            acc += j_hin[f, c] * dl[c]
        value = r_hin[f] + acc
        total += 0.5 * value * value
    return total


@njit(cache=True)
def _converged(relative_tol, absolute_tol, previous, new):
    if new <= 0.0:
        return True
    decrease = previous - new
    relative = decrease / previous
    return (relative_tol != 0.0 and relative <= relative_tol) or decrease <= absolute_tol


@njit(cache=True)
def levenberg_marquardt(initial, lin_i0, lin_i1, lin_a, lin_c, lin_w, lin_j, hin_i0, hin_i1, hin_map, hin_kind,
                        hin_point, hin_offset, hin_eps, hin_w, grid, origin_x, origin_y, resolution,
                        max_iterations, relative_tol, absolute_tol, lambda_initial, lambda_factor,
                        lambda_upper, lambda_lower, min_fidelity):
    """gtsam's LM (see :func:`.gp_vectorised.levenberg_marquardt`) over the packed factors.

    Returns (states, cost, initial cost, iterations, converged, history, history length, status,
    final linear residuals, final hinge residuals).
    """
    n = initial.shape[0]
    lin_count = lin_i0.shape[0]
    hin_count = hin_i0.shape[0]
    values = initial.copy()
    trial = np.empty_like(values)
    r_lin = np.empty((lin_count, 4))
    r_hin = np.empty(hin_count)
    j_hin = np.empty((hin_count, 8))
    t_lin = np.empty((lin_count, 4))
    t_hin = np.empty(hin_count)
    t_jac = np.empty((hin_count, 8))
    diag = np.empty((n, 4, 4))
    sub = np.empty((max(n - 1, 1), 4, 4))
    grad = np.empty((n, 4))
    chol = np.empty((n, 4, 4))
    coupling = np.empty((max(n - 1, 1), 4, 4))
    delta = np.empty((n, 4))
    diag0 = np.empty((n, 4, 4))
    sub0 = np.empty((max(n - 1, 1), 4, 4))
    linear_hessian(lin_i0, lin_i1, lin_j, diag0, sub0)
    history = np.empty(max_iterations + 1)
    count = 0
    error, status = evaluate(values, lin_i0, lin_i1, lin_a, lin_c, lin_w, hin_i0, hin_i1, hin_map, hin_kind,
                             hin_point, hin_offset, hin_eps, hin_w, grid, origin_x, origin_y, resolution,
                             r_lin, r_hin, j_hin)
    initial_error = error
    iterations = 0
    converged = error <= 0.0
    if converged or max_iterations <= 0 or status != STATUS_OK:
        return values, error, initial_error, 0, converged, history, 0, status, r_lin, r_hin
    lam = lambda_initial
    eps = np.finfo(np.float64).eps
    new_error = error
    while True:
        current_error = new_error
        normal_equations(lin_i0, lin_i1, lin_j, r_lin, hin_i0, hin_i1, r_hin, j_hin, diag0, sub0, diag, sub, grad)
        old_linearized = error                 # the cost of the linearisation point
        while True:                            # gtsam's tryLambda loop
            step_successful = False
            stop_searching = False
            if solve_damped(diag, sub, grad, lam, chol, coupling, delta):
                linearized_change = old_linearized - linearized_cost(delta, lin_i0, lin_i1, lin_j, r_lin, hin_i0,
                                                                     hin_i1, r_hin, j_hin)
                if linearized_change >= 0.0:
                    for k in range(n):
                        for c in range(4):
                            trial[k, c] = values[k, c] + delta[k, c]
                    trial_error, status = evaluate(trial, lin_i0, lin_i1, lin_a, lin_c, lin_w, hin_i0, hin_i1,
                                                   hin_map, hin_kind, hin_point, hin_offset, hin_eps, hin_w, grid,
                                                   origin_x, origin_y, resolution, t_lin, t_hin, t_jac)
                    if status != STATUS_OK:
                        return values, error, initial_error, iterations, False, history, count, status, r_lin, r_hin
                    cost_change = error - trial_error
                    if linearized_change > eps * old_linearized:
                        step_successful = cost_change / linearized_change > min_fidelity
                    if abs(cost_change) < relative_tol * error:
                        stop_searching = True
            if step_successful:
                values, trial = trial, values
                r_lin, t_lin = t_lin, r_lin
                r_hin, t_hin = t_hin, r_hin
                j_hin, t_jac = t_jac, j_hin
                error = trial_error
                lam = max(lambda_lower, lam / lambda_factor)
                iterations += 1
                break
            if stop_searching:
                break
            lam *= lambda_factor
            if lam >= lambda_upper:
                break
        new_error = error
        history[count] = new_error
        count += 1
        converged = _converged(relative_tol, absolute_tol, current_error, new_error)
        if iterations >= max_iterations or converged or not math.isfinite(current_error) or count >= history.size:
            break
    return values, new_error, initial_error, iterations, converged, history, count, status, r_lin, r_hin

"""The C source of the native real-time iteration: condensing, a dense box-QP solver and the feedback step.

Kept as text so that the package needs no data files; ``native_lib`` compiles it once (gcc, cached by a
hash of this text) and calls it through ctypes. Everything is plain C99 with no allocation: the caller
hands in every buffer.

Conventions. The augmented OCP (``gauss_newton``) has N stages of z = [x (12), u_prev (2)] (nz = 14) and
u (nu = 2); nzu = nz + nu. Its Gauss–Newton QP at a plan, in the step (Δz, Δu):
    min Σ_k ½ v_kᵀ H_k v_k + g_kᵀ v_k,  v_k = [Δz_k; Δu_k] (v_N = [Δz_N; 0])
    Δz_{k+1} = A_k Δz_k + B_k Δu_k + gap_k,  Δz_0 = dz0 (the measurement's offset from the plan),
    lo ≤ ΔU ≤ hi (input bounds only; the states are free).
Blocks arrive column-major as CasADi writes dense matrices: AB_k (nz × nzu) at AB + k·nz·nzu, H_k
(nzu × nzu) at Hs + k·nzu², g_k at gs + k·nzu, gap_k at gap + k·nz. Eliminating the states
(Δz_k = Γ_k ΔU + Φ_k dz0 + c_k) leaves a dense QP in the n = N·nu input steps:
    min ½ ΔUᵀ Hc ΔU + (gc + Gc dz0)ᵀ ΔU,  lo ≤ ΔU ≤ hi     (Hc n × n, Gc n × nz, row-major).
"""

C_SOURCE = r"""
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <string.h>
#include <time.h>

#define AB_(k, r, j) AB[(size_t)(k) * nz * nzu + (size_t)(j) * nz + (r)]
#define H_(k, r, j) Hs[(size_t)(k) * nzu * nzu + (size_t)(j) * nzu + (r)]

/* Lower Cholesky factor of the m x m SPD matrix a (row-major, lower triangle read), in place. */
static int cholesky(double *a, int m) {
    for (int j = 0; j < m; ++j) {
        double *aj = a + (size_t)j * m;
        double d = aj[j];
        for (int k = 0; k < j; ++k) d -= aj[k] * aj[k];
        if (!(d > 0.0)) return -1;
        d = sqrt(d);
        aj[j] = d;
        for (int i = j + 1; i < m; ++i) {
            double *ai = a + (size_t)i * m;
            double s = ai[j];
            for (int k = 0; k < j; ++k) s -= ai[k] * aj[k];
            ai[j] = s / d;
        }
    }
    return 0;
}

/* State sensitivities: Gam (N+1) x nz x n, Phi (N+1) x nz x nz, c (N+1) x nz, all row-major. */
static void sensitivities(int N, int nz, int nu, const double *AB, const double *gap,
                          double *Gam, double *Phi, double *c) {
    int nzu = nz + nu, n = N * nu;
    memset(Phi, 0, sizeof(double) * (size_t)(N + 1) * nz * nz);
    memset(c, 0, sizeof(double) * (size_t)(N + 1) * nz);
    for (int r = 0; r < nz; ++r) Phi[r * nz + r] = 1.0;
    for (int k = 0; k < N; ++k) {
        const double *G0 = Gam + (size_t)k * nz * n, *P0 = Phi + (size_t)k * nz * nz, *c0 = c + (size_t)k * nz;
        double *G1 = Gam + (size_t)(k + 1) * nz * n, *P1 = Phi + (size_t)(k + 1) * nz * nz;
        double *c1 = c + (size_t)(k + 1) * nz;
        for (int r = 0; r < nz; ++r) {
            double *g1 = G1 + (size_t)r * n, *p1 = P1 + (size_t)r * nz;
            double cr = gap[(size_t)k * nz + r];
            memset(g1, 0, sizeof(double) * (size_t)k * nu);  /* (Gam_k's columns from k nu on are never read) */
            for (int s = 0; s < nz; ++s) {
                double a = AB_(k, r, s);
                if (a == 0.0) continue;
                const double *g0 = G0 + (size_t)s * n, *p0 = P0 + (size_t)s * nz;
                for (int col = 0; col < k * nu; ++col) g1[col] += a * g0[col];
                for (int col = 0; col < nz; ++col) p1[col] += a * p0[col];
                cr += a * c0[s];
            }
            for (int i = 0; i < nu; ++i) g1[k * nu + i] = AB_(k, r, nz + i);
            c1[r] = cr;
        }
    }
}

/* Condense the QP (see the Python docstring) by a backward recursion, quadratic in the horizon: with
   Q_k, S_k (nu x nz), R_k the blocks of H_k, q_k, r_k those of g_k,
       W_N = Q_N,  W_k = Q_k + A_k' W_{k+1} A_k,   lam_N = q_N + Q_N c_N,  lam_k = q_k + Q_k c_k + A_k' lam_{k+1},
       Y_j = S_j + B_j' W_{j+1} A_j,
       Hc_jj = R_j + B_j' W_{j+1} B_j,  Hc_ji = Y_j Gam_{j,i} (i < j),  Gc_j = Y_j Phi_j,
       gc_j = r_j + S_j c_j + B_j' lam_{j+1}
   (the Hessian and gradient of the cost once the states are eliminated; Gam_{j,i} = dz_j/du_i).
   Zero entries of A_k (the u_prev rows and columns) are skipped. tmp: 4 nz^2 + 2 nz + 2 nu nz doubles. */
int nrti_condense(int N, int nz, int nu, const double *AB, const double *Hs, const double *gs,
                  const double *gap, double *Gam, double *Phi, double *c,
                  double *Hc, double *gc, double *Gc, double *tmp) {
    int nzu = nz + nu, n = N * nu;
    sensitivities(N, nz, nu, AB, gap, Gam, Phi, c);
    double *W = tmp, *WA = W + nz * nz, *W1 = WA + nz * nz, *lam = W1 + nz * nz, *lam1 = lam + nz;
    double *BW = lam1 + nz, *Y = BW + nu * nz, *Wt = Y + nu * nz, *WAt = W1;  /* (W1 is free then) */
    const double *cN = c + (size_t)N * nz;
    for (int r = 0; r < nz; ++r) {
        double l = gs[(size_t)N * nzu + r];
        for (int q = 0; q < nz; ++q) {
            W[r * nz + q] = H_(N, r, q);
            l += H_(N, r, q) * cN[q];
        }
        lam[r] = l;
    }
    for (int j = N - 1; j >= 0; --j) {
        const double *cj = c + (size_t)j * nz, *Gj = Gam + (size_t)j * nz * n, *Pj = Phi + (size_t)j * nz * nz;
        memset(BW, 0, sizeof(double) * (size_t)nu * nz);     /* BW = B_j' W_{j+1} */
        for (int r = 0; r < nz; ++r)
            for (int i = 0; i < nu; ++i) {
                double b = AB_(j, r, nz + i);
                if (b == 0.0) continue;
                for (int q = 0; q < nz; ++q) BW[i * nz + q] += b * W[r * nz + q];
            }
        for (int i = 0; i < nu; ++i) {                       /* Hc_jj, gc_j */
            double *hrow = Hc + (size_t)(j * nu + i) * n;
            for (int l = 0; l < nu; ++l) {
                double h = H_(j, nz + i, nz + l);
                for (int q = 0; q < nz; ++q) h += BW[i * nz + q] * AB_(j, q, nz + l);
                hrow[j * nu + l] = h;
            }
            double g = gs[(size_t)j * nzu + nz + i];
            for (int q = 0; q < nz; ++q) g += H_(j, nz + i, q) * cj[q] + AB_(j, q, nz + i) * lam[q];
            gc[j * nu + i] = g;
        }
        for (int i = 0; i < nu; ++i)                         /* Y = S_j + BW A_j */
            for (int q = 0; q < nz; ++q) Y[i * nz + q] = H_(j, nz + i, q);
        for (int r = 0; r < nz; ++r)
            for (int q = 0; q < nz; ++q) {
                double a = AB_(j, r, q);
                if (a == 0.0) continue;
                for (int i = 0; i < nu; ++i) Y[i * nz + q] += BW[i * nz + r] * a;
            }
        for (int i = 0; i < nu; ++i) {                       /* Hc_ji (i < j) and Gc_j */
            double *hrow = Hc + (size_t)(j * nu + i) * n, *grow = Gc + (size_t)(j * nu + i) * nz;
            int m = j * nu;
            memset(hrow, 0, sizeof(double) * (size_t)m);
            memset(grow, 0, sizeof(double) * (size_t)nz);
            for (int q = 0; q < nz; ++q) {
                double y = Y[i * nz + q];
                if (y == 0.0) continue;
                const double *gq = Gj + (size_t)q * n, *pq = Pj + (size_t)q * nz;
                for (int col = 0; col < m; ++col) hrow[col] += y * gq[col];
                for (int col = 0; col < nz; ++col) grow[col] += y * pq[col];
            }
        }
        if (j == 0) break;                                   /* W_0 and lam_0 are not needed */
        for (int r = 0; r < nz; ++r)                         /* WA = W_{j+1} A_j, made as its transpose from W's: */
            for (int t = 0; t < nz; ++t) Wt[t * nz + r] = W[r * nz + t];  /* each element the same sum in the */
        memset(WAt, 0, sizeof(double) * (size_t)nz * nz);    /* same order, with a contiguous inner loop */
        for (int t = 0; t < nz; ++t)
            for (int q = 0; q < nz; ++q) {
                double a = AB_(j, t, q);
                if (a == 0.0) continue;
                const double *wt = Wt + (size_t)t * nz;
                double *wa = WAt + (size_t)q * nz;
                for (int r = 0; r < nz; ++r) wa[r] += wt[r] * a;
            }
        for (int q = 0; q < nz; ++q)
            for (int r = 0; r < nz; ++r) WA[r * nz + q] = WAt[q * nz + r];
        for (int r = 0; r < nz; ++r) {                       /* W1 = Q_j + A_j' WA, lam1 */
            double l = gs[(size_t)j * nzu + r];
            for (int q = 0; q < nz; ++q) {
                W1[r * nz + q] = H_(j, r, q);
                l += H_(j, r, q) * cj[q];
            }
            lam1[r] = l;
        }
        for (int t = 0; t < nz; ++t)
            for (int r = 0; r < nz; ++r) {
                double a = AB_(j, t, r);
                if (a == 0.0) continue;
                const double *wat = WA + (size_t)t * nz;
                double *w1r = W1 + (size_t)r * nz;
                for (int q = 0; q < nz; ++q) w1r[q] += a * wat[q];
                lam1[r] += a * lam[t];
            }
        memcpy(W, W1, sizeof(double) * (size_t)nz * nz);
        memcpy(lam, lam1, sizeof(double) * (size_t)nz);
    }
    for (int a = 0; a < n; ++a)                              /* the upper triangle from the lower */
        for (int b = a + 1; b < n; ++b) Hc[(size_t)a * n + b] = Hc[(size_t)b * n + a];
    return 0;
}

/* Fix the bounded variables, solve the free ones by Cholesky (into L; or with L_given, the factor of these free
   variables made earlier, m x m row-major, read only). Returns the number free, or -1. */
static int solve_free(int n, const double *H, const double *g, const double *lo, const double *hi,
                      const int *state, double *x, double *L, const double *L_given, double *rhs, int *free_idx) {
    int m = 0;
    for (int i = 0; i < n; ++i) {
        if (state[i] < 0) x[i] = lo[i];
        else if (state[i] > 0) x[i] = hi[i];
        else free_idx[m++] = i;
    }
    for (int a = 0; a < m; ++a) {
        const double *Hi = H + (size_t)free_idx[a] * n;
        double s = -g[free_idx[a]];
        for (int j = 0; j < n; ++j) if (state[j] != 0) s -= Hi[j] * x[j];
        rhs[a] = s;
        if (!L_given) for (int b = 0; b <= a; ++b) L[(size_t)a * m + b] = Hi[free_idx[b]];
    }
    const double *F = L_given;
    if (!F) {
        if (cholesky(L, m) != 0) return -1;
        F = L;
    }
    for (int a = 0; a < m; ++a) {
        double s = rhs[a];
        for (int b = 0; b < a; ++b) s -= F[(size_t)a * m + b] * rhs[b];
        rhs[a] = s / F[(size_t)a * m + a];
    }
    for (int a = m - 1; a >= 0; --a) {
        double s = rhs[a];
        for (int b = a + 1; b < m; ++b) s -= F[(size_t)b * m + a] * rhs[b];
        rhs[a] = s / F[(size_t)a * m + a];
    }
    for (int a = 0; a < m; ++a) x[free_idx[a]] = rhs[a];
    return m;
}

/* Mark the variables whose bound status is wrong (bad[i] = 1); returns how many, *last = the largest. */
static int wrong_status(int n, const double *H, const double *g, const double *lo, const double *hi,
                        const int *state, const double *x, double tol, int *bad, int *last) {
    int count = 0;
    for (int i = 0; i < n; ++i) {
        int b;
        if (state[i] == 0) {
            b = x[i] < lo[i] - tol || x[i] > hi[i] + tol;
        } else {
            const double *Hi = H + (size_t)i * n;
            double grad = g[i];
            for (int j = 0; j < n; ++j) grad += Hi[j] * x[j];
            b = state[i] < 0 ? grad < -tol : grad > tol;
        }
        bad[i] = b;
        if (b) { ++count; *last = i; }
    }
    return count;
}

/* min 1/2 x'Hx + g'x, lo <= x <= hi, H SPD (row-major n x n): block principal pivoting (Judice-Pires)
   with Murty's single swap when the count of wrong statuses stops falling. state[i] in {-1, 0, +1}
   (at lo, free, at hi) is the starting guess and the answer. work: n*n + n doubles, iwork: 2n ints.
   Returns the pivoting iterations (> 0), 0 when max_iter ran out (x clipped), -1 if H is not SPD. */
static int box_qp(int n, const double *H, const double *g, const double *lo, const double *hi, int *state,
                  double *x, double *work, int *iwork, int max_iter, double tol, const double *L_first) {
    double *L = work, *rhs = work + (size_t)n * n;
    int *free_idx = iwork, *bad = iwork + n;
    int best = n + 1, stalls = 0;
    for (int it = 1; it <= max_iter; ++it) {
        if (solve_free(n, H, g, lo, hi, state, x, L, it == 1 ? L_first : 0, rhs, free_idx) < 0) return -1;
        int last = -1;
        int count = wrong_status(n, H, g, lo, hi, state, x, tol, bad, &last);
        if (count == 0) return it;
        if (count < best) { best = count; stalls = 0; } else ++stalls;
        for (int i = 0; i < n; ++i) {
            if (!bad[i] || (stalls >= 3 && i != last)) continue;
            if (state[i] != 0) state[i] = 0;
            else state[i] = x[i] < lo[i] ? -1 : 1;
        }
    }
    for (int i = 0; i < n; ++i) x[i] = x[i] < lo[i] ? lo[i] : (x[i] > hi[i] ? hi[i] : x[i]);
    return 0;
}

int nrti_box_qp(int n, const double *H, const double *g, const double *lo, const double *hi, int *state,
                double *x, double *work, int *iwork, int max_iter, double tol) {
    return box_qp(n, H, g, lo, hi, state, x, work, iwork, max_iter, tol, 0);
}

/* The feedback step: g = gc + Gc dz0, the box QP from the guess state0, then the states by the linear
   dynamics; w_out (the controller's layout, x of nx per stage) = the plan w_aug (augmented layout) + step.
   Returns nrti_box_qp's answer. work: n*n + 2n + 2nz doubles; iwork: 3n ints, of which iwork[2n..3n) holds
   the active set the QP ended with (its own copy of state0, updated; the caller may read it back). L0: NULL, or
   the Cholesky factor (m x m, row-major) of Hc's block of state0's m free variables (the preparation's): the first
   iteration then only substitutes. After a call with L0 NULL, work[0..m*m) holds the factor of the last
   iteration's free variables (with L0 given, only if the QP took more than one iteration). */
int nrti_feedback(int N, int nx, int nz, int nu, const double *Hc, const double *gc, const double *Gc,
                  const double *lo, const double *hi, const int *state0, const double *AB, const double *gap,
                  const double *w_aug, const double *dz0, int max_iter, double tol, double *w_out,
                  double *du, double *work, int *iwork, const double *L0) {
    int nzu = nz + nu, n = N * nu;
    double *g = work + (size_t)n * n + n, *dz = g + n, *dz1 = dz + nz;
    int *state = iwork + 2 * n;
    for (int a = 0; a < n; ++a) {
        double s = gc[a];
        for (int b = 0; b < nz; ++b) s += Gc[(size_t)a * nz + b] * dz0[b];
        g[a] = s;
    }
    memcpy(state, state0, sizeof(int) * (size_t)n);
    int status = box_qp(n, Hc, g, lo, hi, state, du, work, iwork, max_iter, tol, L0);
    if (status < 0) return status;
    memcpy(dz, dz0, sizeof(double) * (size_t)nz);
    for (int k = 0; k <= N; ++k) {
        const double *zk = w_aug + (size_t)k * nzu;
        double *out = w_out + (size_t)k * (nx + nu);
        for (int i = 0; i < nx; ++i) out[i] = zk[i] + dz[i];
        if (k == N) break;
        for (int i = 0; i < nu; ++i) out[nx + i] = zk[nz + i] + du[k * nu + i];
        for (int r = 0; r < nz; ++r) {
            double s = gap[(size_t)k * nz + r];
            for (int j = 0; j < nz; ++j) s += AB_(k, r, j) * dz[j];
            for (int i = 0; i < nu; ++i) s += AB_(k, r, nz + i) * du[k * nu + i];
            dz1[r] = s;
        }
        memcpy(dz, dz1, sizeof(double) * (size_t)nz);
    }
    return status;
}

/* The plan w (the controller's layout: x_k (nx) u_k (nu) per stage, then x_N) in the augmented layout (z_k = [x_k,
   u_{k-1}], u_prev before stage 0, u_N's slot the last input), as GaussNewtonSqp.to_aug: copies only. */
static void augment(int N, int nx, int nu, const double *w, const double *u_prev, double *w_aug) {
    int nzu = nx + 2 * nu, stage = nx + nu;
    for (int k = 0; k <= N; ++k) {
        double *z = w_aug + (size_t)k * nzu;
        const double *before = k == 0 ? u_prev : w + (size_t)(k - 1) * stage + nx;
        memcpy(z, w + (size_t)k * stage, sizeof(double) * (size_t)nx);
        memcpy(z + nx, before, sizeof(double) * (size_t)nu);
        if (k < N) memcpy(z + nx + nu, w + (size_t)k * stage + nx, sizeof(double) * (size_t)nu);
    }
}

/* The box of the input steps at the plan: lo = min(u_low - U, 0), hi = max(u_high - U, 0) as numpy's minimum and
   maximum give them (NaN kept, a zero of either sign answered as +0). */
static void input_bounds(int N, int nz, int nu, const double *w_aug, const double *u_low, const double *u_high,
                         double *lo, double *hi) {
    for (int k = 0; k < N; ++k)
        for (int i = 0; i < nu; ++i) {
            int a = k * nu + i;
            double U = w_aug[(size_t)k * (nz + nu) + nz + i], dl = u_low[a] - U, dh = u_high[a] - U;
            lo[a] = (dl < 0.0 || dl != dl) ? dl : 0.0;
            hi[a] = (dh > 0.0 || dh != dh) ? dh : 0.0;
        }
}

/* max |x_i| as numpy's (NaN if any is NaN); -1 when any is not finite and check_finite is set. */
static double max_abs(const double *x, int n, int check_finite) {
    double m = 0.0;
    for (int i = 0; i < n; ++i) {
        double a = fabs(x[i]);
        if (a != a) return check_finite ? -1.0 : a;
        if (check_finite && isinf(a)) return -1.0;
        if (a > m) m = a;
    }
    return m;
}

static double seconds_since(const struct timespec *start) {
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    return (double)(now.tv_sec - start->tv_sec) + 1e-9 * (double)(now.tv_nsec - start->tv_nsec);
}

typedef int (*casadi_function)(const double **arg, double **res, long long *iw, double *w, int mem);

/* nrti's preparation SQP in one call (nrti.Preparation.converge; each iteration exactly Condenser.iterate's C
   calls): from the plan w_in (the controller's layout) with u_prev before it, each iteration puts the plan in
   w_aug (the block linearisation's first input; p its second, bound by the caller), evaluates lin (CasADi's
   generated C: res = AB, Hs, gs, gap), condenses into Hc, gc, Gc, sets lo and hi, and solves the box QP at dz0
   (zero) from state0, which then holds the QP's final active set; its new plan in w_out is the next iteration's.
   Stops once every input step is at most step_tol, after max_iter iterations, or none begun after budget_s
   seconds. *iterations: how many ran. Returns the last QP's status (nrti_feedback's), -2 when lin failed, -3 when
   a plan is not finite. */
int nrti_converge(int N, int nx, int nz, int nu, int max_iter, double step_tol, double budget_s,
                  void *lin, const double **arg, double **res, long long *iw, double *lw,
                  const double *w_in, const double *u_prev, const double *u_low, const double *u_high,
                  double *w_aug, double *Gam, double *Phi, double *c, double *tmp,
                  double *Hc, double *gc, double *Gc, double *lo, double *hi, int *state0,
                  const double *dz0, int qp_max_iter, double qp_tol,
                  double *w_out, double *du, double *work, int *iwork, int *iterations) {
    int n = N * nu, status = 0, size = (N + 1) * nx + N * nu;
    struct timespec start;
    clock_gettime(CLOCK_MONOTONIC, &start);
    const double *w = w_in;
    for (int it = 0; it < max_iter; ++it) {
        *iterations = it + 1;
        augment(N, nx, nu, w, u_prev, w_aug);
        if (((casadi_function)lin)(arg, res, iw, lw, 0) != 0) return -2;
        nrti_condense(N, nz, nu, res[0], res[1], res[2], res[3], Gam, Phi, c, Hc, gc, Gc, tmp);
        input_bounds(N, nz, nu, w_aug, u_low, u_high, lo, hi);
        status = nrti_feedback(N, nx, nz, nu, Hc, gc, Gc, lo, hi, state0, res[0], res[3], w_aug, dz0, qp_max_iter,
                               qp_tol, w_out, du, work, iwork, 0);
        memcpy(state0, iwork + 2 * n, sizeof(int) * (size_t)n);
        if (status < 0) return status;
        if (max_abs(w_out, size, 1) < 0.0) return -3;
        w = w_out;
        if (max_abs(du, n, 0) <= step_tol || seconds_since(&start) > budget_s) break;
    }
    return status;
}
"""

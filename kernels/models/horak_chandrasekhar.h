/*
 * horak_chandrasekhar.h — the exact constants l, m (cos phi mode) and A..F
 * (phi-averaged mode) of the three-term half-space BRDF, from Chandrasekhar's
 * invariance-principle psi-function system solved numerically.
 *
 * References
 *  [d'Eon]  E. d'Eon, "An analytic BRDF for materials with spherical Lambertian
 *           scatterers", Computer Graphics Forum 40(4) (EGSR 2021).  Equation
 *           numbers "eq. N" are this paper's (symbols and the equations
 *           as implemented: docs/models/lambert-sphere.md).
 *  [HC61]   H. G. Horak, S. Chandrasekhar, "Diffuse reflection by a
 *           semi-infinite atmosphere", ApJ 134 (1961) 45.
 *  [RT]     S. Chandrasekhar, Radiative Transfer, Oxford 1950 (Dover 1960),
 *           ch. IV (principles of invariance), ch. V-VI (psi/phi systems,
 *           H-functions).
 *
 * The paper gives only fits for l, m (eqs. 26-27) and B, C, D, F (eqs. 34-37).
 * This header computes them to ~1e-12 (c < 0.9975) / ~1e-10 (c -> 1).
 *
 * ---------------------------------------------------------------- API
 *   hc_constants(c, out)      out[0..7] = l, m, A, B, C, D, E, F   (c in [0, 1])
 *   hc_f0(mi, mo, H0i, H0o, k)   eq. 30 with k = out (phi-average f^(0))
 *   hc_f1(mi, mo, H1i, H1o, c, k) the EXACT cos(phi) coefficient f^(1):
 *                              2 x eq. 22 (see "Departures" 1)
 *   hc_f2(mi, mo, H2i, H2o, c)   the exact cos(2 phi) coefficient (eq. 21 drops it)
 *   Lower level: hc_solve_mode() (the psi system on nodes), hc_psi_at()
 *   (Nystrom interpolation), hc_q_coefficients() (the polynomials q_l),
 *   hc_h_at() (the H-function implied by the system).
 * H0, H1, H2 themselves come from hfunction.h (HF_PSI_LAMBERT0/1/2): this header
 * does not depend on it; the tests check that the H implied here equals it.
 * phi: the project's convention, phi = 0 back-scattering (viewer with light).
 * Precision: the solver runs in ACCUM (double when the device has fp64, also
 * for --precision float); tolerance 1e-15 (HC_TOL).
 * Cost (host, -O2, one core): ~0.5 ms per hc_constants call for c < 0.9975,
 * ~6 ms above (11 solves, departure 2); tabulate in c if called per pixel.
 * Private memory: ~30 KB of fixed arrays per call (fine on the PoCL CPU
 * device; checked to compile and run there).
 *
 * ---------------------------------------------------------------- derivation
 * Chandrasekhar's notation [RT §29]: phase function p(cos Theta) =
 * sum_l w_l P_l(cos Theta) with (1/4 pi) int p dOmega = w_0 = c; for the
 * three-term truncation (eq. 8) w_0 = c, w_1 = -4c/3, w_2 = 5c/16.  Reflected
 * intensity I(mu, phi) = F S(mu, phi; mu0, phi0) / (4 mu) for incident flux
 * pi F, so the BRDF is f = S / (4 pi mu mu0).  Single scattering:
 * S_1 = p mu mu0/(mu + mu0)  ->  f_1 = c p3 / (mu + mu0) (eq. 10) with p3 = p/(4 pi c).
 *
 * (i) Invariance principles [RT §29, eq. IV (29)-(30)]:
 *   (1/mu + 1/mu0) S(mu,phi;mu0,phi0) = p(mu,phi; -mu0,phi0)
 *     + (1/4pi) int_0^1 int_0^2pi p(mu,phi; mu'',phi'') S(mu'',phi''; mu0,phi0) dmu''/mu'' dphi''
 *     + (1/4pi) int int S(mu,phi; mu',phi') p(-mu',phi'; -mu0,phi0) dmu'/mu' dphi'
 *     + (1/16pi^2) int^4 S(mu,phi;mu',phi') p(-mu',phi'; mu'',phi'') S(mu'',phi'';mu0,phi0) ...
 *   (check: p = c (isotropic) gives Chandrasekhar's H equation below.)
 *
 * (ii) Fourier modes.  Addition theorem: P_l(cos Theta) = sum_m (2 - d_m0)
 *   (l-m)!/(l+m)! P_l^m(mu) P_l^m(mu') cos m(phi - phi'), so
 *   p = sum_m (2 - d_m0) p^(m)(mu, mu') cos m(phi - phi'),
 *   p^(m)(mu, mu') = sum_{l>=m} w_l^m P_l^m(mu) P_l^m(mu'),  w_l^m = w_l (l-m)!/(l+m)!,
 *   a finite separable kernel.  With S = sum_m S^(m)(mu, mu0) cos m(phi0 - phi),
 *   the azimuth integrals of (i) give, with p's factor (2 - d_m0):
 *   (1/4pi) int_0^2pi (2-d) cos m(phi-phi'') cos m(phi''-phi0) dphi'' = (1/2) cos m(phi-phi0)
 *   for every m (single integrals), and (1/16pi^2) x (2-d) x (2pi)^2 x (1/2)^2 (m >= 1)
 *   or x 1 (m = 0) = 1/(4(2 - d_m0)) for the double integral, so that every
 *   mode obeys
 *   (1/mu + 1/mu0) S^(m) = (2-d) p^(m)(mu,-mu0) + (1/2) int p^(m)(mu,mu'') S^(m)(mu'',mu0) dmu''/mu''
 *       + (1/2) int S^(m)(mu,mu') p^(m)(-mu',-mu0) dmu'/mu'
 *       + (1/(4(2-d))) int int S^(m)(mu,mu') p^(m)(-mu',mu'') S^(m)(mu'',mu0) dmu'/mu' dmu''/mu''.
 *
 * (iii) Factorisation.  Insert the separable kernel and use P_l^m(-x) =
 *   (-1)^(l+m) P_l^m(x) and the symmetry S^(m)(x, y) = S^(m)(y, x): the right
 *   side is exactly the product form
 *     (1/mu + 1/mu0) S^(m)(mu, mu0) = (2 - d_m0) sum_l (-1)^(l+m) w_l^m psi_l(mu) psi_l(mu0),
 *     psi_l(mu) = P_l^m(mu) + 1/(2(2 - d_m0)) int_0^1 S^(m)(mu, mu') P_l^m(-mu') dmu'/mu'
 *   (expanding the product reproduces the four terms of (ii) term by term:
 *   (2-d) x 1/(2(2-d)) = 1/2 for the cross terms, (2-d)/(2(2-d))^2 = 1/(4(2-d))
 *   for the double integral).  Eliminating S gives the closed nonlinear system
 *     psi_l(mu) = P_l^m(mu) + (mu/2) sum_k (-1)^(k+l) w_k^m psi_k(mu)
 *                                 int_0^1 psi_k(mu') P_l^m(mu') / (mu + mu') dmu'.      (*)
 *   Isotropic check: psi_0 = 1 + (c/2) mu psi_0 int psi_0/(mu+mu') = H (RT ch. V).
 *
 * (iv) Reduced functions.  For m >= 1 every P_l^m carries (1 - mu^2)^(m/2):
 *   psi_l = (1 - mu^2)^(m/2) chi_l, P_l^m = (1 - mu^2)^(m/2) p_l (|P_l^m|, the
 *   Condon-Shortley sign cancels in (*): psi_k appears squared),
 *     chi_l(mu) = p_l(mu) + (mu/2) sum_k s_kl w_k^m chi_k(mu)
 *                  int_0^1 (1 - mu'^2)^m chi_k(mu') p_l(mu') / (mu + mu') dmu',
 *   m = 0: p = {1, mu, P_2(mu)}, weights {c, -4c/3, 5c/16};
 *   m = 1: p = {1, 3 mu} (P_1^1, P_2^1 / sqrt(1-mu^2)), weights w_l/2, w_2/6 = {-2c/3, 5c/96};
 *   m = 2: p = {3}, weight w_2/24 = 5c/384 (no constants: chi = 3 H2, below).
 *   The (1 - mu'^2)^m factor makes every integrand smooth except for the
 *   mu log mu of H at 0, which the log-spaced nodes below resolve.
 *
 * (v) Horak-Chandrasekhar structure (checked numerically in the tests, to
 *   ~1e-14): psi_l(mu) = (1-mu^2)^(m/2) H_m(mu) q_l(mu) with q_l polynomials,
 *   q_l(0) = p_l(0) (H(0) = 1):
 *     m = 0: q_0 = 1 + a1 mu + a2 mu^2, q_1 = b1 mu + b2 mu^2, q_2 = -1/2 + d1 mu + d2 mu^2,
 *     m = 1: q_1 = 1 + alpha mu,          q_2 = beta mu,
 *   and H_m is the H-function of Psi_m(mu) = (1/2)(1-mu^2)^m sum_l (-1)^(l+m) w_l^m
 *   q_l(mu) q_l(-mu), which reproduces eqs. 13-14 (also checked).  The q's are
 *   extracted from the converged system WITHOUT H: psi_0 q_l - psi_l q_0 = 0
 *   (m = 0), chi_1 q_2 - chi_2 q_1 = 0 (m = 1) at every node, linear least
 *   squares (the discrete Nystrom system preserves this structure exactly, so
 *   the residual is at rounding level; hc_q_coefficients returns it).
 *
 * (vi) Constants.  f^(m) in the project's phi (phi_ours = phi_Chandrasekhar - pi,
 *   so cos m phi flips sign for odd m) is (-1)^m S^(m) / (4 pi mu mu0):
 *     f^(0) = sum_l (-1)^l w_l psi_l psi_l / (4 pi (mu+mu0))
 *           = H0 H0 / (2 pi (mu+mu0)) * [q(mu)^T Q0 q(mu0)],  Q0 = (1/2) diag((-1)^l w_l),
 *   i.e. with q_l = sum_j Q_lj mu^j the bilinear form of eq. 30 is
 *   M = Q^T diag(w_0, -w_1, w_2)/2 Q:  A = M00, B = M01, F = M02, C = M11,
 *   D = M12, E = M22.  A = (w_0 + w_2/4)/2 = 69c/128 exactly (eq. 33) because
 *   q_l(0) = P_l(0).
 *     f^(1) = sum_l (-1)^l w_l^1 psi_l psi_l / (2 pi (mu+mu0))
 *           = H1 H1 sqrt((1-mu^2)(1-mu0^2)) / (2 pi (mu+mu0))
 *             * [(2c/3)(1 + alpha mu)(1 + alpha mu0) + (5c/96) beta^2 mu mu0]
 *           = (c/(3 pi)) H1 H1 sqrt(..) (1 + alpha (mu+mu0) + (alpha^2 + 5 beta^2/64) mu mu0)/(mu+mu0),
 *   which is eq. 22 with  l = alpha,  m = beta^2 / 9,  and prefactor c/(3 pi),
 *   TWICE the printed c/(6 pi).
 *     f^(2) = 2 w_2^2 psi_2^2 psi_2^2 / (4 pi (mu+mu0)) = 15 c (1-mu^2)(1-mu0^2) H2 H2 / (256 pi (mu+mu0)).
 *
 * (vii) Numerics.  Nodes: HC_N-point Gauss-Legendre in s = log mu on
 *   [-HC_SPAN, 0] (the kernel mu' ds/(mu + mu') is a logistic function of
 *   s' - s: geometric convergence; the neglected [0, e^-34] is below 1e-14).
 *   Iteration: at every node, (*) is linear in psi(mu_j) once the integrals
 *   are fixed; we solve that K x K system (K <= 3) with the integrals from the
 *   previous iterate (the analogue of H = 1/(1 - mu int Psi H/(mu+mu'))), and
 *   accelerate with Anderson mixing of depth HC_AA (type II, least squares by
 *   modified Gram-Schmidt).  8-25 iterations to 1e-15.
 *
 * ---------------------------------------------------------------- departures
 *  1. f^(1): the exact solution has prefactor c/(3 pi), i.e. f^(1)_exact =
 *     2 x eq. 22 (with the exact l, m).  Its first-order term is 2 x eq. 28.
 *     This is the "factor 2 on the cos phi mode" finding, derived here:
 *     eq. 22 is correct in shape, and eqs. 22 and 28 are both half of the
 *     cos(phi) Fourier coefficient of eq. 9.  hc_f1 returns the exact (doubled)
 *     value.  Nothing changes in the phi-average (eq. 30 normalisation is exact).
 *  2. Conservative limit c -> 1 (m = 0).  At c = 1 exactly the discrete psi
 *     system is singular (one zero singular value of its Jacobian: the
 *     0/0 limits of [RT] §47-type conservative problems) and the iteration
 *     converges to a spurious member of a one-parameter family (psi_1 = 0,
 *     E != 0, wrong H).  Near c = 1 the smallest singular value is ~0.8 s,
 *     s = sqrt(1 - c).  The constants are smooth in s, so for s < HC_S_SWITCH
 *     (c > 0.9975) we evaluate them at HC_NS Chebyshev nodes in s on
 *     [HC_S_LO, HC_S_HI] and interpolate (extrapolate) the polynomial in s:
 *     ~1e-10 absolute.  The m = 1 mode (K1(0) > 1) needs nothing of this.
 *     At c = 1 the result is C = 15/128, D = E = F = 0 (to 1e-10), B = -0.0833231.
 *  3. The paper's eq. 22 writes H1 with Psi1 of eq. 14 and its eq. 30 with
 *     Psi0 of eq. 13; here both H's are implied by the psi system (v) and the
 *     tests check they are the same functions.
 */
#ifndef BRDFTAB_HORAK_CHANDRASEKHAR_H
#define BRDFTAB_HORAK_CHANDRASEKHAR_H

#include "../common/compat.h"
#include "../common/gauss_legendre.h"

/* The solver works in ACCUM: double wherever the device has fp64, also in a
 * float build (--precision float), because near c = 1 the system is
 * ill-conditioned (~1/sqrt(1 - c)) and float residuals stall above what the
 * extrapolation of departure 2 needs.  Only the results are rounded to REAL. */
typedef ACCUM HC_REAL;
#define HC_R(x) ((HC_REAL)(x))
#define HC_PI HC_R(3.14159265358979323846)

#define HC_N 48          /* Gauss-Legendre nodes in s = log mu */
#define HC_SPAN HC_R(34.0)  /* mu in [exp(-HC_SPAN), 1] */
#define HC_KMAX 3        /* functions per mode (m = 0: 3, m = 1: 2, m = 2: 1) */
#define HC_LEN (HC_KMAX * HC_N)
#define HC_AA 5          /* Anderson depth */
#define HC_MAX_IT 300
/* Iteration tolerance: 1e-15 in double; a device without fp64 (ACCUM =
 * float) cannot go below ~1e-7, so it stops at 2e-6 (constants good to
 * ~1e-5 away from c = 1). */
#if BT_DEVICE && !(defined(BT_HAS_FP64) && BT_HAS_FP64)
#define HC_TOL HC_R(2e-6)
#else
#define HC_TOL HC_R(1e-15)
#endif
#define HC_S_SWITCH HC_R(0.05) /* s = sqrt(1 - c) below which departure 2 applies */
#define HC_S_LO HC_R(0.05)
#define HC_S_HI HC_R(0.35)
#define HC_NS 10
#define HC_NQ 6          /* max least-squares unknowns */
/* Constants: hc_constants output indices. */
#define HC_L 0
#define HC_M 1
#define HC_A 2
#define HC_B 3
#define HC_C 4
#define HC_D 5
#define HC_E 6
#define HC_F 7

typedef struct {
    int m;                     /* Fourier mode 0, 1, 2 */
    int k;                     /* number of functions */
    HC_REAL c;
    HC_REAL mu[HC_N];             /* nodes */
    HC_REAL wg[HC_N];             /* weight x (1 - mu^2)^m, dmu = mu ds included */
    HC_REAL p[HC_KMAX][HC_N];     /* reduced Legendre functions p_l at the nodes */
    HC_REAL coef[HC_KMAX][HC_KMAX]; /* (1/2)(-1)^(k+l) w_k^m, [k][l] */
    HC_REAL chi[HC_KMAX * HC_N];  /* solution chi_l(mu_j) at [l * HC_N + j] */
    int iterations;            /* < 0: not converged */
    HC_REAL residual;             /* max |G(chi) - chi| at exit */
} hc_mode;


/* Reduced Legendre function p_l of mode m (derivation (iv)), l-index i. */
BT_INLINE HC_REAL hc_p(int m, int i, HC_REAL x)
{
    if (m == 0) return i == 0 ? HC_R(1.0) : (i == 1 ? x : HC_R(1.5) * x * x - HC_R(0.5));
    if (m == 1) return i == 0 ? HC_R(1.0) : HC_R(3.0) * x;
    return HC_R(3.0);
}

/* Solve the n x n (n <= HC_KMAX) system a x = b in place (partial pivoting). */
BT_INLINE void hc_small_solve(int n, HC_REAL a[HC_KMAX][HC_KMAX], HC_REAL* b)
{
    for (int col = 0; col < n; ++col) {
        int piv = col;
        for (int r = col + 1; r < n; ++r)
            if (fabs(a[r][col]) > fabs(a[piv][col])) piv = r;
        if (piv != col) {
            for (int q = 0; q < n; ++q) {
                HC_REAL t = a[col][q];
                a[col][q] = a[piv][q];
                a[piv][q] = t;
            }
            HC_REAL t = b[col];
            b[col] = b[piv];
            b[piv] = t;
        }
        for (int r = col + 1; r < n; ++r) {
            HC_REAL f = a[r][col] / a[col][col];
            for (int q = col; q < n; ++q) a[r][q] -= f * a[col][q];
            b[r] -= f * b[col];
        }
    }
    for (int r = n - 1; r >= 0; --r) {
        HC_REAL s = b[r];
        for (int q = r + 1; q < n; ++q) s -= a[r][q] * b[q];
        b[r] = s / a[r][r];
    }
}

/* The fixed-point map at one abscissa x: given chi on the nodes, the
 * integrals I_kl(x) = int (1-mu'^2)^m chi_k p_l/(x + mu') are fixed and (*)
 * is solved for chi(x) (K x K).  out[l] = chi_l(x).  Also the Nystrom
 * interpolation of the converged solution (hc_psi_at). */
BT_INLINE void hc_apply_at(const hc_mode* M, const HC_REAL* chi, HC_REAL x, HC_REAL* out)
{
    int K = M->k;
    HC_REAL I[HC_KMAX][HC_KMAX];
    for (int a = 0; a < HC_KMAX; ++a)
        for (int b = 0; b < HC_KMAX; ++b) I[a][b] = HC_R(0.0);
    for (int n = 0; n < HC_N; ++n) {
        HC_REAL g = M->wg[n] / (x + M->mu[n]);
        for (int k = 0; k < K; ++k) {
            HC_REAL gk = g * chi[k * HC_N + n];
            for (int l = 0; l < K; ++l) I[k][l] += gk * M->p[l][n];
        }
    }
    HC_REAL A[HC_KMAX][HC_KMAX];
    for (int l = 0; l < K; ++l) {
        for (int k = 0; k < K; ++k) A[l][k] = (l == k ? HC_R(1.0) : HC_R(0.0)) - x * M->coef[k][l] * I[k][l];
        out[l] = hc_p(M->m, l, x);
    }
    hc_small_solve(K, A, out);
}

/* x <- argmin |A x - b| for an nrow x ncol (ncol <= HC_NQ, nrow <= HC_LEN)
 * column-major matrix a[col * HC_LEN + row], by modified Gram-Schmidt applied
 * twice.  Columns whose remaining norm is below 1e-13 of their own are
 * dropped (x = 0).  a is overwritten by Q.  Returns the number of columns kept. */
BT_INLINE int hc_lsq(HC_REAL* a, int nrow, int ncol, const HC_REAL* b, HC_REAL* x)
{
    HC_REAL r[HC_NQ][HC_NQ];
    int keep[HC_NQ];
    for (int i = 0; i < HC_NQ; ++i)
        for (int j = 0; j < HC_NQ; ++j) r[i][j] = HC_R(0.0);
    int kept = 0;
    for (int j = 0; j < ncol; ++j) {
        HC_REAL* aj = a + j * HC_LEN;
        HC_REAL n0 = HC_R(0.0);
        for (int i = 0; i < nrow; ++i) n0 += aj[i] * aj[i];
        n0 = sqrt(n0);
        for (int pass = 0; pass < 2; ++pass)
            for (int q = 0; q < j; ++q) {
                if (!keep[q]) continue;
                const HC_REAL* aq = a + q * HC_LEN;
                HC_REAL d = HC_R(0.0);
                for (int i = 0; i < nrow; ++i) d += aq[i] * aj[i];
                for (int i = 0; i < nrow; ++i) aj[i] -= d * aq[i];
                r[q][j] += d;
            }
        HC_REAL nn = HC_R(0.0);
        for (int i = 0; i < nrow; ++i) nn += aj[i] * aj[i];
        nn = sqrt(nn);
        keep[j] = (n0 > HC_R(0.0) && nn > HC_R(1e-13) * n0) ? 1 : 0;
        if (keep[j]) {
            for (int i = 0; i < nrow; ++i) aj[i] /= nn;
            r[j][j] = nn;
            ++kept;
        }
    }
    HC_REAL qtb[HC_NQ];
    for (int j = 0; j < ncol; ++j) {
        qtb[j] = HC_R(0.0);
        if (!keep[j]) continue;
        const HC_REAL* aj = a + j * HC_LEN;
        for (int i = 0; i < nrow; ++i) qtb[j] += aj[i] * b[i];
    }
    for (int j = ncol - 1; j >= 0; --j) {
        if (!keep[j]) {
            x[j] = HC_R(0.0);
            continue;
        }
        HC_REAL s = qtb[j];
        for (int q = j + 1; q < ncol; ++q)
            if (keep[q]) s -= r[j][q] * x[q];
        x[j] = s / r[j][j];
    }
    return kept;
}

/* Set up and solve mode m (0, 1, 2) of the psi system (*) at albedo c.
 * Returns the iteration count (< 0 if HC_MAX_IT was reached). */
BT_INLINE int hc_solve_mode(hc_mode* M, int m, HC_REAL c)
{
    M->m = m;
    M->c = c;
    M->k = m == 0 ? 3 : (m == 1 ? 2 : 1);
    HC_REAL w[3];
    if (m == 0) {
        w[0] = c;
        w[1] = -HC_R(4.0) * c / HC_R(3.0);
        w[2] = HC_R(5.0) * c / HC_R(16.0);
    } else if (m == 1) {
        w[0] = -HC_R(2.0) * c / HC_R(3.0); /* w_1 (l-1)!/(l+1)! = w_1/2 */
        w[1] = HC_R(5.0) * c / HC_R(96.0); /* w_2/6 */
        w[2] = HC_R(0.0);
    } else {
        w[0] = HC_R(5.0) * c / HC_R(384.0); /* w_2/24 */
        w[1] = w[2] = HC_R(0.0);
    }
    int K = M->k;
    /* (-1)^(k+l) of (*): with Legendre degrees i + m, j + m it is (-1)^(i+j). */
    for (int k = 0; k < HC_KMAX; ++k)
        for (int l = 0; l < HC_KMAX; ++l)
            M->coef[k][l] = (k < K && l < K) ? HC_R(0.5) * (((k + l) & 1) ? -HC_R(1.0) : HC_R(1.0)) * w[k] : HC_R(0.0);
    for (int j = 0; j < HC_N; ++j) {
        HC_REAL xg, wgl;
        bt_gauss_legendre(HC_N, j, &xg, &wgl); /* HC_REAL is ACCUM */
        HC_REAL s = -HC_R(0.5) * HC_SPAN * (HC_R(1.0) - xg);
        HC_REAL mu = exp(s);
        HC_REAL g = HC_R(1.0);
        for (int q = 0; q < m; ++q) g *= HC_R(1.0) - mu * mu;
        M->mu[j] = mu;
        M->wg[j] = HC_R(0.5) * HC_SPAN * wgl * mu * g;
        for (int l = 0; l < HC_KMAX; ++l) M->p[l][j] = l < K ? hc_p(m, l, mu) : HC_R(0.0);
    }
    for (int l = 0; l < HC_KMAX; ++l)
        for (int j = 0; j < HC_N; ++j) M->chi[l * HC_N + j] = l < K ? M->p[l][j] : HC_R(0.0);

    /* Anderson-accelerated iteration (derivation (vii)). */
    const int L = K * HC_N;
    HC_REAL hx[HC_AA + 1][HC_LEN], hf[HC_AA + 1][HC_LEN];
    HC_REAL dfm[HC_AA * HC_LEN], gam[HC_NQ], gx[HC_LEN], out[HC_KMAX];
    int nh = 0, head = 0; /* ring buffer: newest at head - 1 */
    M->iterations = -1;
    for (int it = 0; it < HC_MAX_IT; ++it) {
        for (int j = 0; j < HC_N; ++j) {
            hc_apply_at(M, M->chi, M->mu[j], out);
            for (int l = 0; l < K; ++l) gx[l * HC_N + j] = out[l];
        }
        HC_REAL res = HC_R(0.0);
        for (int i = 0; i < L; ++i) res = fmax(res, fabs(gx[i] - M->chi[i]));
        M->residual = res;
        if (res < HC_TOL || !(res == res)) {
            for (int i = 0; i < L; ++i) M->chi[i] = gx[i];
            M->iterations = (res == res) ? it : -1;
            break;
        }
        for (int i = 0; i < L; ++i) {
            hx[head][i] = M->chi[i];
            hf[head][i] = gx[i] - M->chi[i];
        }
        head = (head + 1) % (HC_AA + 1);
        if (nh < HC_AA + 1) ++nh;
        int ncol = nh - 1;
        int newest = (head + HC_AA) % (HC_AA + 1);
        if (ncol > 0) {
            /* columns dF_q = f_(q+1) - f_q, newest first */
            HC_REAL rhs[HC_LEN];
            for (int q = 0; q < ncol; ++q) {
                int i1 = (newest - q + HC_AA + 1) % (HC_AA + 1);
                int i0 = (newest - q - 1 + 2 * (HC_AA + 1)) % (HC_AA + 1);
                for (int i = 0; i < L; ++i) dfm[q * HC_LEN + i] = hf[i1][i] - hf[i0][i];
            }
            for (int i = 0; i < L; ++i) rhs[i] = hf[newest][i];
            hc_lsq(dfm, L, ncol, rhs, gam);
            for (int i = 0; i < L; ++i) {
                HC_REAL v = hx[newest][i] + hf[newest][i];
                for (int q = 0; q < ncol; ++q) {
                    int i1 = (newest - q + HC_AA + 1) % (HC_AA + 1);
                    int i0 = (newest - q - 1 + 2 * (HC_AA + 1)) % (HC_AA + 1);
                    v -= gam[q] * ((hx[i1][i] - hx[i0][i]) + (hf[i1][i] - hf[i0][i]));
                }
                M->chi[i] = v;
            }
        } else {
            for (int i = 0; i < L; ++i) M->chi[i] = gx[i];
        }
    }
    return M->iterations;
}

/* Reduced psi functions chi_l(x) = psi_l(x) / (1 - x^2)^(m/2) of a solved
 * mode at any x in [0, 1] (Nystrom interpolation: (*) evaluated at x). */
BT_INLINE void hc_psi_at(const hc_mode* M, HC_REAL x, HC_REAL* chi_out) { hc_apply_at(M, M->chi, x, chi_out); }

/* Polynomials q_l (derivation (v)) as q[l * 3 + j] = coefficient of mu^j,
 * from chi_0 q_l - chi_l q_0 = 0 at every node (least squares, no H needed).
 * Returns the max residual of these equations (structure check). */
BT_INLINE HC_REAL hc_q_coefficients(const hc_mode* M, HC_REAL* q)
{
    HC_REAL a[HC_NQ * HC_LEN], b[HC_LEN], x[HC_NQ];
    for (int i = 0; i < 9; ++i) q[i] = HC_R(0.0);
    int nrow = 0, ncol;
    if (M->m == 0) {
        /* unknowns a1 a2 b1 b2 d1 d2 */
        ncol = 6;
        for (int j = 0; j < HC_N; ++j) {
            HC_REAL mu = M->mu[j], mu2 = mu * mu;
            HC_REAL p0 = M->chi[j], p1 = M->chi[HC_N + j], p2 = M->chi[2 * HC_N + j];
            /* p0 (b1 mu + b2 mu^2) - p1 (1 + a1 mu + a2 mu^2) = 0 */
            HC_REAL row1[6] = {-p1 * mu, -p1 * mu2, p0 * mu, p0 * mu2, HC_R(0.0), HC_R(0.0)};
            /* p0 (-1/2 + d1 mu + d2 mu^2) - p2 (1 + a1 mu + a2 mu^2) = 0 */
            HC_REAL row2[6] = {-p2 * mu, -p2 * mu2, HC_R(0.0), HC_R(0.0), p0 * mu, p0 * mu2};
            for (int col = 0; col < 6; ++col) {
                a[col * HC_LEN + nrow] = row1[col];
                a[col * HC_LEN + nrow + 1] = row2[col];
            }
            b[nrow] = p1;
            b[nrow + 1] = p2 + HC_R(0.5) * p0;
            nrow += 2;
        }
    } else if (M->m == 1) {
        /* unknowns alpha beta: chi_1 beta mu - chi_2 (1 + alpha mu) = 0 */
        ncol = 2;
        for (int j = 0; j < HC_N; ++j) {
            HC_REAL mu = M->mu[j];
            HC_REAL p1 = M->chi[j], p2 = M->chi[HC_N + j];
            a[nrow] = -p2 * mu;
            a[HC_LEN + nrow] = p1 * mu;
            b[nrow] = p2;
            ++nrow;
        }
    } else {
        q[0] = HC_R(3.0); /* chi = 3 H2: q_2 = 3 */
        return HC_R(0.0);
    }
    HC_REAL a_copy[HC_NQ * HC_LEN];
    for (int i = 0; i < HC_NQ * HC_LEN; ++i) a_copy[i] = a[i];
    hc_lsq(a, nrow, ncol, b, x);
    HC_REAL res = HC_R(0.0);
    for (int i = 0; i < nrow; ++i) {
        HC_REAL s = -b[i];
        for (int col = 0; col < ncol; ++col) s += a_copy[col * HC_LEN + i] * x[col];
        res = fmax(res, fabs(s));
    }
    if (M->m == 0) {
        q[0] = HC_R(1.0); q[1] = x[0]; q[2] = x[1];
        q[3] = HC_R(0.0); q[4] = x[2]; q[5] = x[3];
        q[6] = -HC_R(0.5); q[7] = x[4]; q[8] = x[5];
    } else {
        q[0] = HC_R(1.0); q[1] = x[0];
        q[3] = HC_R(0.0); q[4] = x[1];
    }
    return res;
}

/* The H-function implied by the solved system, H_m(x) = chi_0(x) / q_0(x)
 * (q as returned by hc_q_coefficients; for m = 2, chi / 3). */
BT_INLINE HC_REAL hc_h_at(const hc_mode* M, const HC_REAL* q, HC_REAL x)
{
    HC_REAL chi[HC_KMAX];
    hc_psi_at(M, x, chi);
    return chi[0] / (q[0] + x * (q[1] + x * q[2]));
}

/* l, m (eq. 22, derivation (vi)) and A..F (eq. 30) at c without the
 * conservative-limit treatment (departure 2): accurate for c < ~0.9999, a
 * spurious solution at c = 1.  out[0..7] = l, m, A, B, C, D, E, F.
 * Returns 0 on success, -1 if an iteration did not converge. */
BT_INLINE int hc_constants_direct(HC_REAL c, HC_REAL* out)
{
    hc_mode M;
    HC_REAL q[9];
    int ok = 0;
    if (hc_solve_mode(&M, 1, c) < 0) ok = -1;
    hc_q_coefficients(&M, q);
    out[0] = q[1];                 /* l = alpha */
    out[1] = q[4] * q[4] / HC_R(9.0); /* m = beta^2 / 9 */
    if (hc_solve_mode(&M, 0, c) < 0) ok = -1;
    hc_q_coefficients(&M, q);
    HC_REAL wd[3] = {HC_R(0.5) * c, HC_R(0.5) * HC_R(4.0) * c / HC_R(3.0), HC_R(0.5) * HC_R(5.0) * c / HC_R(16.0)};
    HC_REAL Mx[3][3];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            HC_REAL s = HC_R(0.0);
            for (int l = 0; l < 3; ++l) s += q[l * 3 + i] * wd[l] * q[l * 3 + j];
            Mx[i][j] = s;
        }
    out[2] = Mx[0][0]; /* A */
    out[3] = Mx[0][1]; /* B */
    out[4] = Mx[1][1]; /* C */
    out[5] = Mx[1][2]; /* D */
    out[6] = Mx[2][2]; /* E */
    out[7] = Mx[0][2]; /* F */
    return ok;
}

/* l, m, A, B, C, D, E, F at c in [0, 1] (departure 2 for c > 1 - HC_S_SWITCH^2).
 * Returns 0 on success, -1 if an iteration did not converge. */
BT_INLINE int hc_constants(HC_REAL c, HC_REAL* out)
{
    HC_REAL s = sqrt(fmax(HC_R(1.0) - c, HC_R(0.0)));
    if (s >= HC_S_SWITCH) return hc_constants_direct(c, out);
    int ok = 0;
    HC_REAL tmp[8];
    /* m = 1 is regular at c = 1: direct. */
    ok |= hc_constants_direct(c, tmp) < 0 ? -1 : 0;
    out[0] = tmp[0];
    out[1] = tmp[1];
    for (int i = 2; i < 8; ++i) out[i] = HC_R(0.0);
    HC_REAL sj[HC_NS], vj[HC_NS][8];
    for (int j = 0; j < HC_NS; ++j) {
        sj[j] = HC_R(0.5) * (HC_S_LO + HC_S_HI) +
                HC_R(0.5) * (HC_S_HI - HC_S_LO) * cos(HC_PI * ((HC_REAL)j + HC_R(0.5)) / (HC_REAL)HC_NS);
        ok |= hc_constants_direct(HC_R(1.0) - sj[j] * sj[j], vj[j]) < 0 ? -1 : 0;
    }
    for (int j = 0; j < HC_NS; ++j) {
        HC_REAL Lj = HC_R(1.0);
        for (int i = 0; i < HC_NS; ++i)
            if (i != j) Lj *= (s - sj[i]) / (sj[j] - sj[i]);
        for (int i = 2; i < 8; ++i) out[i] += Lj * vj[j][i];
    }
    out[2] = HC_R(69.0) * c / HC_R(128.0); /* exact either way (q_l(0) = P_l(0)) */
    return ok;
}

/* eq. 30 (phi-average f^(0)) with k = hc_constants output. */
BT_INLINE REAL hc_f0(REAL mi, REAL mo, REAL h0i, REAL h0o, const REAL* k)
{
    REAL sum = mi + mo, prod = mi * mo;
    REAL poly = k[2] + k[3] * sum + k[4] * prod + k[5] * prod * sum + k[6] * prod * prod +
                k[7] * (mi * mi + mo * mo);
    return h0i * h0o * poly / (R(2.0) * BT_PI * sum);
}

/* The exact cos(phi) coefficient f^(1) = 2 x eq. 22 (departure 1). */
BT_INLINE REAL hc_f1(REAL mi, REAL mo, REAL h1i, REAL h1o, REAL c, const REAL* k)
{
    REAL l = k[0], m = k[1];
    REAL S = sqrt(fmax((R(1.0) - mi * mi) * (R(1.0) - mo * mo), R(0.0)));
    return c * h1i * h1o * S * (R(1.0) + (l * l + R(45.0) * m / R(64.0)) * mi * mo + l * (mi + mo)) /
           (R(3.0) * BT_PI * (mi + mo));
}

/* The exact cos(2 phi) coefficient (derivation (vi); eq. 21 sets it to 0). */
BT_INLINE REAL hc_f2(REAL mi, REAL mo, REAL h2i, REAL h2o, REAL c)
{
    return R(15.0) * c * (R(1.0) - mi * mi) * (R(1.0) - mo * mo) * h2i * h2o / (R(256.0) * BT_PI * (mi + mo));
}

#endif /* BRDFTAB_HORAK_CHANDRASEKHAR_H */

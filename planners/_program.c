/* The native evaluator of traced stage programs (planners/program.py), and Newton's method on series
 * around it: the same operations, tangents and steps as planners/_program_kernels.py (numba) and
 * planners/newton.py (numpy), in C, compiled once per machine by the system's C compiler
 * (planners/_native.py) and loaded with ctypes.
 *
 * A program is data: an int64 table, one row (op, out, a, b, k, unk) per instruction, and a vector of
 * parameters (the aircraft's numbers).  Registers hold truncated power series on a batch of nodes,
 * coefficient first: register r, coefficient k, node i at W[(r * M + k) * S + i].  Data and unknowns are
 * read with their own coefficient counts (Md, Mx >= M), so one array at the top order serves every lower
 * working order.  The tangent is forward mode on series in real arithmetic: T[((r * n + d) * M + k) * S + i]
 * is coefficient k of d(register r)/d(unknown d).
 *
 * Every function returns 0 on success; the Newton functions return 1 when the caller's full scheme must
 * take over (as planners.newton._warm_newton returning None) and 2 when a Jacobian's constant term is
 * exactly singular at a node (the caller then reruns the numpy path, which takes a least-squares step).
 */

#if !defined(_WIN32) && !defined(_POSIX_C_SOURCE)
#define _POSIX_C_SOURCE 199309L /* clock_gettime */
#endif
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

typedef int64_t i64;

enum {
    INPUT, DATA, ADD, SUB, MUL, DIV, NEG, ADDC, RSUBC, MULC, DIVC, RDIVC,
    SQRT, EXP, LOG, SINCOS, SINHCOSH, POW, ARCTAN, CONST, AXPY, ZERO, TAN, COPY, DERIV, ATAN2
};

/* ------------------------------------------------------------------ series recurrences on (M, S) */

/* The Cauchy products accumulate each coefficient of a block of BLOCK nodes in local variables (registers):
 * the same sum, in the same order (j ascending), as one node at a time.  The last nodes (S not a multiple of
 * BLOCK) are one more block ending at node S - 1, overlapping the one before: its nodes' sums are computed
 * again, the same operations on the same operands, and written again with the same bits (the output distinct
 * from the operands; else, and for S < BLOCK, node by node). */
#define BLOCK 8
#if defined(__GNUC__) && !defined(__clang__)
#define HOT __attribute__((optimize("O3")))
#else
#define HOT
#endif

/* whether the M S doubles at o and at a do not overlap */
static int disjoint(const double *o, const double *a, i64 MS) {
    uintptr_t po = (uintptr_t)o, pa = (uintptr_t)a, len = (uintptr_t)MS * sizeof(double);
    return po + len <= pa || pa + len <= po;
}

HOT static inline void mul_block(const double *a, const double *b, double *out, i64 k, i64 S, i64 i) {
    double acc[BLOCK] = {0.0};
    for (i64 j = 0; j <= k; j++) {
        const double *aj = a + j * S + i, *bk = b + (k - j) * S + i;
        for (int q = 0; q < BLOCK; q++) acc[q] += aj[q] * bk[q];
    }
    for (int q = 0; q < BLOCK; q++) out[k * S + i + q] = acc[q];
}

HOT static void s_mul(const double *a, const double *b, double *out, i64 M, i64 S) {
    int overlap = S > BLOCK && disjoint(out, a, M * S) && disjoint(out, b, M * S);
    for (i64 k = 0; k < M; k++) {
        i64 i = 0;
        for (; i + BLOCK <= S; i += BLOCK) mul_block(a, b, out, k, S, i);
        if (i < S && overlap)
            mul_block(a, b, out, k, S, S - BLOCK);
        else if (i < S) { /* the last nodes: independent sums side by side (each node's in the same order) */
            i64 rem = S - i;
            double acc[BLOCK] = {0.0};
            for (i64 j = 0; j <= k; j++) {
                const double *aj = a + j * S + i, *bk = b + (k - j) * S + i;
                for (i64 q = 0; q < rem; q++) acc[q] += aj[q] * bk[q];
            }
            for (i64 q = 0; q < rem; q++) out[k * S + i + q] = acc[q];
        }
    }
}

/* out += a * b */
static void s_mul_add(const double *a, const double *b, double *out, i64 M, i64 S) {
    for (i64 k = 0; k < M; k++)
        for (i64 j = 0; j <= k; j++) {
            const double *aj = a + j * S, *bk = b + (k - j) * S;
            for (i64 i = 0; i < S; i++) out[k * S + i] += aj[i] * bk[i];
        }
}

HOT static inline void mul2_block(const double *a, const double *b, const double *c, const double *d, double *out,
                                  i64 k, i64 S, i64 i) {
    double acc[BLOCK] = {0.0};
    for (i64 j = 0; j <= k; j++) {
        const double *aj = a + j * S + i, *bk = b + (k - j) * S + i;
        const double *cj = c + j * S + i, *dk = d + (k - j) * S + i;
        for (int q = 0; q < BLOCK; q++) acc[q] += aj[q] * bk[q] + cj[q] * dk[q];
    }
    for (int q = 0; q < BLOCK; q++) out[k * S + i + q] = acc[q];
}

/* out = a * b + c * d (the tangent of a product: one pass) */
HOT static void s_mul2(const double *a, const double *b, const double *c, const double *d, double *out, i64 M, i64 S) {
    i64 MS = M * S;
    int overlap = S > BLOCK && disjoint(out, a, MS) && disjoint(out, b, MS) && disjoint(out, c, MS)
                  && disjoint(out, d, MS);
    for (i64 k = 0; k < M; k++) {
        i64 i = 0;
        for (; i + BLOCK <= S; i += BLOCK) mul2_block(a, b, c, d, out, k, S, i);
        if (i < S && overlap)
            mul2_block(a, b, c, d, out, k, S, S - BLOCK);
        else if (i < S) {
            i64 rem = S - i;
            double acc[BLOCK] = {0.0};
            for (i64 j = 0; j <= k; j++) {
                const double *aj = a + j * S + i, *bk = b + (k - j) * S + i;
                const double *cj = c + j * S + i, *dk = d + (k - j) * S + i;
                for (i64 q = 0; q < rem; q++) acc[q] += aj[q] * bk[q] + cj[q] * dk[q];
            }
            for (i64 q = 0; q < rem; q++) out[k * S + i + q] = acc[q];
        }
    }
}

HOT static inline void div_block(const double *a, const double *b, double *out, i64 k, i64 S, i64 i) {
    double acc[BLOCK];
    for (int q = 0; q < BLOCK; q++) acc[q] = a[k * S + i + q];
    for (i64 j = 1; j <= k; j++) {
        const double *bj = b + j * S + i, *ok = out + (k - j) * S + i;
        for (int q = 0; q < BLOCK; q++) acc[q] -= bj[q] * ok[q];
    }
    for (int q = 0; q < BLOCK; q++) out[k * S + i + q] = acc[q] / b[i + q];
}

/* out = a / b (out distinct from b; may equal a): coefficient k is (a_k - sum_(j=1..k) b_j out_(k-j)) / b_0,
 * j ascending, by blocks of nodes as the products (the overlapping last block only when out is not a) */
HOT static void s_div(const double *a, const double *b, double *out, i64 M, i64 S) {
    int overlap = S > BLOCK && disjoint(out, a, M * S);
    for (i64 k = 0; k < M; k++) {
        i64 i = 0;
        for (; i + BLOCK <= S; i += BLOCK) div_block(a, b, out, k, S, i);
        if (i < S && overlap)
            div_block(a, b, out, k, S, S - BLOCK);
        else
            for (; i < S; i++) {
                double acc = a[k * S + i];
                for (i64 j = 1; j <= k; j++) acc -= b[j * S + i] * out[(k - j) * S + i];
                out[k * S + i] = acc / b[i];
            }
    }
}

static void s_sqrt(const double *u, double *out, i64 M, i64 S) {
    for (i64 i = 0; i < S; i++) out[i] = sqrt(u[i]);
    for (i64 k = 1; k < M; k++) {
        double *o = out + k * S;
        for (i64 i = 0; i < S; i++) o[i] = u[k * S + i];
        for (i64 j = 1; j < k; j++) {
            const double *a = out + j * S, *b = out + (k - j) * S;
            for (i64 i = 0; i < S; i++) o[i] -= a[i] * b[i];
        }
        for (i64 i = 0; i < S; i++) o[i] /= 2.0 * out[i];
    }
}

static void s_exp(const double *u, double *out, i64 M, i64 S) {
    for (i64 i = 0; i < S; i++) out[i] = exp(u[i]);
    for (i64 k = 1; k < M; k++) {
        double *o = out + k * S;
        for (i64 i = 0; i < S; i++) o[i] = 0.0;
        for (i64 j = 1; j <= k; j++) {
            const double *a = u + j * S, *b = out + (k - j) * S;
            for (i64 i = 0; i < S; i++) o[i] += j * a[i] * b[i];
        }
        for (i64 i = 0; i < S; i++) o[i] /= (double)k;
    }
}

static void s_log(const double *u, double *out, i64 M, i64 S) {
    for (i64 i = 0; i < S; i++) out[i] = log(u[i]);
    for (i64 k = 1; k < M; k++) {
        double *o = out + k * S;
        for (i64 i = 0; i < S; i++) o[i] = 0.0;
        for (i64 j = 1; j < k; j++) {
            const double *a = out + j * S, *b = u + (k - j) * S;
            for (i64 i = 0; i < S; i++) o[i] += j * a[i] * b[i];
        }
        for (i64 i = 0; i < S; i++) o[i] = (u[k * S + i] - o[i] / (double)k) / u[i];
    }
}

HOT static inline void sincos_block(const double *u, double *s, double *c, double sign, i64 k, i64 S, i64 i) {
    /* the two sums one after the other (each one's terms in the order of the node-by-node loop; v = j u_j,
     * the same value in both) */
    double as[BLOCK] = {0.0}, ac[BLOCK] = {0.0};
    for (i64 j = 1; j <= k; j++) {
        const double *uj = u + j * S + i, *cj = c + (k - j) * S + i;
        double jd = (double)j;
        for (int q = 0; q < BLOCK; q++) as[q] += (jd * uj[q]) * cj[q];
    }
    for (i64 j = 1; j <= k; j++) {
        const double *uj = u + j * S + i, *sj = s + (k - j) * S + i;
        double jd = (double)j;
        for (int q = 0; q < BLOCK; q++) ac[q] += (jd * uj[q]) * sj[q];
    }
    for (int q = 0; q < BLOCK; q++) s[k * S + i + q] = as[q] / (double)k;
    for (int q = 0; q < BLOCK; q++) c[k * S + i + q] = sign * ac[q] / (double)k;
}

/* sin/cos (sign -1) or sinh/cosh (sign +1); the sums by blocks of nodes in registers as the products */
HOT static void s_sincos(const double *u, double *s, double *c, double sign, i64 M, i64 S) {
    for (i64 i = 0; i < S; i++) {
        if (sign < 0) {
            s[i] = sin(u[i]);
            c[i] = cos(u[i]);
        } else {
            s[i] = sinh(u[i]);
            c[i] = cosh(u[i]);
        }
    }
    int overlap = S > BLOCK && disjoint(s, u, M * S) && disjoint(c, u, M * S) && disjoint(s, c, M * S);
    for (i64 k = 1; k < M; k++) {
        i64 i0 = 0;
        for (; i0 + BLOCK <= S; i0 += BLOCK) sincos_block(u, s, c, sign, k, S, i0);
        if (i0 < S && overlap) {
            sincos_block(u, s, c, sign, k, S, S - BLOCK);
            continue;
        }
        double *sk = s + k * S, *ck = c + k * S;
        for (i64 i = i0; i < S; i++) sk[i] = ck[i] = 0.0;
        for (i64 j = 1; j <= k; j++) {
            const double *uj = u + j * S, *cj = c + (k - j) * S, *sj = s + (k - j) * S;
            for (i64 i = i0; i < S; i++) {
                double v = j * uj[i];
                sk[i] += v * cj[i];
                ck[i] += v * sj[i];
            }
        }
        for (i64 i = i0; i < S; i++) {
            sk[i] /= (double)k;
            ck[i] = sign * ck[i] / (double)k;
        }
    }
}

static void s_pow(const double *u, double p, double *out, i64 M, i64 S) {
    for (i64 i = 0; i < S; i++) out[i] = pow(u[i], p);
    for (i64 k = 1; k < M; k++) {
        double *o = out + k * S;
        for (i64 i = 0; i < S; i++) o[i] = 0.0;
        for (i64 j = 1; j <= k; j++) {
            const double *a = u + j * S, *b = out + (k - j) * S;
            double f = p * j - (k - j);
            for (i64 i = 0; i < S; i++) o[i] += f * a[i] * b[i];
        }
        for (i64 i = 0; i < S; i++) o[i] /= (k * u[i]);
    }
}

/* arctan(u) = arctan(u0) + integral(u' / (1 + u^2)); scratch: 2 M S */
static void s_arctan(const double *u, double *out, i64 M, i64 S, double *scratch) {
    double *w = scratch, *q = scratch + M * S;
    s_mul(u, u, w, M, S);
    for (i64 i = 0; i < S; i++) {
        w[i] += 1.0;
        out[i] = atan(u[i]);
    }
    for (i64 k = 0; k < M - 1; k++) {
        double *qk = q + k * S;
        for (i64 i = 0; i < S; i++) qk[i] = (k + 1) * u[(k + 1) * S + i];
        for (i64 j = 1; j <= k; j++) {
            const double *wj = w + j * S, *qj = q + (k - j) * S;
            for (i64 i = 0; i < S; i++) qk[i] -= wj[i] * qj[i];
        }
        for (i64 i = 0; i < S; i++) qk[i] /= w[i];
    }
    for (i64 k = 1; k < M; k++)
        for (i64 i = 0; i < S; i++) out[k * S + i] = q[(k - 1) * S + i] / (double)k;
}

/* tan(u) = sin(u) / cos(u); scratch: 2 M S */
static void s_tan(const double *u, double *out, i64 M, i64 S, double *scratch) {
    double *s = scratch, *c = scratch + M * S;
    s_sincos(u, s, c, -1.0, M, S);
    s_div(s, c, out, M, S);
}

/* arctan2(y, x) = arctan2(y0, x0) + integral((x y' - y x') / (x^2 + y^2)); scratch: 6 M S */
static void s_deriv(const double *u, double *out, i64 M, i64 S);
static void s_atan2(const double *y, const double *x, double *out, i64 M, i64 S, double *scratch) {
    for (i64 i = 0; i < S; i++) out[i] = atan2(y[i], x[i]);
    if (M < 2) return;
    i64 M1 = M - 1;
    double *dy = scratch, *dx = dy + M * S, *num = dx + M * S, *t2 = num + M * S, *den = t2 + M * S;
    double *q = den + M * S;
    s_deriv(y, dy, M, S);
    s_deriv(x, dx, M, S);
    s_mul(x, dy, num, M1, S);
    s_mul(y, dx, t2, M1, S);
    for (i64 i = 0; i < M1 * S; i++) num[i] -= t2[i];
    s_mul(x, x, den, M1, S);
    s_mul(y, y, t2, M1, S);
    for (i64 i = 0; i < M1 * S; i++) den[i] += t2[i];
    s_div(num, den, q, M1, S);
    for (i64 k = 1; k < M; k++)
        for (i64 i = 0; i < S; i++) out[k * S + i] = q[(k - 1) * S + i] / (double)k;
}

/* the time derivative: coefficient m is (m + 1) u_(m+1); the last one 0 */
static void s_deriv(const double *u, double *out, i64 M, i64 S) {
    for (i64 m = 0; m + 1 < M; m++)
        for (i64 i = 0; i < S; i++) out[m * S + i] = (m + 1) * u[(m + 1) * S + i];
    for (i64 i = 0; i < S; i++) out[(M - 1) * S + i] = 0.0;
}

static void s_copy(double *o, const double *a, i64 MS) { memcpy(o, a, (size_t)MS * sizeof(double)); }

static void s_fill(double *o, double v, i64 MS) {
    for (i64 i = 0; i < MS; i++) o[i] = v;
}

/* ------------------------------------------------------------------ the interpreter */

typedef struct {
    const i64 *code;
    i64 ninstr;
    const double *p;
    const double *data;
    i64 Md; /* coefficients per datum in data */
    i64 nreg;
    const i64 *outs;
    const i64 *outs_unk;
    i64 neq;
    i64 n; /* unknowns */
    i64 S;
} Prog;

/* one instruction on the registers W (M coefficients); x: unknowns with Mx coefficients each */
static void value_op(const Prog *P, const i64 *row, double *W, const double *x, i64 Mx, i64 M, double *scratch) {
    i64 op = row[0], o = row[1], a = row[2], b = row[3], k = row[4];
    i64 S = P->S, MS = M * S;
    double *Wo = W + o * MS;
    const double *Wa = W + a * MS, *Wb = W + b * MS;
    const double *p = P->p;
    switch (op) {
    case INPUT:
        for (i64 m = 0; m < M; m++) memcpy(Wo + m * S, x + (a * Mx + m) * S, (size_t)S * sizeof(double));
        break;
    case DATA:
        for (i64 m = 0; m < M; m++) memcpy(Wo + m * S, P->data + (a * P->Md + m) * S, (size_t)S * sizeof(double));
        break;
    case ADD:
        for (i64 i = 0; i < MS; i++) Wo[i] = Wa[i] + Wb[i];
        break;
    case SUB:
        for (i64 i = 0; i < MS; i++) Wo[i] = Wa[i] - Wb[i];
        break;
    case MUL:
        s_mul(Wa, Wb, Wo, M, S);
        break;
    case DIV:
        s_div(Wa, Wb, Wo, M, S);
        break;
    case NEG:
        for (i64 i = 0; i < MS; i++) Wo[i] = -Wa[i];
        break;
    case ADDC:
        s_copy(Wo, Wa, MS);
        for (i64 i = 0; i < S; i++) Wo[i] += p[k];
        break;
    case RSUBC:
        for (i64 i = 0; i < MS; i++) Wo[i] = -Wa[i];
        for (i64 i = 0; i < S; i++) Wo[i] += p[k];
        break;
    case MULC:
        for (i64 i = 0; i < MS; i++) Wo[i] = Wa[i] * p[k];
        break;
    case DIVC:
        for (i64 i = 0; i < MS; i++) Wo[i] = Wa[i] / p[k];
        break;
    case RDIVC:
        s_fill(Wo, 0.0, MS);
        for (i64 i = 0; i < S; i++) Wo[i] = p[k];
        s_div(Wo, Wa, Wo, M, S);
        break;
    case SQRT:
        s_sqrt(Wa, Wo, M, S);
        break;
    case EXP:
        s_exp(Wa, Wo, M, S);
        break;
    case LOG:
        s_log(Wa, Wo, M, S);
        break;
    case SINCOS:
        s_sincos(Wa, Wo, W + b * MS, -1.0, M, S);
        break;
    case SINHCOSH:
        s_sincos(Wa, Wo, W + b * MS, 1.0, M, S);
        break;
    case POW:
        s_pow(Wa, p[k], Wo, M, S);
        break;
    case ARCTAN:
        s_arctan(Wa, Wo, M, S, scratch);
        break;
    case CONST:
        s_fill(Wo, 0.0, MS);
        for (i64 i = 0; i < S; i++) Wo[i] = p[k];
        break;
    case AXPY:
        for (i64 i = 0; i < MS; i++) Wo[i] = Wa[i] + p[k] * Wb[i];
        break;
    case ZERO:
        s_fill(Wo, 0.0, MS);
        break;
    case TAN:
        s_tan(Wa, Wo, M, S, scratch);
        break;
    case COPY:
        s_copy(Wo, Wa, MS);
        break;
    case DERIV:
        s_deriv(Wa, Wo, M, S);
        break;
    case ATAN2:
        s_atan2(Wa, Wb, Wo, M, S, scratch);
        break;
    }
}

/* the dependency masks of planners._native.tangent_masks: bits 2.. and UNK_SHIFT.. of a row's unk */
#define UNK_BITS 30
#define UNK_SHIFT 32
#define UNK_MASK ((((i64)1) << UNK_BITS) - 1)

/* the tangent of one instruction, after its value (W holds the values, T the tangents) */
static void tangent_op(const Prog *P, const i64 *row, const double *W, double *T, i64 M, double *tmp, double *tmp2) {
    i64 op = row[0], o = row[1], a = row[2], b = row[3], k = row[4], unk = row[5];
    i64 S = P->S, MS = M * S, n = P->n;
    const double *p = P->p;
    /* unk: bit 0 operand a carries a tangent, bit 1 operand b; above (UNK_SHIFT, when n <= UNK_BITS) the
     * unknowns each one's tangent depends on: a tangent known to be zero is neither computed nor read */
    int ta0 = (unk & 1) != 0, tb0 = (unk & 2) != 0;
    i64 ma = (unk >> 2) & UNK_MASK, mb = (unk >> UNK_SHIFT) & UNK_MASK, all = (unk >> 2) == 0;
    const double *Wo = W + o * MS, *Wa = W + a * MS, *Wb = W + b * MS;
    for (i64 d = 0; d < n; d++) {
        int ta = all ? ta0 : (int)((ma >> d) & 1), tb = all ? tb0 : (int)((mb >> d) & 1);
        if (!ta && !tb) continue;
        double *To = T + (o * n + d) * MS;
        const double *Ta = T + (a * n + d) * MS, *Tb = T + (b * n + d) * MS;
        switch (op) {
        case INPUT:
            s_fill(To, 0.0, MS);
            if (a == d)
                for (i64 i = 0; i < S; i++) To[i] = 1.0;
            break;
        case ADD:
        case SUB: {
            double sgn = op == ADD ? 1.0 : -1.0;
            if (ta && tb)
                for (i64 i = 0; i < MS; i++) To[i] = Ta[i] + sgn * Tb[i];
            else if (ta)
                s_copy(To, Ta, MS);
            else
                for (i64 i = 0; i < MS; i++) To[i] = sgn * Tb[i];
            break;
        }
        case MUL:
            if (ta && tb)
                s_mul2(Ta, Wb, Wa, Tb, To, M, S);
            else if (ta)
                s_mul(Ta, Wb, To, M, S);
            else
                s_mul(Wa, Tb, To, M, S);
            break;
        case DIV:
            /* (da - q db) / b */
            if (tb) {
                s_mul(Wo, Tb, tmp, M, S);
                if (ta)
                    for (i64 i = 0; i < MS; i++) tmp2[i] = Ta[i] - tmp[i];
                else
                    for (i64 i = 0; i < MS; i++) tmp2[i] = -tmp[i];
            } else
                s_copy(tmp2, Ta, MS);
            s_div(tmp2, Wb, To, M, S);
            break;
        case NEG:
        case RSUBC:
            for (i64 i = 0; i < MS; i++) To[i] = -Ta[i];
            break;
        case ADDC:
        case COPY:
            s_copy(To, Ta, MS);
            break;
        case MULC:
            for (i64 i = 0; i < MS; i++) To[i] = Ta[i] * p[k];
            break;
        case DIVC:
            for (i64 i = 0; i < MS; i++) To[i] = Ta[i] / p[k];
            break;
        case RDIVC:
            /* c = p / a: dc = -c da / a */
            s_mul(Wo, Ta, tmp, M, S);
            s_div(tmp, Wa, To, M, S);
            for (i64 i = 0; i < MS; i++) To[i] = -To[i];
            break;
        case SQRT:
            s_div(Ta, Wo, To, M, S);
            for (i64 i = 0; i < MS; i++) To[i] = 0.5 * To[i];
            break;
        case EXP:
            s_mul(Wo, Ta, To, M, S);
            break;
        case LOG:
            s_div(Ta, Wa, To, M, S);
            break;
        case SINCOS:
        case SINHCOSH: {
            double *Tb2 = T + (b * n + d) * MS;
            s_mul(Wb, Ta, To, M, S);  /* d sin = cos du */
            s_mul(Wo, Ta, Tb2, M, S); /* d cos = -sin du, d cosh = sinh du */
            if (op == SINCOS)
                for (i64 i = 0; i < MS; i++) Tb2[i] = -Tb2[i];
            break;
        }
        case POW:
            s_mul(Wo, Ta, tmp, M, S);
            s_div(tmp, Wa, To, M, S);
            for (i64 i = 0; i < MS; i++) To[i] = p[k] * To[i];
            break;
        case ARCTAN:
            s_mul(Wa, Wa, tmp, M, S);
            for (i64 i = 0; i < S; i++) tmp[i] += 1.0;
            s_div(Ta, tmp, To, M, S);
            break;
        case TAN:
            s_mul(Wo, Wo, tmp, M, S);
            for (i64 i = 0; i < S; i++) tmp[i] += 1.0;
            s_mul(tmp, Ta, To, M, S);
            break;
        case AXPY:
            if (ta && tb)
                for (i64 i = 0; i < MS; i++) To[i] = Ta[i] + p[k] * Tb[i];
            else if (ta)
                s_copy(To, Ta, MS);
            else
                for (i64 i = 0; i < MS; i++) To[i] = p[k] * Tb[i];
            break;
        case DERIV:
            s_deriv(Ta, To, M, S);
            break;
        case ATAN2: {
            /* d arctan2(y, x) = (x dy - y dx) / (x^2 + y^2); y = a, x = b */
            double *den = tmp2;
            s_mul(Wb, Wb, den, M, S);
            s_mul_add(Wa, Wa, den, M, S);
            if (ta && tb) {
                s_mul(Wb, Ta, tmp, M, S);
                s_mul(Wa, Tb, To, M, S);
                for (i64 i = 0; i < MS; i++) tmp[i] -= To[i];
            } else if (ta)
                s_mul(Wb, Ta, tmp, M, S);
            else {
                s_mul(Wa, Tb, tmp, M, S);
                for (i64 i = 0; i < MS; i++) tmp[i] = -tmp[i];
            }
            s_div(tmp, den, To, M, S);
            break;
        }
        }
    }
}

/* residual series res (neq, M, S); with jac != NULL also the Jacobian series (neq, n, M, S).
 * work: (nreg + 8) M S doubles, plus nreg n M S with a Jacobian. */
static void run(const Prog *P, const double *x, i64 Mx, i64 M, double *res, double *jac, double *work) {
    i64 S = P->S, MS = M * S, n = P->n;
    double *W = work, *scratch = W + P->nreg * MS, *tmp = scratch + 6 * MS, *tmp2 = tmp + MS;
    double *T = tmp2 + MS;
    for (i64 i = 0; i < P->ninstr; i++) {
        const i64 *row = P->code + 6 * i;
        value_op(P, row, W, x, Mx, M, scratch);
        if (jac != NULL && row[5] != 0) tangent_op(P, row, W, T, M, tmp, tmp2);
    }
    for (i64 j = 0; j < P->neq; j++) {
        s_copy(res + j * MS, W + P->outs[j] * MS, MS);
        if (jac != NULL) {
            i64 u = P->outs_unk[j], mask = (u >> 2) & UNK_MASK;
            for (i64 d = 0; d < n; d++) {
                double *dst = jac + (j * n + d) * MS;
                if (u != 0 && ((u >> 2) == 0 || ((mask >> d) & 1)))
                    s_copy(dst, T + (P->outs[j] * n + d) * MS, MS);
                else
                    s_fill(dst, 0.0, MS);
            }
        }
    }
}

static i64 work_size(const Prog *P, i64 M, int tangent) {
    i64 MS = M * P->S;
    return (P->nreg + 8) * MS + (tangent ? P->nreg * P->n * MS : 0);
}

#define PROG_ARGS                                                                                              \
    const i64 *code, i64 ninstr, const double *p, const double *data, i64 Md, i64 nreg, const i64 *outs,      \
        const i64 *outs_unk, i64 neq, i64 n, i64 S
#define PROG_INIT {code, ninstr, p, data, Md, nreg, outs, outs_unk, neq, n, S}

/* The residual series (neq, M, S) of a program at the unknowns x (n, Mx, S), data (D, Md, S). */
int gf_evaluate(PROG_ARGS, const double *x, i64 Mx, i64 M, double *res) {
    Prog P = PROG_INIT;
    double *work = malloc((size_t)work_size(&P, M, 0) * sizeof(double));
    if (work == NULL) return -1;
    run(&P, x, Mx, M, res, NULL, work);
    free(work);
    return 0;
}

/* The residual series and the Jacobian series (neq, n, M, S). */
int gf_evaluate_tangent(PROG_ARGS, const double *x, i64 Mx, i64 M, double *res, double *jac) {
    Prog P = PROG_INIT;
    double *work = malloc((size_t)work_size(&P, M, 1) * sizeof(double));
    if (work == NULL) return -1;
    run(&P, x, Mx, M, res, jac, work);
    free(work);
    return 0;
}

/* ------------------------------------------------------------------ linear series systems */

/* inverse of the n x n matrices J0 (S of them: J[(a * n + b) * M * S + i], coefficient 0) into inv (n, n, S):
 * inv[(r * n + c) * S + i], Gauss-Jordan with partial pivoting; 2 when a pivot is exactly zero
 * (numpy.linalg.inv raises there) */
static int invert_constant(const double *J, i64 n, i64 M, i64 S, double *inv, double *aug) {
    i64 MS = M * S;
    for (i64 i = 0; i < S; i++) {
        for (i64 r = 0; r < n; r++)
            for (i64 c = 0; c < n; c++) {
                aug[r * 2 * n + c] = J[(r * n + c) * MS + i];
                aug[r * 2 * n + n + c] = r == c ? 1.0 : 0.0;
            }
        for (i64 c = 0; c < n; c++) {
            i64 piv = c;
            double best = fabs(aug[c * 2 * n + c]);
            for (i64 r = c + 1; r < n; r++)
                if (fabs(aug[r * 2 * n + c]) > best) {
                    best = fabs(aug[r * 2 * n + c]);
                    piv = r;
                }
            if (!(best > 0.0)) return 2;
            if (piv != c)
                for (i64 q = 0; q < 2 * n; q++) {
                    double t = aug[c * 2 * n + q];
                    aug[c * 2 * n + q] = aug[piv * 2 * n + q];
                    aug[piv * 2 * n + q] = t;
                }
            double d = aug[c * 2 * n + c];
            for (i64 q = 0; q < 2 * n; q++) aug[c * 2 * n + q] /= d;
            for (i64 r = 0; r < n; r++) {
                if (r == c) continue;
                double f = aug[r * 2 * n + c];
                if (f != 0.0)
                    for (i64 q = 0; q < 2 * n; q++) aug[r * 2 * n + q] -= f * aug[c * 2 * n + q];
            }
        }
        for (i64 r = 0; r < n; r++)
            for (i64 c = 0; c < n; c++) inv[(r * n + c) * S + i] = aug[r * 2 * n + n + c];
    }
    return 0;
}

/* series_solve's coefficient m at the BLOCK nodes from node i (r: the right-hand sides, n S) */
HOT static inline void solve_block(const double *J, const double *inv, const double *G, double *D, i64 n, i64 M,
                                   i64 S, double *r, i64 m, i64 i) {
    i64 MS = M * S;
    for (i64 a = 0; a < n; a++) {
        double acc[BLOCK];
        const double *g = G + a * MS + m * S + i;
        for (int q = 0; q < BLOCK; q++) acc[q] = g[q];
        for (i64 l = 1; l <= m; l++)
            for (i64 b = 0; b < n; b++) {
                const double *Jab = J + (a * n + b) * MS + l * S + i, *Db = D + b * MS + (m - l) * S + i;
                for (int q = 0; q < BLOCK; q++) acc[q] -= Jab[q] * Db[q];
            }
        for (int q = 0; q < BLOCK; q++) r[a * S + i + q] = acc[q];
    }
    for (i64 a = 0; a < n; a++) {
        double acc[BLOCK] = {0.0};
        for (i64 b = 0; b < n; b++) {
            const double *ib = inv + (a * n + b) * S + i, *rb = r + b * S + i;
            for (int q = 0; q < BLOCK; q++) acc[q] += ib[q] * rb[q];
        }
        for (int q = 0; q < BLOCK; q++) D[a * MS + m * S + i + q] = acc[q];
    }
}

/* D = J^-1 G order by order: D_m = J0^-1 (G_m - sum_{l=1..m} J_l D_{m-l}); J (n, n, M, S), G, D (n, M, S),
 * inv (n, n, S); r: n S doubles.  Each node's sums in the order of a node-by-node loop (l, then b,
 * ascending), by blocks of nodes in registers as the products (the last block overlapping when D is apart
 * from J and G). */
HOT static void series_solve(const double *J, const double *inv, const double *G, double *D, i64 n, i64 M, i64 S,
                             double *r) {
    i64 MS = M * S;
    int overlap = S > BLOCK && disjoint(D, G, n * MS) && !(J < D + n * MS && D < J + n * n * MS);
    for (i64 m = 0; m < M; m++) {
        i64 i0 = 0;
        for (; i0 + BLOCK <= S; i0 += BLOCK) solve_block(J, inv, G, D, n, M, S, r, m, i0);
        if (i0 < S && overlap) {
            solve_block(J, inv, G, D, n, M, S, r, m, S - BLOCK);
            continue;
        }
        if (i0 == S) continue;
        for (i64 a = 0; a < n; a++) {
            double *ra = r + a * S;
            const double *g = G + a * MS + m * S;
            for (i64 i = i0; i < S; i++) ra[i] = g[i];
            for (i64 l = 1; l <= m; l++)
                for (i64 b = 0; b < n; b++) {
                    const double *Jab = J + (a * n + b) * MS + l * S, *Db = D + b * MS + (m - l) * S;
                    for (i64 i = i0; i < S; i++) ra[i] -= Jab[i] * Db[i];
                }
        }
        for (i64 a = 0; a < n; a++) {
            double *Da = D + a * MS + m * S;
            for (i64 i = i0; i < S; i++) Da[i] = 0.0;
            for (i64 b = 0; b < n; b++) {
                const double *ib = inv + (a * n + b) * S, *rb = r + b * S;
                for (i64 i = i0; i < S; i++) Da[i] += ib[i] * rb[i];
            }
        }
    }
}

/* The series solve with the inverse of the constant term computed here: 2 at an exactly singular node. */
int gf_series_solve(const double *J, const double *G, double *D, i64 n, i64 M, i64 S) {
    double *inv = malloc((size_t)(S * n * n + 2 * n * n + n * S) * sizeof(double));
    if (inv == NULL) return -1;
    int st = invert_constant(J, n, M, S, inv, inv + S * n * n);
    if (st == 0) series_solve(J, inv, G, D, n, M, S, inv + S * n * n + 2 * n * n);
    free(inv);
    return st;
}

static int all_finite(const double *v, i64 len) {
    for (i64 i = 0; i < len; i++)
        if (!isfinite(v[i])) return 0;
    return 1;
}

/* ------------------------------------------------------------------ Newton's method on series */

/* planners.newton._warm_newton: Newton and chord steps at the full working order M - 1 from x (n, M, S).
 * Jc (n, n, M, S): in, the carried Jacobian series when has_carried (its constant term is replaced by the
 * Jacobian at the start); out, the Jacobian of the last step.  weights (M): step^m.  Out: x the solution,
 * cres (S) its constant-term residual bound, *nsteps the evaluations made.
 * Returns 0 (solved), 1 (not solved: the caller runs the full scheme), 2 (singular: the numpy path). */
int gf_warm_newton(PROG_ARGS, double *x, double *Jc, i64 M, i64 has_carried, double tol, const double *weights,
                   i64 maxsteps, i64 chord_steps, double chord_proof, double *cres, i64 *nsteps) {
    Prog P = PROG_INIT;
    i64 MS = M * S, nMS = n * MS;
    i64 wsz = work_size(&P, M, 1);
    i64 total = wsz + 3 * nMS /* G, before, D */ + S * n * n + 2 * n * n + n * S /* inverse */ + n * n * S /* J0 */
                + n * S /* x0 */;
    double *buf = malloc((size_t)total * sizeof(double));
    if (buf == NULL) return -1;
    double *work = buf, *G = work + wsz, *before = G + nMS, *D = before + nMS, *inv = D + nMS;
    double *aug = inv + S * n * n, *r = aug + 2 * n * n, *J0 = r + n * S, *x0 = J0 + n * n * S;
    int status = 1, have_inv = 0;
    int has_J = 0, proof = has_carried != 0;
    double bound = 1.0;
    *nsteps = 0;
    if (has_carried) {
        /* the constant term of the carried Jacobian at this start: a tangent evaluation at order 0 */
        for (i64 j = 0; j < n; j++) memcpy(x0 + j * S, x + j * MS, (size_t)S * sizeof(double));
        run(&P, x0, 1, 1, D, J0, work);
        if (all_finite(J0, n * n * S)) {
            for (i64 q = 0; q < n * n; q++) memcpy(Jc + q * MS, J0 + q * S, (size_t)S * sizeof(double));
            has_J = 1;
        }
    }
    int have_last = 0, newton_step = 0;
    double last = 0.0, theta = 0.0;
    i64 step;
    for (step = 0; step < maxsteps; step++) {
        int fresh = !has_J;
        if (fresh) {
            run(&P, x, M, M, G, Jc, work);
            have_inv = 0;
            has_J = 1;
            if (!all_finite(Jc, n * nMS)) goto done;
        } else
            run(&P, x, M, M, G, NULL, work);
        (*nsteps)++;
        if (!all_finite(G, nMS)) goto done;
        double size = 0.0;
        for (i64 a = 0; a < n; a++)
            for (i64 m = 0; m < M; m++)
                for (i64 i = 0; i < S; i++) {
                    double v = fabs(G[a * MS + m * S + i]) * weights[m];
                    if (v > size) size = v;
                }
        if (have_last && !(size < last)) {
            if (newton_step) goto done; /* a Newton step that does not decrease the residual */
            /* a chord step that made it worse: back to where the residual was smaller, a Newton step there */
            memcpy(x, before, (size_t)nMS * sizeof(double));
            has_J = 0;
            have_last = 0;
            theta = 0.0;
            continue;
        }
        if (fresh) {
            have_last = 0;
            theta = 0.0;
        }
        if (have_last) theta = fmax(theta, size / last);
        memcpy(before, x, (size_t)nMS * sizeof(double));
        newton_step = fresh;
        if (!have_inv) {
            int st = invert_constant(Jc, n, M, S, inv, aug);
            if (st) {
                status = st;
                goto done;
            }
            have_inv = 1;
        }
        series_solve(Jc, inv, G, D, n, M, S, r);
        for (i64 q = 0; q < nMS; q++) x[q] -= D[q];
        if (size <= tol) {
            bound = 1.0;
            break;
        }
        if (proof && have_last && theta * size <= chord_proof * tol) {
            bound = theta; /* the contraction bounds the residual of the new point */
            break;
        }
        if (have_last && log(tol / size) / log(theta) > (double)chord_steps) {
            has_J = 0; /* the chord contracts too slowly: a Newton step next */
            last = size;
            have_last = 1;
        } else {
            last = size;
            have_last = 1;
        }
    }
    if (step == maxsteps) goto done; /* still above the tolerance after maxsteps evaluations */
    if (!all_finite(x, nMS)) goto done;
    for (i64 i = 0; i < S; i++) {
        double c = 0.0;
        for (i64 a = 0; a < n; a++) {
            double v = fabs(G[a * MS + i]);
            if (v > c || isnan(v)) c = v;
        }
        cres[i] = bound * c;
    }
    status = 0;
done:
    free(buf);
    return status;
}

/* The precision-doubling steps of planners.newton.newton_series: x (n, Mx, S) holds the pointwise solution
 * in its constant terms and the starting guess above; for each working order k of orders (increasing), one
 * Newton step on the coefficients 0..k (a fresh Jacobian series, the linear series system).  Jc (n, n, Mx, S):
 * the Jacobian of the last step (working order orders[norders - 1] = Mx - 1).
 * Returns 0, or 2 at an exactly singular node (the numpy path then takes a least-squares step). */
int gf_doubling(PROG_ARGS, double *x, i64 Mx, const i64 *orders, i64 norders, double *Jc) {
    Prog P = PROG_INIT;
    i64 wsz = work_size(&P, Mx, 1), nMS = n * Mx * S;
    i64 total = wsz + 2 * nMS + S * n * n + 2 * n * n + n * S;
    double *buf = malloc((size_t)total * sizeof(double));
    if (buf == NULL) return -1;
    double *work = buf, *G = work + wsz, *D = G + nMS, *inv = D + nMS, *aug = inv + S * n * n, *r = aug + 2 * n * n;
    int status = 0;
    for (i64 s = 0; s < norders; s++) {
        i64 M = orders[s] + 1, MS = M * S;
        run(&P, x, Mx, M, G, Jc, work);
        status = invert_constant(Jc, n, M, S, inv, aug);
        if (status) break;
        series_solve(Jc, inv, G, D, n, M, S, r);
        for (i64 j = 0; j < n; j++)
            for (i64 q = 0; q < MS; q++) x[j * Mx * S + q] -= D[j * MS + q];
    }
    free(buf);
    return status;
}

/* ------------------------------------------------------------------ piecewise polynomials on many times */

/* out (v, N): the polynomials c (intervals, v, d1) of interval idx[t] at offsets s[t], by Horner's rule:
 * o = c_(d1-1); o = o * s + c_p for p = d1 - 2 .. 0 (the operations of planners.plan._horner, without
 * contraction into fused multiply-adds: the same values). */
int gf_horner(const double *c, i64 v, i64 d1, const i64 *idx, const double *s, i64 N, double *out) {
    /* by runs of times in one interval (the usual sorted grid): the run's coefficients are scalars, the
     * times a vector; each value's operations are those of one time at a time */
    i64 t0 = 0;
    while (t0 < N) {
        i64 t1 = t0 + 1;
        while (t1 < N && idx[t1] == idx[t0]) t1++;
        for (i64 q = 0; q < v; q++) {
            const double *cp = c + (idx[t0] * v + q) * d1;
            double *o = out + q * N;
            for (i64 t = t0; t < t1; t++) o[t] = cp[d1 - 1];
            for (i64 p = d1 - 2; p >= 0; p--) {
                double cq = cp[p];
                for (i64 t = t0; t < t1; t++) o[t] = o[t] * s[t] + cq;
            }
        }
        t0 = t1;
    }
    return 0;
}

/* ------------------------------------------------------------------ the pointwise Newton (constant terms) */

static double node_norm(const double *f, i64 n, i64 S, i64 i) {
    /* max_a |f_a| at node i, NaN when one is NaN (numpy.max) */
    double r = fabs(f[i]);
    for (i64 a = 1; a < n; a++) {
        double v = fabs(f[a * S + i]);
        if (isnan(v) || isnan(r))
            r = NAN;
        else if (v > r)
            r = v;
    }
    return r;
}

/* gna.solve.newton on the constant terms of a program (scale ones, damped, the Jacobian by the tangent):
 * x (n, S) in/out, res (S) out, *iterations out.  Returns 0, or 2 when a node's Jacobian is exactly singular
 * (numpy then takes least squares: the caller reruns gna.solve.newton). */
int gf_pointwise_newton(PROG_ARGS, double *x, double tol, i64 maxiter, double *res, i64 *iterations) {
    Prog P = PROG_INIT;
    i64 nS = n * S;
    i64 wsz = work_size(&P, 1, 1);
    double *buf = malloc((size_t)(wsz + 6 * nS + n * nS + 2 * S + n * (n + 1)) * sizeof(double));
    if (buf == NULL) return -1;
    double *work = buf, *f = work + wsz, *fn = f + nS, *xn = fn + nS, *dx = xn + nS, *tmp = dx + nS;
    double *J = tmp + nS, *rn = J + n * nS, *step = rn + S, *aug = step + S;
    int status = 0;
    run(&P, x, 1, 1, f, NULL, work);
    for (i64 i = 0; i < S; i++) res[i] = node_norm(f, n, S, i);
    i64 it = 0;
    for (;;) {
        int all_done = 1;
        for (i64 i = 0; i < S; i++)
            if (!(res[i] <= tol)) all_done = 0;
        if (it >= maxiter || all_done) break;
        it++;
        if (!all_finite(f, nS)) break;
        run(&P, x, 1, 1, tmp, J, work); /* J (n, n, 1, S) */
        for (i64 i = 0; i < S; i++) {
            /* J dx = -f at node i: Gaussian elimination with partial pivoting */
            for (i64 r = 0; r < n; r++) {
                for (i64 c = 0; c < n; c++) aug[r * (n + 1) + c] = J[(r * n + c) * S + i];
                aug[r * (n + 1) + n] = -f[r * S + i];
            }
            for (i64 c = 0; c < n; c++) {
                i64 piv = c;
                double best = fabs(aug[c * (n + 1) + c]);
                for (i64 r = c + 1; r < n; r++)
                    if (fabs(aug[r * (n + 1) + c]) > best) {
                        best = fabs(aug[r * (n + 1) + c]);
                        piv = r;
                    }
                if (!(best > 0.0)) {
                    status = 2;
                    goto done;
                }
                if (piv != c)
                    for (i64 q = 0; q <= n; q++) {
                        double t = aug[c * (n + 1) + q];
                        aug[c * (n + 1) + q] = aug[piv * (n + 1) + q];
                        aug[piv * (n + 1) + q] = t;
                    }
                for (i64 r = c + 1; r < n; r++) {
                    double m = aug[r * (n + 1) + c] / aug[c * (n + 1) + c];
                    for (i64 q = c; q <= n; q++) aug[r * (n + 1) + q] -= m * aug[c * (n + 1) + q];
                }
            }
            for (i64 r = n - 1; r >= 0; r--) {
                double acc = aug[r * (n + 1) + n];
                for (i64 q = r + 1; q < n; q++) acc -= aug[r * (n + 1) + q] * dx[q * S + i];
                dx[r * S + i] = acc / aug[r * (n + 1) + r];
            }
            if (!(res[i] > tol))
                for (i64 r = 0; r < n; r++) dx[r * S + i] = 0.0; /* inactive */
            step[i] = 1.0;
        }
        for (i64 q = 0; q < nS; q++) xn[q] = x[q] + dx[q];
        run(&P, xn, 1, 1, fn, NULL, work);
        for (i64 i = 0; i < S; i++) rn[i] = node_norm(fn, n, S, i);
        for (int h = 0; h < 10; h++) {
            int any = 0;
            for (i64 i = 0; i < S; i++) {
                int active = res[i] > tol;
                int bad = !(rn[i] < res[i]) && active && !(rn[i] <= tol);
                bad = bad && (!isfinite(rn[i]) || rn[i] >= res[i]);
                if (bad) {
                    any = 1;
                    step[i] *= 0.5;
                }
            }
            if (!any) break;
            for (i64 a = 0; a < n; a++)
                for (i64 i = 0; i < S; i++) xn[a * S + i] = x[a * S + i] + dx[a * S + i] * step[i];
            run(&P, xn, 1, 1, fn, NULL, work);
            for (i64 i = 0; i < S; i++) rn[i] = node_norm(fn, n, S, i);
        }
        memcpy(x, xn, (size_t)nS * sizeof(double));
        memcpy(f, fn, (size_t)nS * sizeof(double));
        for (i64 i = 0; i < S; i++) res[i] = isfinite(rn[i]) ? rn[i] : INFINITY;
    }
done:
    *iterations = it;
    free(buf);
    return status;
}

/* ------------------------------------------------------------------ generalized-flatness iterates, whole */

#include <time.h>
static double now_s(void) { /* wall time [s] (processor time without a monotonic clock) */
#ifdef CLOCK_MONOTONIC
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
#else
    return (double)clock() / CLOCKS_PER_SEC;
#endif
}

#define META 10  /* per stage: kind (0 Newton, 1 closed form), n, neq, ninstr, nreg, D, Mtop, nvar, nstatic, h */
#define PTRS 5   /* per stage: code, params, outs, outs_unk, B */

/* row (M, S) of B := coefficients 0..K-1 of the series src (K, S) (or of its derivative), zero-padded */
static void fill_row(double *row, i64 M, i64 S, const double *src, i64 K, int deriv) {
    i64 avail = deriv ? K - 1 : K;
    i64 m = avail < M ? avail : M;
    if (m < 0) m = 0;
    for (i64 c = 0; c < m; c++)
        for (i64 i = 0; i < S; i++) row[c * S + i] = deriv ? (c + 1) * src[(c + 1) * S + i] : src[c * S + i];
    for (i64 c = m; c < M; c++)
        for (i64 i = 0; i < S; i++) row[c * S + i] = 0.0;
}

/* Iterates j0 .. j1 - 1 of the generalized flat parametrization on the native evaluator, each from the one
 * before (the stages of planners.chained._native_iterate: the warm Newton with the carried Jacobian, the closed
 * forms), without returning to Python between them.
 *
 * Slots are the stages' unknowns; slot_ptrs[j * nslots + s] is the coefficient array (order_j - slot_h[s] + 1,
 * S) of slot s at iterate j (iterate j0 - 1 given).  Each stage's data rows are its buffer B's: var rows
 * (row, slot, derivative, previous iterate) written here, static rows (row, top order) truncated by the
 * iterate's loss.  jac_ptrs[j * nst + st] and cres_ptrs: the Newton stages' Jacobian (n, n, M_j, S) and
 * constant-term residual (S) at iterate j (iterate j0 - 1's Jacobian given); steps[j * nst + st] their
 * evaluations; seconds[j] each iterate's wall time.  Returns the first iterate not completed (j1 when all
 * were): a Newton stage that needs the full scheme or the numpy steps stops here, and the caller goes on. */
i64 gf_iterates(i64 nst, const i64 *meta, const i64 *ptrs, const i64 *var_rows, const i64 *static_rows,
                i64 nslots, const i64 *slot_h, const i64 *unk_slots, i64 S, i64 j0, i64 j1, const i64 *orders,
                i64 order_top, const i64 *slot_ptrs, const i64 *jac_ptrs, const i64 *cres_ptrs, i64 *steps,
                double *seconds, double tol, const double *weights, i64 maxsteps, i64 chord_steps,
                double chord_proof) {
    for (i64 j = j0; j < j1; j++) {
        double t0 = now_s();
        i64 order = orders[j], loss = order_top - order;
        const i64 *vr = var_rows, *sr = static_rows, *us = unk_slots;
        for (i64 st = 0; st < nst; st++) {
            const i64 *m = meta + META * st;
            i64 kind = m[0], n = m[1], neq = m[2], Mtop = m[6], nvar = m[7], nstatic = m[8], h = m[9];
            const i64 *pp = ptrs + PTRS * st;
            double *B = (double *)(intptr_t)pp[4];
            i64 k = order - h, M = k + (kind ? 2 : 1);
            if (M > Mtop) return j;
            for (i64 q = 0; q < nvar; q++) {
                i64 row = vr[4 * q], slot = vr[4 * q + 1], deriv = vr[4 * q + 2], prev = vr[4 * q + 3];
                i64 jj = prev ? j - 1 : j;
                const double *src = (const double *)(intptr_t)slot_ptrs[jj * nslots + slot];
                i64 K = orders[jj] - slot_h[slot] + 1;
                fill_row(B + row * Mtop * S, M, S, src, K, (int)deriv);
            }
            for (i64 q = 0; q < nstatic; q++) {
                i64 row = sr[2 * q], o = sr[2 * q + 1];
                i64 from = o - loss + 1;
                if (from < 0) from = 0;
                for (i64 c = from; c < M; c++)
                    for (i64 i = 0; i < S; i++) B[(row * Mtop + c) * S + i] = 0.0;
            }
            Prog P = {(const i64 *)(intptr_t)pp[0], m[3], (const double *)(intptr_t)pp[1], B, Mtop, m[4],
                      (const i64 *)(intptr_t)pp[2], (const i64 *)(intptr_t)pp[3], neq, n, S};
            if (kind == 1) {
                double *res = malloc((size_t)(neq * M * S + work_size(&P, M, 0)) * sizeof(double));
                if (res == NULL) return j;
                run(&P, NULL, M, M, res, NULL, res + neq * M * S);
                for (i64 a = 0; a < neq; a++) {
                    double *dst = (double *)(intptr_t)slot_ptrs[j * nslots + us[a]];
                    memcpy(dst, res + a * M * S, (size_t)((k + 1) * S) * sizeof(double));
                }
                free(res);
            } else {
                double *x = malloc((size_t)(n * M * S) * sizeof(double));
                if (x == NULL) return j;
                for (i64 a = 0; a < n; a++) {
                    const double *src = (const double *)(intptr_t)slot_ptrs[(j - 1) * nslots + us[a]];
                    i64 K = orders[j - 1] - slot_h[us[a]] + 1;
                    fill_row(x + a * M * S, M, S, src, K, 0);
                }
                const double *Jp = (const double *)(intptr_t)jac_ptrs[(j - 1) * nst + st];
                i64 Mp = orders[j - 1] - h + 1;
                double *Jc = (double *)(intptr_t)jac_ptrs[j * nst + st];
                if (Mp < M) {
                    free(x);
                    return j;
                }
                for (i64 q = 0; q < n * n; q++) memcpy(Jc + q * M * S, Jp + q * Mp * S, (size_t)(M * S) * sizeof(double));
                if (!all_finite(Jc, n * n * M * S)) {
                    free(x);
                    return j;
                }
                i64 ns = 0;
                int status = gf_warm_newton(P.code, P.ninstr, P.p, B, Mtop, P.nreg, P.outs, P.outs_unk, neq, n, S, x,
                                            Jc, M, 1, tol, weights, maxsteps, chord_steps, chord_proof,
                                            (double *)(intptr_t)cres_ptrs[j * nst + st], &ns);
                steps[j * nst + st] = ns;
                if (status != 0) {
                    free(x);
                    return j;
                }
                for (i64 a = 0; a < n; a++) {
                    double *dst = (double *)(intptr_t)slot_ptrs[j * nslots + us[a]];
                    memcpy(dst, x + a * M * S, (size_t)(M * S) * sizeof(double));
                }
                free(x);
            }
            vr += 4 * nvar;
            sr += 2 * nstatic;
            us += (kind ? neq : n);
        }
        seconds[j] = now_s() - t0;
    }
    return j1;
}

/* ------------------------------------------------------------------ a plan's limits on its fine grid */

/* The interval of time x among the nodes tn (nn >= 2): numpy's clip(searchsorted(tn, x, "right") - 1, 0, nn - 2)
 * (a NaN sorts after every node). */
static i64 grid_interval(const double *tn, i64 nn, double x) {
    if (isnan(x)) return nn - 2;
    i64 lo = 0, hi = nn; /* the count of nodes <= x, by bisection */
    while (lo < hi) {
        i64 mid = lo + (hi - lo) / 2;
        if (tn[mid] <= x)
            lo = mid + 1;
        else
            hi = mid;
    }
    i64 i = lo - 1;
    return i < 0 ? 0 : (i > nn - 2 ? nn - 2 : i);
}

/* Whether grid_interval(tn, nn, x) is i, in two comparisons (tn increasing). */
static int in_interval(const double *tn, i64 nn, double x, i64 i) {
    if (isnan(x)) return i == nn - 2;
    return (i == 0 || tn[i] <= x) && (i == nn - 2 || x < tn[i + 1]);
}

/* out (v rows of stride N): the interval polynomials c (nn - 1, v, d1) at the times t (N), each time in its interval
 * (grid_interval) at the offset t - tn[i], by Horner's rule as gf_horner (the same operations, so the same values).
 * pad: the caller's reference zero-pads these polynomials to a higher degree; its Horner steps on the padded zeros
 * leave +0 (for finite offsets), so the evaluation starts from o = +0 and takes one step more: the padded values
 * bit for bit, without their steps. */
int gf_grid_horner(const double *c, i64 v, i64 d1, i64 pad, const double *tn, i64 nn, const double *t, i64 N,
                   double *out) {
    double *s = (double *)malloc((size_t)(N > 0 ? N : 1) * sizeof(double));
    if (!s) return 1;
    i64 t0 = 0;
    while (t0 < N) { /* by runs of times in one interval: the coefficients scalars, the times a vector */
        i64 i = grid_interval(tn, nn, t[t0]);
        i64 t1 = t0 + 1;
        while (t1 < N && in_interval(tn, nn, t[t1], i)) t1++;
        double ti = tn[i];
        for (i64 q = t0; q < t1; q++) s[q] = t[q] - ti;
        for (i64 r = 0; r < v; r++) {
            const double *cp = c + (i * v + r) * d1;
            double *o = out + r * N;
            double top = pad ? 0.0 : cp[d1 - 1];
            i64 p0 = pad ? d1 - 1 : d1 - 2;
            i64 q = t0;
            for (; q + BLOCK <= t1; q += BLOCK) { /* a block of times in registers through all the steps */
                double acc[BLOCK], sb[BLOCK];
                for (int b = 0; b < BLOCK; b++) {
                    acc[b] = top;
                    sb[b] = s[q + b];
                }
                for (i64 p = p0; p >= 0; p--) {
                    double cq = cp[p];
                    for (int b = 0; b < BLOCK; b++) acc[b] = acc[b] * sb[b] + cq;
                }
                for (int b = 0; b < BLOCK; b++) o[q + b] = acc[b];
            }
            for (; q < t1; q++) {
                double a = top;
                for (i64 p = p0; p >= 0; p--) a = a * s[q] + cp[p];
                o[q] = a;
            }
        }
        t0 = t1;
    }
    free(s);
    return 0;
}

/* The count of rows whose excess (lower: b - v, upper: v - b; b the constant bq, or the array bnd) is > 0: a
 * comparison and an integer sum per row (vectorized). */
static i64 count_over(const double *v, const double *bnd, double bq, i64 N, int lower) {
    i64 c = 0;
    if (bnd && lower)
        for (i64 k = 0; k < N; k++) c += (bnd[k] - v[k]) > 0.0;
    else if (bnd)
        for (i64 k = 0; k < N; k++) c += (v[k] - bnd[k]) > 0.0;
    else if (lower)
        for (i64 k = 0; k < N; k++) c += (bq - v[k]) > 0.0;
    else
        for (i64 k = 0; k < N; k++) c += (v[k] - bq) > 0.0;
    return c;
}

/* The sides of a plan's limits on its grid (gna.limits.scan_sides, the test of gna.limits.limit_violations):
 * side q of nsides reads the quantity at pointer vp[q] (N values) and its bound: kind[q] 0 none (skipped),
 * 1 the constant bc[q], 2 the array at pointer bp[q] (N values); lower[q] says the side.  excess = bound - v on
 * a lower side, v - bound on an upper one; a row is over when its excess is > 0 (never a NaN).  First the count of
 * rows over (vectorized), then, only where there are some, the rows: res[4 q ..] the count, the row of the largest
 * excess (the first of equal ones, numpy.argmax), the first and the last row over (-1 without one). */
int gf_limit_scan(i64 N, i64 nsides, const i64 *vp, const i64 *kind, const i64 *lower, const double *bc,
                  const i64 *bp, i64 *res) {
    for (i64 q = 0; q < nsides; q++) {
        i64 count = 0, worst = -1, first = -1, last = -1;
        const double *v = (const double *)(intptr_t)vp[q];
        int lo = lower[q] != 0;
        const double *b = kind[q] == 2 ? (const double *)(intptr_t)bp[q] : NULL;
        double bq = bc[q], best = 0.0;
        if (kind[q] != 0) count = count_over(v, b, bq, N, lo);
        if (count > 0)
            for (i64 k = 0; k < N; k++) {
                double bk = b ? b[k] : bq;
                double e = lo ? bk - v[k] : v[k] - bk;
                if (e > 0.0) {
                    if (first < 0 || e > best) {
                        best = e;
                        worst = k;
                    }
                    if (first < 0) first = k;
                    last = k;
                }
            }
        res[4 * q] = count;
        res[4 * q + 1] = worst;
        res[4 * q + 2] = first;
        res[4 * q + 3] = last;
    }
    return 0;
}

/*
 * The hot loops of _sgbm_c.c, included once per instruction set (x86-64-v4 with AVX-512BW:
 * 32 int16 lanes; AVX2: 16; the baseline: 8) with K(name) giving each copy its own names
 * and KATTR its target; _sgbm_c.c picks one at run time (py_raw). Everything here works on
 * the Job and Work of _sgbm_c.c.
 *
 * The path steps are functions of their own (KSTEP: not inlined): there, with restrict
 * arguments, GCC vectorises them; inlined into the column loops it kept some copies scalar.
 */
#define KINLINE static inline __attribute__((always_inline)) KATTR
#define KSTEP static __attribute__((noinline)) KATTR

/* ---------------------------------------------------------------------------------------
 * Birchfield-Tomasi pixel costs of image row k for the w1 matched columns into `p`
 * ([w1][nd], uint8): for the left column xl = min_x1 + x and the right one xl - min_d - d,
 *   min(dist(g_l, [g_r-, g_r+]), dist(g_r, [g_l-, g_l+]))
 *     + min(dist(i_l, [i_r-, i_r+]), dist(i_r, [i_l-, i_l+])) >> 2,
 * dist(u, [v0, v1]) = max(u, v0) - min(u, v1), exact in 8 bits (at most 30 + 63 = 93).
 * The right row is mirrored: the partner of xl at disparity min_d + d is at base + d.
 */
KINLINE void K(pixel_costs)(const Job *J, int k, u8 *restrict p) {
    const int w = J->w, nd = J->nd;
    const u8 *r1 = J->ch1 + (size_t)k * 6 * w, *r2 = J->ch2 + (size_t)k * 6 * w;
    const u8 *g2 = r2, *g2lo = r2 + w, *g2hi = r2 + 2 * w;
    const u8 *i2 = r2 + 3 * w, *i2lo = r2 + 4 * w, *i2hi = r2 + 5 * w;
    for (int x = 0; x < J->w1; x++) {
        const int xl = J->min_x1 + x, base = w - 1 - xl + J->min_d;
        const u8 gu = r1[xl], gu0 = r1[w + xl], gu1 = r1[2 * w + xl];
        const u8 iu = r1[3 * w + xl], iu0 = r1[4 * w + xl], iu1 = r1[5 * w + xl];
        const u8 *restrict G = g2 + base, *restrict Glo = g2lo + base, *restrict Ghi = g2hi + base;
        const u8 *restrict I = i2 + base, *restrict Ilo = i2lo + base, *restrict Ihi = i2hi + base;
        u8 *restrict px = p + (size_t)x * nd;
        for (int d = 0; d < nd; d++) {
            u8 gv = G[d], iv = I[d];
            u8 a = (u8)((gu > Glo[d] ? gu : Glo[d]) - (gu < Ghi[d] ? gu : Ghi[d]));
            u8 b = (u8)((gv > gu0 ? gv : gu0) - (gv < gu1 ? gv : gu1));
            u8 c = (u8)((iu > Ilo[d] ? iu : Ilo[d]) - (iu < Ihi[d] ? iu : Ihi[d]));
            u8 e = (u8)((iv > iu0 ? iv : iu0) - (iv < iu1 ? iv : iu1));
            px[d] = (u8)((a < b ? a : b) + ((c < e ? c : e) >> 2));
        }
    }
}

/* The block's row sums: vsum += wa * padd (wa = half + 1 for a stripe's first row, whose rows
 * above it OpenCV replicates), or vsum += padd - psub as the block moves down a row. */
KINLINE void K(vsum_add)(i16 *restrict vs, const u8 *restrict padd, int wa, size_t n) {
    for (size_t i = 0; i < n; i++) vs[i] = (i16)(vs[i] + padd[i] * wa);
}
KINLINE void K(vsum_move)(i16 *restrict vs, const u8 *restrict padd, const u8 *restrict psub,
                      size_t n) {
    for (size_t i = 0; i < n; i++) vs[i] = (i16)(vs[i] + padd[i] - psub[i]);
}

/* One step of a path (OpenCV's form of Hirschmueller's eq. 13) for all d:
 *   L[d] = C[d] + min(min(prev[d-1], prev[d+1]) + P1, prev[d], min(prev) + P2) - (min(prev) + P2)
 * over `prev` padded with SHRT_MAX - P1 at d = -1 and d = D (never chosen; + P1 never wraps);
 * `pm` = min(prev) + P2. Writes next[d]; returns min(next). */
KSTEP i16 K(path_step)(const i16 *restrict C, const i16 *restrict prev, i16 *restrict next, int nd,
                     i16 P1, i16 pm) {
    i16 mn = MAX_COST;
    for (int d = 0; d < nd; d++) {
        i16 a = (i16)((prev[d] < prev[d + 2] ? prev[d] : prev[d + 2]) + P1);
        i16 b = prev[d + 1] < pm ? prev[d + 1] : pm;
        i16 v = (i16)(C[d] + (a < b ? a : b) - pm);
        next[d] = v;
        mn = v < mn ? v : mn;
    }
    return mn;
}

/* The same step, also writing sum[d] = next[d] + other[d] and its minimum into *smin. */
KSTEP i16 K(path_step_sum)(const i16 *restrict C, const i16 *restrict prev, i16 *restrict next,
                         const i16 *restrict other, i16 *restrict sum, i16 *smin, int nd, i16 P1,
                         i16 pm) {
    i16 mn = MAX_COST, ms = MAX_COST;
    for (int d = 0; d < nd; d++) {
        i16 a = (i16)((prev[d] < prev[d + 2] ? prev[d] : prev[d + 2]) + P1);
        i16 b = prev[d + 1] < pm ? prev[d + 1] : pm;
        i16 v = (i16)(C[d] + (a < b ? a : b) - pm);
        next[d] = v;
        mn = v < mn ? v : mn;
        i16 t = (i16)(v + other[d]);
        sum[d] = t;
        ms = t < ms ? t : ms;
    }
    *smin = ms;
    return mn;
}

/* ---------------------------------------------------------------------------------------
 * Forward pass of one row, left to right, column by column (each column's rows stay in L1):
 *  - block costs: C[x][d] = P2 + the horizontal box sum of vsum over columns x - half ..
 *    x + half, the edge columns replicated (OpenCV's getRawMatchingCost), kept in cvol;
 *  - the top path (from the row above: top[x]) and, on rows whose output is kept, the left
 *    path (from column x - 1), in OpenCV's form of Hirschmueller's eq. 13:
 *      L[d] = C[d] + min(min(prev[d-1], prev[d+1]) + P1, prev[d], min(prev) + P2)
 *             - (min(prev) + P2),
 *    over rows padded with SHRT_MAX - P1 at d = -1 and d = D (never chosen; + P1 never
 *    wraps); lt[x] = left + top.
 */
KINLINE void K(forward)(const Job *J, Work *W, int with_left) {
    const int nd = J->nd, w1 = J->w1, half = J->half, np2 = nd + 2;
    const i16 P1 = (i16)J->p1, P2 = (i16)J->p2;
    i16 *restrict hs = W->hs, *restrict tmp = W->tmp;
    const i16 *restrict vs = W->vsum;
    /* the box sum at column 0: column 0 counted half + 1 times, then columns 1 .. half */
    for (int d = 0; d < nd; d++) hs[d] = (i16)(vs[d] * (half + 1));
    for (int j = 1; j <= half; j++) {
        const i16 *restrict vj = vs + (size_t)(j < w1 ? j : w1 - 1) * nd;
        for (int d = 0; d < nd; d++) hs[d] = (i16)(hs[d] + vj[d]);
    }
    for (int d = 1; d <= nd; d++) W->left[d] = 0;
    i16 lmin = 0;
    int cur = 0;
    for (int x = 0; x < w1; x++) {
        i16 *restrict C = W->cvol + (size_t)x * nd;
        if (x > 0) {
            int ja = x + half < w1 - 1 ? x + half : w1 - 1, js = x - half - 1 > 0 ? x - half - 1 : 0;
            const i16 *restrict va = vs + (size_t)ja * nd, *restrict vb = vs + (size_t)js * nd;
            for (int d = 0; d < nd; d++) hs[d] = (i16)(hs[d] + va[d] - vb[d]);
        }
        for (int d = 0; d < nd; d++) C[d] = (i16)(hs[d] + P2);
        i16 *restrict T = W->top + (size_t)x * np2;
        const i16 tm = (i16)(W->top_min[x] + P2);
        /* the top path from the row above, into tmp, then in place */
        const i16 mt = K(path_step)(C, T, tmp, nd, P1, tm);
        memcpy(T + 1, tmp, (size_t)nd * sizeof(i16));
        W->top_min[x] = mt;
        if (!with_left) continue;
        const i16 *restrict Lp = W->left + (size_t)cur * np2;
        i16 *restrict Ln = W->left + (size_t)(1 - cur) * np2;
        i16 *restrict LT = W->lt + (size_t)x * nd;
        const i16 lm = (i16)(lmin + P2);
        i16 ml_unused;
        const i16 ml = K(path_step_sum)(C, Lp, Ln + 1, tmp, LT, &ml_unused, nd, P1, lm);
        lmin = ml;
        cur = 1 - cur;
    }
}

/* ---------------------------------------------------------------------------------------
 * Backward pass of one row, right to left: the right path, the sum of the three paths
 * s = lt + right, the choice of the disparity (the first d with the least sum), the
 * uniqueness test (no d further than 1 from it may cost less than 100 * min / (100 - ratio)
 * + 1, the vector form OpenCV runs), the reverse map disp2 for the left-right check, and the
 * sub-pixel parabola through s[best - 1], s[best], s[best + 1] (in 1/16 px, rounded as
 * OpenCV rounds). Writes row[min_x1 + x] for the pixels that pass.
 */
KINLINE void K(backward)(const Job *J, Work *W, i16 *restrict row) {
    const int nd = J->nd, w1 = J->w1, np2 = nd + 2, w = J->w, min_d = J->min_d;
    const i16 P1 = (i16)J->p1, P2 = (i16)J->p2;
    i16 *restrict s = W->s, *restrict disp2 = W->disp2, *restrict disp2cost = W->disp2cost;
    for (int d = 1; d <= nd; d++) W->right[d] = 0;
    i16 rmin = 0;
    int cur = 0;
    for (int x = w1 - 1; x >= 0; x--) {
        const i16 *restrict C = W->cvol + (size_t)x * nd;
        const i16 *restrict LT = W->lt + (size_t)x * nd;
        const i16 *restrict Rp = W->right + (size_t)cur * np2;
        i16 *restrict Rn = W->right + (size_t)(1 - cur) * np2;
        const i16 rm = (i16)(rmin + P2);
        i16 ms;
        const i16 mr = K(path_step_sum)(C, Rp, Rn + 1, LT, s, &ms, nd, P1, rm);
        rmin = mr;
        cur = 1 - cur;
        int best;
        if (J->uniq > 0) {
            i16 first = (i16)nd; /* the first d with the minimum (a min over d or nd) */
            for (int d = 0; d < nd; d++) {
                i16 dd = s[d] == ms ? (i16)d : (i16)nd;
                first = dd < first ? dd : first;
            }
            best = first;
            /* ties apart by more than 1 fail the test whichever of them is "best" */
            const i16 thresh = (i16)((100 * (int)ms) / (100 - J->uniq) + 1);
            i16 other = MAX_COST;
            for (int d = 0; d < best - 1; d++) other = s[d] < other ? s[d] : other;
            for (int d = best + 2; d < nd; d++) other = s[d] < other ? s[d] : other;
            if (other < thresh) continue;
        } else {
            best = lane_best(s, nd, ms, J->lanes);
        }
        const int x2 = x + J->min_x1 - best - min_d;
        if (x2 >= 0 && x2 < w && disp2cost[x2] > ms) {
            disp2cost[x2] = ms;
            disp2[x2] = (i16)(best + min_d);
        }
        int dd = best * 16;
        if (best > 0 && best < nd - 1) {
            const int sm = s[best - 1], sp = s[best + 1];
            int denom2 = sm + sp - 2 * s[best];
            denom2 = denom2 > 1 ? denom2 : 1;
            const int num = (sm - sp) * 16 + denom2;
            const int q = (num >= 0 ? num : -num) / (2 * denom2);
            dd += num >= 0 ? q : -q;
        }
        row[x + J->min_x1] = (i16)(dd + min_d * 16);
    }
}

/* ---------------------------------------------------------------------------------------
 * SGBM3WayMainLoop for stripe n: rows y0 (its overlap above it) .. y1. Only the rows OpenCV
 * keeps from this stripe (from n * stripe_sz on) get the left path and the backward pass; the
 * overlap rows only carry the top path and the block sums down, which is all they feed.
 */
KATTR static void K(stripe)(const Job *J, Work *W, int n) {
    const int h = J->h, w = J->w, nd = J->nd, half = J->half, hrows = J->hrows;
    const size_t cells = (size_t)J->w1 * nd;
    const int y0 = n * J->stripe_sz - J->overlap < 0
                       ? 0
                       : (n * J->stripe_sz - J->overlap > h ? h : n * J->stripe_sz - J->overlap);
    const int y1 = (n + 1) * J->stripe_sz < h ? (n + 1) * J->stripe_sz : h;
    const int keep = n * J->stripe_sz;
    const i16 edge = (i16)(MAX_COST - J->p1);
    memset(W->vsum, 0, cells * sizeof(i16));
    memset(W->top_min, 0, (size_t)J->w1 * sizeof(i16));
    for (int x = 0; x < J->w1; x++) {
        i16 *T = W->top + (size_t)x * (nd + 2);
        memset(T + 1, 0, (size_t)nd * sizeof(i16));
        T[0] = T[nd + 1] = edge;
    }
    for (int i = 0; i < 2; i++) {
        W->left[i * (nd + 2)] = W->left[i * (nd + 2) + nd + 1] = edge;
        W->right[i * (nd + 2)] = W->right[i * (nd + 2) + nd + 1] = edge;
    }
    for (int y = y0; y < y1; y++) {
        if (y == y0) { /* rows y0 .. y0 + half, y0 counted half + 1 times */
            for (int k = y0; k <= y0 + half; k++) {
                u8 *pk = W->ring + (size_t)((k < h ? k : h - 1) % hrows) * cells;
                if (k < h) K(pixel_costs)(J, k, pk);
                K(vsum_add)(W->vsum, pk, k == y0 ? half + 1 : 1, cells);
            }
        } else {
            const int k = y + half, ks = y - half - 1 > y0 ? y - half - 1 : y0;
            u8 *pk = W->ring + (size_t)((k < h ? k : h - 1) % hrows) * cells;
            if (k < h) K(pixel_costs)(J, k, pk);
            K(vsum_move)(W->vsum, pk, W->ring + (size_t)(ks % hrows) * cells, cells);
        }
        const int kept = y >= keep;
        K(forward)(J, W, kept);
        if (!kept) continue;
        i16 *row = J->raw + (size_t)y * w;
        for (int x = 0; x < w; x++) {
            W->disp2[x] = (i16)((J->min_d - 1) * 16);
            W->disp2cost[x] = MAX_COST;
        }
        K(backward)(J, W, row);
        lr_check(J, W, row);
    }
}

#undef KINLINE
#undef KSTEP

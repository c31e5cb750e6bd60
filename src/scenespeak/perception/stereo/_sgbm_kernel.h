/*
 * The hot loops of _sgbm_c.c, included once per instruction set (x86-64-v4 with AVX-512BW:
 * 32 int16 lanes; x86-64-v3 with AVX2: 16; the baseline: 8) with K(name) giving each copy
 * its own names and KATTR its target; _sgbm_c.c picks one at run time (run_stripe).
 *
 * Each loop over d is a function of its own (KSTEP: not inlined) with restrict arguments:
 * that is where GCC vectorises them reliably (inlined into the column loops, it kept some
 * copies scalar). A call per column costs little next to its D = 64..304 disparities.
 */
#define KSTEP static __attribute__((noinline)) KATTR
#define KINLINE static inline __attribute__((always_inline)) KATTR

/* ---------------------------------------------------------------------------------------
 * calcPixelCostBT's two matching channels of image row y, with their half-pixel minima and
 * maxima (Birchfield & Tomasi 1998), into out[c * 3 + k][x] (rows wp apart): c = 0 the
 * clipped horizontal Sobel response (0..30, preFilterCap 15), c = 1 the intensity; k = 0 the
 * value, 1 its minimum and 2 its maximum over the half-pixel neighbours (v + v[x +- 1]) / 2.
 * Columns 0 and w - 1 are 15 in both channels (OpenCV writes tab[0] there). With `mirror`
 * the rows are stored reversed (column w - 1 - x at x; made in tmp first), as OpenCV keeps
 * the right image's, so that a left pixel's partners lie at increasing addresses in d.
 */
KSTEP void K(channels_row)(const u8 *restrict img, int h, int w, int wp, int y,
                           u8 *restrict out, u8 *restrict tmp, int mirror) {
    const u8 *r = img + (size_t)y * w;
    const u8 *rn = img + (size_t)(y > 0 ? y - 1 : y) * w;
    const u8 *rs = img + (size_t)(y < h - 1 ? y + 1 : y) * w;
    u8 *dst = mirror ? tmp : out;
    u8 *restrict g = dst, *restrict v = dst + 3 * (size_t)wp;
    g[0] = g[w - 1] = v[0] = v[w - 1] = 15;
    for (int x = 1; x < w - 1; x++) {
        int sx = (r[x + 1] - r[x - 1]) * 2 + rn[x + 1] - rn[x - 1] + rs[x + 1] - rs[x - 1];
        sx = sx < -15 ? -15 : (sx > 15 ? 15 : sx);
        g[x] = (u8)(sx + 15);
        v[x] = r[x];
    }
    for (int c = 0; c < 2; c++) {
        const u8 *restrict val = dst + 3 * (size_t)c * wp;
        u8 *restrict lo = dst + (3 * (size_t)c + 1) * wp, *restrict hi = lo + wp;
        int u = val[0], ur = (u + val[1]) / 2; /* column 0: no left neighbour */
        lo[0] = (u8)(ur < u ? ur : u);
        hi[0] = (u8)(ur > u ? ur : u);
        for (int x = 1; x < w - 1; x++) {
            const int uu = val[x], ul = (uu + val[x - 1]) / 2, ur2 = (uu + val[x + 1]) / 2;
            const int mn = ul < ur2 ? ul : ur2, mx = ul > ur2 ? ul : ur2;
            lo[x] = (u8)(mn < uu ? mn : uu);
            hi[x] = (u8)(mx > uu ? mx : uu);
        }
        u = val[w - 1]; /* column w - 1: no right neighbour */
        const int ul = (u + val[w - 2]) / 2;
        lo[w - 1] = (u8)(ul < u ? ul : u);
        hi[w - 1] = (u8)(ul > u ? ul : u);
    }
    if (mirror) {
        for (int q = 0; q < 6; q++) {
            const u8 *restrict src = tmp + (size_t)q * wp;
            u8 *restrict o = out + (size_t)q * wp;
            for (int x = 0; x < w; x++) o[w - 1 - x] = src[x];
        }
    }
}

/* ---------------------------------------------------------------------------------------
 * Birchfield-Tomasi pixel costs of the left column xl against its partners, all d, into
 * px[0 .. ndp - 1] (uint8): with the right column xl - min_d - d,
 *   min(dist(g_l, [g_r-, g_r+]), dist(g_r, [g_l-, g_l+]))
 *     + (min(dist(i_l, [i_r-, i_r+]), dist(i_r, [i_l-, i_l+])) >> 2),
 * dist(u, [v0, v1]) = max(u, v0) - min(u, v1), exact in 8 bits (at most 30 + 63 = 93);
 * g the clipped Sobel channel, i the intensity, - and + their half-pixel minima and maxima.
 * r1: the left row's channels; G: the mirrored right row's at the partner of d = 0 (column
 * w - 1 - xl + min_d), the others following at increasing addresses. The loop runs to ndp
 * (D rounded up to 64: whole vectors, no scalar tail); the costs past D come from the
 * channels' padding and are never read as costs.
 */
KINLINE void K(bt_costs)(const u8 *restrict r1, const u8 *restrict G, int wp, int xl,
                         u8 *restrict px, int ndp) {
    const u8 gu = r1[xl], gu0 = r1[wp + xl], gu1 = r1[2 * wp + xl];
    const u8 iu = r1[3 * wp + xl], iu0 = r1[4 * wp + xl], iu1 = r1[5 * wp + xl];
    const u8 *restrict Glo = G + wp, *restrict Ghi = G + 2 * wp;
    const u8 *restrict I = G + 3 * wp, *restrict Ilo = G + 4 * wp, *restrict Ihi = G + 5 * wp;
    for (int d = 0; d < ndp; d++) {
        const u8 gv = G[d], iv = I[d];
        const u8 a = (u8)((gu > Glo[d] ? gu : Glo[d]) - (gu < Ghi[d] ? gu : Ghi[d]));
        const u8 b = (u8)((gv > gu0 ? gv : gu0) - (gv < gu1 ? gv : gu1));
        const u8 c = (u8)((iu > Ilo[d] ? iu : Ilo[d]) - (iu < Ihi[d] ? iu : Ihi[d]));
        const u8 e = (u8)((iv > iu0 ? iv : iu0) - (iv < iu1 ? iv : iu1));
        px[d] = (u8)((a < b ? a : b) + ((c < e ? c : e) >> 2));
    }
}

/* The pixel costs of one image row (its channels in W->c1, W->c2) for the w1 matched columns
 * into p ([w1][ndp]). */
KSTEP void K(pixel_costs)(const Job *J, const Work *W, u8 *restrict p) {
    const int wp = J->wp, ndp = J->ndp;
    for (int x = 0; x < J->w1; x++) {
        const int xl = J->min_x1 + x;
        K(bt_costs)(W->c1, W->c2 + (J->w - 1 - xl + J->min_d), wp, xl, p + (size_t)x * ndp, ndp);
    }
}

/* The same, and the block's column sums moved down a row at once: vs += p - psub (p the row
 * entering the block, psub the one leaving it), while p's row is in the L1 cache. */
KSTEP void K(pixel_costs_move)(const Job *J, const Work *W, u8 *restrict p,
                               const u8 *restrict psub, i16 *restrict vs) {
    const int wp = J->wp, ndp = J->ndp;
    for (int x = 0; x < J->w1; x++) {
        const int xl = J->min_x1 + x;
        const size_t o = (size_t)x * ndp;
        K(bt_costs)(W->c1, W->c2 + (J->w - 1 - xl + J->min_d), wp, xl, p + o, ndp);
        u8 *restrict px = p + o;
        const u8 *restrict ps = psub + o;
        i16 *restrict v = vs + o;
        for (int d = 0; d < ndp; d++) v[d] = (i16)(v[d] + px[d] - ps[d]);
    }
}

/* The block's column sums over its rows (vsum, [w1][ndp]): vsum += wa * padd (wa = half + 1
 * for a stripe's first row, whose rows above it OpenCV replicates), or vsum += padd - psub as
 * the block moves down a row (padd the row entering it, psub the one leaving it). */
KSTEP void K(vsum_add)(i16 *restrict vs, const u8 *restrict padd, int wa, size_t n) {
    for (size_t i = 0; i < n; i++) vs[i] = (i16)(vs[i] + padd[i] * wa);
}
KSTEP void K(vsum_move)(i16 *restrict vs, const u8 *restrict padd, const u8 *restrict psub,
                        size_t n) {
    for (size_t i = 0; i < n; i++) vs[i] = (i16)(vs[i] + padd[i] - psub[i]);
}

/* ---------------------------------------------------------------------------------------
 * One column x of the forward pass, all d at once:
 *  - the block cost C[d] = P2 + the horizontal box sum of vsum over columns x - half ..
 *    x + half (edge columns replicated, as OpenCV's getRawMatchingCost), as a running sum:
 *    C = Cprev + va - vb (Cprev the previous column's, va the column entering the box, vb
 *    the one leaving it);
 *  - the top path (from this column's previous row, T, made in tmp, then copied into T) and
 *    the left path (from the previous column, Lp, into Ln), each in OpenCV's form of Hirschmueller's eq. 13:
 *      L[d] = C[d] + min(min(prev[d-1], prev[d+1]) + P1, prev[d], min(prev) + P2)
 *             - (min(prev) + P2),
 *    over rows padded with SHRT_MAX - P1 at d = -1 and d = D (never chosen; + P1 never
 *    wraps); tm and lm are min(prev) + P2 of the two paths;
 *  - LT[d] = left + top, for the backward pass.
 * Returns the minima of the new top and left rows in mins[0], mins[1].
 */
KINLINE void K(forward_column)(const i16 *restrict va, const i16 *restrict vb,
                               const i16 *restrict Cprev,
                             i16 *restrict C, i16 *restrict T, i16 *restrict tmp,
                             const i16 *restrict Lp, i16 *restrict Ln, i16 *restrict LT,
                             const i16 *restrict pen, i16 *restrict mins, int nd) {
    const i16 P1 = pen[0], tm = pen[2], lm = pen[3];
    i16 mt = MAX_COST, ml = MAX_COST;
    for (int d = 0; d < nd; d++) {
        const i16 c = (i16)(Cprev[d] + va[d] - vb[d]);
        C[d] = c;
        const i16 ta = (i16)((T[d] < T[d + 2] ? T[d] : T[d + 2]) + P1);
        const i16 tb = T[d + 1] < tm ? T[d + 1] : tm;
        const i16 t = (i16)(c + (ta < tb ? ta : tb) - tm);
        tmp[d] = t;
        mt = t < mt ? t : mt;
        const i16 la = (i16)((Lp[d] < Lp[d + 2] ? Lp[d] : Lp[d + 2]) + P1);
        const i16 lb = Lp[d + 1] < lm ? Lp[d + 1] : lm;
        const i16 v = (i16)(c + (la < lb ? la : lb) - lm);
        Ln[d + 1] = v;
        ml = v < ml ? v : ml;
        LT[d] = (i16)(v + t);
    }
    for (int d = 0; d < nd; d++) T[d + 1] = tmp[d]; /* in place: one top path buffer */
    mins[0] = mt;
    mins[1] = ml;
}

/* One column of the backward pass: the right path (from column x + 1, Rp, into Rn; eq. 13 as
 * above, rm = min(Rp) + P2) and the sum of the three paths s = LT + right. Returns
 * min(right) in mins[0] and min(s) in mins[1]. */
KINLINE void K(backward_column)(const i16 *restrict C, const i16 *restrict LT,
                              const i16 *restrict Rp, i16 *restrict Rn, i16 *restrict s,
                              const i16 *restrict pen, i16 *restrict mins, int nd) {
    const i16 P1 = pen[0], rm = pen[1];
    i16 mr = MAX_COST, ms = MAX_COST;
    for (int d = 0; d < nd; d++) {
        const i16 a = (i16)((Rp[d] < Rp[d + 2] ? Rp[d] : Rp[d + 2]) + P1);
        const i16 b = Rp[d + 1] < rm ? Rp[d + 1] : rm;
        const i16 v = (i16)(C[d] + (a < b ? a : b) - rm);
        Rn[d + 1] = v;
        mr = v < mr ? v : mr;
        const i16 sv = (i16)(LT[d] + v);
        s[d] = sv;
        ms = sv < ms ? sv : ms;
    }
    mins[0] = mr;
    mins[1] = ms;
}

/* The choice among the summed costs s of one pixel, whose minimum is ms: the first d with
 * s[d] == ms, and how many d cost less than the uniqueness threshold (s[d] < thresh), both
 * in one pass. */
#ifdef K_AVX512
/* With AVX-512BW: the comparisons give bit masks, so the first d is a count of trailing
 * zeros and the count a popcount (no reductions across the vector); the tail is masked. */
KINLINE int K(first_min)(const i16 *restrict s, i16 ms, i16 thresh, int nd, int *below) {
    const __m512i vm = _mm512_set1_epi16(ms), vt = _mm512_set1_epi16(thresh);
    int first = -1, n = 0;
    for (int d = 0; d < nd; d += 32) {
        const __mmask32 m = nd - d >= 32 ? 0xFFFFFFFFu : ((__mmask32)1 << (nd - d)) - 1;
        const __m512i v = _mm512_maskz_loadu_epi16(m, s + d);
        const __mmask32 e = _mm512_mask_cmpeq_epi16_mask(m, v, vm);
        n += __builtin_popcount(_mm512_mask_cmplt_epi16_mask(m, v, vt));
        if (first < 0 && e) first = d + __builtin_ctz(e);
    }
    *below = n;
    return first;
}
#else
/* The smallest of "d where ms is reached, else D", and the count, as plain loops. */
KINLINE int K(first_min)(const i16 *restrict s, i16 ms, i16 thresh, int nd, int *below) {
    i16 first = (i16)nd, n = 0;
    for (int d = 0; d < nd; d++) {
        const i16 dd = s[d] == ms ? (i16)d : (i16)nd;
        first = dd < first ? dd : first;
        n = (i16)(n + (s[d] < thresh));
    }
    *below = n;
    return first;
}
#endif

/* ---------------------------------------------------------------------------------------
 * The forward pass of one row, left to right: forward_column for each column (block costs
 * kept in cvol, the top path updated in top, left + top in lt).
 */
KSTEP void K(forward)(const Job *J, Work *W) {
    const int nd = J->nd, ndp = J->ndp, w1 = J->w1, half = J->half, np2 = nd + 2;
    i16 *restrict hs = W->hs;
    const i16 *vs = W->vsum;
    /* the block cost at column 0: P2 + column 0 counted half + 1 times, then columns
     * 1 .. half */
    for (int d = 0; d < nd; d++) hs[d] = (i16)(vs[d] * (half + 1) + J->p2);
    for (int j = 1; j <= half; j++) {
        const i16 *vj = vs + (size_t)(j < w1 ? j : w1 - 1) * ndp;
        for (int d = 0; d < nd; d++) hs[d] = (i16)(hs[d] + vj[d]);
    }
    for (int d = 1; d <= nd; d++) W->left[d] = 0;
    i16 pen[4] = {(i16)J->p1, (i16)J->p2, 0, (i16)J->p2}, mins[2];
    int lc = 0;
    i16 *T = W->top;
    for (int x = 0; x < w1; x++) {
        /* the column entering the box and the one leaving it (the same at x = 0: no change) */
        const int ja = x == 0 ? 0 : (x + half < w1 - 1 ? x + half : w1 - 1);
        const int js = x - half - 1 > 0 ? x - half - 1 : 0;
        pen[2] = (i16)(W->top_min[x] + J->p2);
        K(forward_column)(vs + (size_t)ja * ndp, vs + (size_t)js * ndp,
                          x == 0 ? hs : W->cvol + (size_t)(x - 1) * nd,
                          W->cvol + (size_t)x * nd, T + (size_t)x * np2, W->tmp,
                          W->left + (size_t)lc * np2, W->left + (size_t)(1 - lc) * np2,
                          W->lt + (size_t)x * nd, pen, mins, nd);
        W->top_min[x] = mins[0];
        pen[3] = (i16)(mins[1] + J->p2);
        lc = 1 - lc;
    }
}

/* ---------------------------------------------------------------------------------------
 * The backward pass of one row, right to left: the right path and the sum of the three paths
 * (backward_column); the disparity, the first d with the least sum, or with the uniqueness
 * test off the one OpenCV's 8-lane loop picks (lane_best); the uniqueness test (no d further
 * than 1 from it may cost less than 100 * min / (100 - ratio) + 1, the vector form OpenCV
 * runs: ties apart by more than 1 fail it, whichever of them is the best); the reverse map
 * disp2 for the left-right check; the sub-pixel parabola through s[best - 1], s[best],
 * s[best + 1] (in 1/16 px, rounded as OpenCV rounds). Writes row[min_x1 + x] for the pixels
 * that pass.
 */
KSTEP void K(backward)(const Job *J, Work *W, i16 *restrict row) {
    const int nd = J->nd, w1 = J->w1, np2 = nd + 2, w = J->w, min_d = J->min_d;
    i16 *restrict s = W->s, *restrict disp2 = W->disp2, *restrict disp2cost = W->disp2cost;
    for (int d = 1; d <= nd; d++) W->right[d] = 0;
    i16 pen[2] = {(i16)J->p1, (i16)J->p2}, mins[2];
    int cur = 0;
    for (int x = w1 - 1; x >= 0; x--) {
        K(backward_column)(W->cvol + (size_t)x * nd, W->lt + (size_t)x * nd,
                           W->right + (size_t)cur * np2, W->right + (size_t)(1 - cur) * np2, s,
                           pen, mins, nd);
        pen[1] = (i16)(mins[0] + J->p2);
        cur = 1 - cur;
        const i16 ms = mins[1];
        int best;
        if (J->uniq > 0) {
            const i16 thresh = (i16)((100 * (int)ms) / (100 - J->uniq) + 1);
            int below;
            best = K(first_min)(s, ms, thresh, nd, &below);
            for (int d = best - 1; d <= best + 1; d++) /* the near ones do not count */
                if (d >= 0 && d < nd && s[d] < thresh) below--;
            if (below > 0) continue;
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

/* Both images' channels of row k into W->c1 (left) and W->c2 (right, mirrored). */
KINLINE void K(row_channels)(const Job *J, Work *W, int k) {
    K(channels_row)(J->img1, J->h, J->w, J->wp, k, W->c1, W->ctmp, 0);
    K(channels_row)(J->img2, J->h, J->w, J->wp, k, W->c2, W->ctmp, 1);
}

/* ---------------------------------------------------------------------------------------
 * SGBM3WayMainLoop for stripe n: rows y0 (its overlap above it) .. y1. Only the rows OpenCV
 * keeps from this stripe (from n * stripe_sz on) get the backward pass and the left-right
 * check; the overlap rows only carry the top path and the block sums down, all they feed.
 */
KATTR static void K(stripe)(const Job *J, Work *W, int n) {
    const int h = J->h, w = J->w, nd = J->nd, half = J->half, hrows = J->hrows;
    const size_t cells = (size_t)J->w1 * J->ndp;
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
                if (k < h) {
                    K(row_channels)(J, W, k);
                    K(pixel_costs)(J, W, pk);
                }
                K(vsum_add)(W->vsum, pk, k == y0 ? half + 1 : 1, cells);
            }
        } else {
            const int k = y + half, ks = y - half - 1 > y0 ? y - half - 1 : y0;
            u8 *pk = W->ring + (size_t)((k < h ? k : h - 1) % hrows) * cells;
            const u8 *psub = W->ring + (size_t)(ks % hrows) * cells;
            if (k < h) {
                K(row_channels)(J, W, k);
                K(pixel_costs_move)(J, W, pk, psub, W->vsum);
            } else { /* below the image: its last row again (OpenCV reuses its costs) */
                K(vsum_move)(W->vsum, pk, psub, cells);
            }
        }
        K(forward)(J, W);
        if (y < keep) continue;
        i16 *row = J->raw + (size_t)y * w;
        for (int x = 0; x < w; x++) {
            row[x] = (i16)((J->min_d - 1) * 16); /* unknown until backward finds it */
            W->disp2[x] = (i16)((J->min_d - 1) * 16);
            W->disp2cost[x] = MAX_COST;
        }
        K(backward)(J, W, row);
        lr_check(J, W, row);
    }
}

#undef KSTEP
#undef KINLINE

/*
 * OpenCV's 3-way semi-global block matching as plain C loops over int16 (private).
 *
 * The raw int16 map (before medianBlur and filterSpeckles) of cv2.StereoSGBM in
 * MODE_SGBM_3WAY, bit for bit, written from the algorithm as _sgbm3way.py (the Numba copy,
 * the readable reference) documents it: Hirschmueller 2008, "Stereo Processing by Semiglobal
 * Matching and Mutual Information", IEEE TPAMI 30(2), eq. 13, in OpenCV's variant
 * (Birchfield-Tomasi pixel costs, block sums, three paths: left, top, right, a pseudo
 * left-right check) with OpenCV's 4 fixed stripes and their overlap.
 *
 * The hot loops (_sgbm_kernel.h) run over d in int16 (the pixel costs in uint8) so that GCC
 * vectorises them; with GCC on x86-64 they are compiled three times (x86-64-v4 with
 * AVX-512BW, x86-64-v3 with AVX2, the baseline) and the widest the CPU runs is picked at run
 * time (best_isa), so the build stays portable (no -march=native). The callers (sgbm.py)
 * guarantee that no int16 sum can saturate (sgbm.fits_int16), so plain int16 arithmetic
 * equals OpenCV's saturating one.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#ifndef _WIN32
#include <pthread.h>
#endif


#define STRIPES 4
#define MAX_COST 32767 /* SHRT_MAX: OpenCV's MAX_COST */

typedef int16_t i16;
typedef uint8_t u8;

/* One call: the images' channels, the parameters and the output. */
typedef struct {
    int h, w, min_d, nd, half, p1, p2, uniq, disp12, lanes;
    int min_x1, max_x1, w1, stripe_sz, overlap, hrows;
    int wp;         /* the channel rows' stride: w + 64 (zero padding after each row) */
    int ndp;        /* D rounded up to 64: the pixel costs' row stride */
    const u8 *img1; /* [h][w]: the left image */
    const u8 *img2; /* [h][w]: the right image */
    i16 *raw;      /* [h][w]: the map (each stripe writes its rows) */
    int next;      /* the next stripe to take (threads share it) */
#ifndef _WIN32
    pthread_mutex_t lock;
#endif
    int failed; /* a thread could not allocate its buffers */
    int isa;    /* the copy of the hot loops that runs (best_isa) */
} Job;

/* One thread's buffers (their contents do not matter between stripes). */
typedef struct {
    u8 *ring;      /* [hrows][w1][ndp]: the last rows' pixel costs */
    i16 *vsum;     /* [w1][ndp]: pixel costs summed over the block's rows */
    i16 *cvol;     /* [w1][nd]: block costs C (P2 + the block's pixel costs) */
    i16 *top;      /* [w1][nd + 2]: the top path, padded at d = -1 and d = D */
    i16 *tmp;      /* [nd]: one column's new top path */
    i16 *top_min;  /* [w1]: its minima */
    i16 *lt;       /* [w1][nd]: left + top paths */
    i16 *left;     /* [2][nd + 2]: the left path, this column's and the previous one */
    i16 *right;    /* [2][nd + 2]: the right path, likewise */
    i16 *hs;       /* [nd]: the block costs of column 0 */
    i16 *s;        /* [nd]: one pixel's summed costs */
    i16 *disp2;    /* [w]: the reverse map of one row */
    i16 *disp2cost; /* [w]: its costs */
    u8 *c1, *c2;   /* [6][wp]: one row's channels (channels_row) of the left image and the
                      right one (mirrored), the padding 0 */
    u8 *ctmp;      /* [6][wp]: the right row's before it is mirrored */
} Work;

/* The disparity OpenCV's vector loop picks among equal summed costs m when the uniqueness
 * test is off: in each of `lanes` lanes (d mod lanes) the last d with cost m, then the
 * smallest of those. */
static int lane_best(const i16 *s, int nd, i16 m, int lanes) {
    int best = nd;
    for (int lane = 0; lane < lanes && lane < nd; lane++) {
        int last = -1;
        for (int d = lane; d < nd; d += lanes)
            if (s[d] == m) last = d;
        if (last >= 0 && last < best) best = last;
    }
    return best;
}

/* OpenCV's pseudo left-right check of one row against its reverse map: a disparity whose
 * floor and ceiling both land on known reverse disparities more than disp12MaxDiff away is
 * dropped. */
static void lr_check(const Job *J, const Work *W, i16 *row) {
    const int w = J->w, min_d = J->min_d, invalid = (min_d - 1) * 16;
    const i16 *disp2 = W->disp2;
    for (int x = J->min_x1; x < J->max_x1; x++) {
        const int d1 = row[x];
        if (d1 == invalid) continue;
        const int da = d1 >> 4, db = (d1 + 15) >> 4, xa = x - da, xb = x - db;
        if (xa >= 0 && xa < w && disp2[xa] >= min_d && abs(disp2[xa] - da) > J->disp12 &&
            xb >= 0 && xb < w && disp2[xb] >= min_d && abs(disp2[xb] - db) > J->disp12)
            row[x] = (i16)invalid;
    }
}

/* The hot loops, once per instruction set (see _sgbm_kernel.h). */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define HAVE_X86_COPIES 1
#include <immintrin.h> /* the v4 copy's first_min uses AVX-512BW mask compares */
#define K_AVX512 1
#define KATTR __attribute__((target("arch=x86-64-v4")))
#define K(name) name##_v4
#include "_sgbm_kernel.h"
#undef KATTR
#undef K
#undef K_AVX512
#define KATTR __attribute__((target("arch=x86-64-v3")))
#define K(name) name##_v3
#include "_sgbm_kernel.h"
#undef KATTR
#undef K
#endif
#define KATTR
#define K(name) name##_base
#include "_sgbm_kernel.h"
#undef KATTR
#undef K

/* The widest copy this CPU runs: 2 x86-64-v4 (AVX-512BW), 1 x86-64-v3 (AVX2), 0 baseline. */
static int best_isa(void) {
#ifdef HAVE_X86_COPIES
    __builtin_cpu_init();
    if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
        __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512dq") &&
        __builtin_cpu_supports("avx512cd") && __builtin_cpu_supports("avx2") &&
        __builtin_cpu_supports("fma") && __builtin_cpu_supports("bmi2"))
        return 2;
    if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") &&
        __builtin_cpu_supports("bmi2"))
        return 1;
#endif
    return 0;
}

static void run_stripe(const Job *J, Work *W, int n) {
#ifdef HAVE_X86_COPIES
    if (J->isa == 2) return stripe_v4(J, W, n);
    if (J->isa == 1) return stripe_v3(J, W, n);
#endif
    stripe_base(J, W, n);
}

static void work_free(Work *W) {
    free(W->ring);
    free(W->vsum);
    free(W->cvol);
    free(W->top);
    free(W->tmp);
    free(W->top_min);
    free(W->lt);
    free(W->left);
    free(W->right);
    free(W->hs);
    free(W->s);
    free(W->disp2);
    free(W->disp2cost);
    free(W->c1);
    free(W->c2);
    free(W->ctmp);
}

static int work_alloc(const Job *J, Work *W) {
    const size_t cells = (size_t)J->w1 * J->nd, nd = (size_t)J->nd, w = (size_t)J->w;
    const size_t pcells = (size_t)J->w1 * J->ndp;
    memset(W, 0, sizeof(*W));
    W->ring = malloc((size_t)J->hrows * pcells);
    W->vsum = malloc(pcells * sizeof(i16));
    W->cvol = malloc(cells * sizeof(i16));
    W->top = malloc((size_t)J->w1 * (nd + 2) * sizeof(i16));
    W->tmp = malloc(nd * sizeof(i16));
    W->top_min = malloc((size_t)J->w1 * sizeof(i16));
    W->lt = malloc(cells * sizeof(i16));
    W->left = malloc(2 * (nd + 2) * sizeof(i16));
    W->right = malloc(2 * (nd + 2) * sizeof(i16));
    W->hs = malloc(nd * sizeof(i16));
    W->s = malloc(nd * sizeof(i16));
    W->disp2 = malloc(w * sizeof(i16));
    W->disp2cost = malloc(w * sizeof(i16));
    W->c1 = calloc(6 * (size_t)J->wp, 1);
    W->c2 = calloc(6 * (size_t)J->wp, 1);
    W->ctmp = calloc(6 * (size_t)J->wp, 1);
    if (!W->ring || !W->vsum || !W->cvol || !W->top || !W->tmp || !W->top_min || !W->lt ||
        !W->left || !W->right || !W->hs || !W->s || !W->disp2 || !W->disp2cost || !W->c1 ||
        !W->c2 || !W->ctmp) {
        work_free(W);
        return -1;
    }
    return 0;
}

/* A thread: takes stripes until none is left, in its own buffers. */
static void *worker(void *arg) {
    Job *J = arg;
    Work W;
    if (work_alloc(J, &W)) {
        J->failed = 1;
        return NULL;
    }
    for (;;) {
        int n;
#ifndef _WIN32
        pthread_mutex_lock(&J->lock);
        n = J->next++;
        pthread_mutex_unlock(&J->lock);
#else
        n = J->next++;
#endif
        if (n >= STRIPES) break;
        run_stripe(J, &W, n);
    }
    work_free(&W);
    return NULL;
}

/* raw(left, right, out, h, w, min_d, nd, block_size, p1, p2, uniqueness, disp12, lanes,
 * threads[, isa]): the raw map of the C-contiguous uint8 pair (h, w) into the int16 buffer
 * `out` (h, w), on `threads` threads without the GIL, with the copy `isa` of the hot loops
 * (-1, the default: the widest this CPU runs; a wider one than it runs is not taken). */
static PyObject *py_raw(PyObject *self, PyObject *args) {
    Py_buffer L, R, O;
    int h, w, min_d, nd, bs, p1, p2, uniq, disp12, lanes, threads, isa = -1;
    (void)self;
    if (!PyArg_ParseTuple(args, "y*y*w*iiiiiiiiiii|i", &L, &R, &O, &h, &w, &min_d, &nd, &bs,
                          &p1, &p2, &uniq, &disp12, &lanes, &threads, &isa))
        return NULL;
    PyObject *result = NULL;
    const Py_ssize_t px = (Py_ssize_t)h * w;
    Job J;
    memset(&J, 0, sizeof(J));
    J.h = h, J.w = w, J.min_d = min_d, J.nd = nd, J.half = bs / 2, J.p1 = p1, J.p2 = p2;
    J.uniq = uniq, J.disp12 = disp12, J.lanes = lanes;
    J.isa = isa < 0 || isa > best_isa() ? best_isa() : isa;
    J.min_x1 = min_d + nd > 0 ? min_d + nd : 0;
    J.max_x1 = w + (min_d < 0 ? min_d : 0);
    J.w1 = J.max_x1 - J.min_x1;
    J.stripe_sz = (h + STRIPES - 1) / STRIPES;
    J.overlap = J.half + 1 + (J.stripe_sz + 9) / 10; /* ceil(0.1 * stripe_sz) */
    J.hrows = 2 * J.half + 2;
    J.wp = w + 64;
    J.ndp = (nd + 63) / 64 * 64;
    if (h < 1 || w < 3 || nd < 1 || bs < 1 || bs % 2 == 0 || J.w1 < 1 || lanes < 1 ||
        uniq < 0 || uniq >= 100 || p1 < 1 || p2 <= p1 || L.len != px || R.len != px ||
        O.len != px * (Py_ssize_t)sizeof(i16) || J.stripe_sz < J.overlap) {
        PyErr_SetString(PyExc_ValueError,
                        "_sgbm_c.raw: arguments outside what sgbm.SgbmParams.check allows "
                        "(or buffers of the wrong size); check them there first");
        goto done;
    }
    J.img1 = L.buf;
    J.img2 = R.buf;
    J.raw = O.buf;
    if (threads < 1) threads = 1;
    if (threads > STRIPES) threads = STRIPES;
    Py_BEGIN_ALLOW_THREADS
#ifndef _WIN32
    pthread_mutex_init(&J.lock, NULL);
    pthread_t tid[STRIPES];
    int started = 0;
    for (int t = 1; t < threads; t++)
        if (pthread_create(&tid[started], NULL, worker, &J) == 0) started++;
    worker(&J);
    for (int t = 0; t < started; t++) pthread_join(tid[t], NULL);
    pthread_mutex_destroy(&J.lock);
#else
    worker(&J);
#endif
    Py_END_ALLOW_THREADS
    if (J.failed) {
        PyErr_NoMemory();
        goto done;
    }
    Py_INCREF(Py_None);
    result = Py_None;
done:
    PyBuffer_Release(&L);
    PyBuffer_Release(&R);
    PyBuffer_Release(&O);
    return result;
}

static PyObject *py_isa(PyObject *self, PyObject *args) {
    (void)self, (void)args;
    return PyLong_FromLong(best_isa());
}

static PyMethodDef methods[] = {
    {"isa", py_isa, METH_NOARGS,
     "isa(): the copy of the hot loops raw() runs on this CPU: 2 x86-64-v4 (AVX-512BW), "
     "1 x86-64-v3 (AVX2), 0 the baseline."},
    {"raw", py_raw, METH_VARARGS,
     "raw(left, right, out, h, w, min_disparity, num_disparities, block_size, p1, p2, "
     "uniqueness, disp12_max_diff, lanes, threads[, isa]): OpenCV's 3-way SGBM map before "
     "medianBlur and filterSpeckles, into out (int16, h x w)."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_sgbm_c",
    "OpenCV's 3-way SGBM as ahead-of-time compiled C loops (private; see sgbm.py).", -1,
    methods,
};

PyMODINIT_FUNC PyInit__sgbm_c(void) { return PyModule_Create(&module); }

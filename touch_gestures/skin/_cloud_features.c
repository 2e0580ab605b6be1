/* touch_gestures.skin._cloud_accel, the features: the compiled twins of features.py's
 * arc_length_resample_complex, clouds.py's cloud_features and ndollar.py's ink_features and unistroke of one
 * path (cloud_accel.py). numpy's arithmetic step by step: its complex absolute value (AVX-512 loop), np.interp,
 * its pairwise sums, axis-0 sums in order, Smith's complex division; the same numbers as numpy's on a machine
 * where numpy takes those loops, else to an ulp (test/test_skin_cloud_accel.py). */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

/* numpy's C API table: _cloud_accel.c's (it imports it once for both units). */
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#define PY_ARRAY_UNIQUE_SYMBOL social_touch_cloud_accel_ARRAY_API
#define NO_IMPORT_ARRAY
#include <numpy/arrayobject.h>

#include <float.h>
#include <math.h>
#include <string.h>

#include "_cloud_features.h"

/* ------------------------------------------------------------------------- resampling, $N's unistroke */

/* points as (m, 2) float64 C-contiguous (converted if need be, a new reference), m >= 1; the errors of
 * features.py's arc_length_resample_complex. */
static PyArrayObject *path_points(PyObject *obj)
{
    PyArrayObject *a = (PyArrayObject *)PyArray_FROMANY(obj, NPY_FLOAT64, 0, 0, NPY_ARRAY_CARRAY_RO);
    if (a == NULL)
        return NULL;
    if (PyArray_NDIM(a) >= 1 && PyArray_DIM(a, 0) == 0) {
        PyErr_SetString(PyExc_ValueError, "cannot resample an empty path");
        Py_DECREF(a);
        return NULL;
    }
    if (PyArray_NDIM(a) != 2 || PyArray_DIM(a, 1) != 2) {
        PyObject *shape = PyObject_GetAttrString((PyObject *)a, "shape");
        if (shape != NULL)
            PyErr_Format(PyExc_ValueError, "a path is (m, 2) points; got shape %R", shape);
        Py_XDECREF(shape);
        Py_DECREF(a);
        return NULL;
    }
    return a;
}

/* |dx + i dy| as numpy's SIMD complex absolute computes it (the larger part times sqrt(1 + ratio^2), the
 * square and the 1 fused): numpy's own result depends on the machine (its scalar loop calls hypot), so
 * this matches it bit for bit where numpy takes its AVX-512 loop, else to an ulp. */
static inline double step_length(double dx, double dy)
{
    double a = fabs(dx), b = fabs(dy), larger = a > b ? a : b, smaller = a > b ? b : a;
    if (isinf(larger))
        return INFINITY;
    if (isnan(larger) || isnan(smaller))
        return NAN;
    if (larger == 0.0)
        return 0.0;
    double ratio = smaller / larger;
    return sqrt(fma(ratio, ratio, 1.0)) * larger;
}

/* features.py's arc_length_resample_complex into out (n complex as 2 n doubles): the steps' lengths
 * (as numpy's abs of a complex), zero across a change of stroke id, their running sum in order
 * (cumsum), n targets equally spaced (the last exactly the total), and np.interp's arithmetic: the last
 * knot at or below each target, its value where they are equal, else the slope times the offset plus
 * the value (numpy's formula, and its fall-back where that gives NaN). cum holds m doubles. */
void skin_resample_into(const double *p, const double *ids, Py_ssize_t m, Py_ssize_t n, double *cum,
                          double *out)
{
    cum[0] = 0.0;
    for (Py_ssize_t i = 1; i < m; i++) {
        double step = step_length(p[2 * i] - p[2 * i - 2], p[2 * i + 1] - p[2 * i - 1]);
        if (ids != NULL && ids[i] != ids[i - 1])
            step = 0.0;   /* the finger is lifted: no ink between strokes */
        cum[i] = cum[i - 1] + step;
    }
    double total = cum[m - 1];
    if (!(total > 0)) {
        for (Py_ssize_t k = 0; k < n; k++) {
            out[2 * k] = p[0];
            out[2 * k + 1] = p[1];
        }
        return;
    }
    double spacing = n > 1 ? total / (double)(n - 1) : 0.0;
    Py_ssize_t j = 0;
    for (Py_ssize_t k = 0; k < n; k++) {
        double x = (n > 1 && k == n - 1) ? total : (double)k * spacing;
        if (isnan(x)) {
            out[2 * k] = x;
            out[2 * k + 1] = 0.0;
            continue;
        }
        if (x >= cum[m - 1]) {   /* at or beyond the last knot: its value */
            out[2 * k] = p[2 * (m - 1)];
            out[2 * k + 1] = p[2 * (m - 1) + 1];
            continue;
        }
        if (x < cum[0]) {
            out[2 * k] = p[0];
            out[2 * k + 1] = p[1];
            continue;
        }
        if (j > 0 && cum[j] > x)
            j = 0;   /* targets rise, so this never happens; kept for safety */
        while (j + 1 < m && cum[j + 1] <= x)
            j++;
        if (cum[j] == x) {
            out[2 * k] = p[2 * j];
            out[2 * k + 1] = p[2 * j + 1];
            continue;
        }
        double inv = 1.0 / (cum[j + 1] - cum[j]);
        for (int a = 0; a < 2; a++) {
            double lo = p[2 * j + a], hi = p[2 * (j + 1) + a], slope = (hi - lo) * inv;
            double v = slope * (x - cum[j]) + lo;
            if (isnan(v)) {
                v = slope * (x - cum[j + 1]) + hi;
                if (isnan(v) && lo == hi)
                    v = lo;
            }
            out[2 * k + a] = v;
        }
    }
}

/* A path's points (path_points) and its (m,) stroke ids as float64, or NULL for None: compared as numpy
 * compares the ids it is given (integers exactly, NaN unlike itself). 0, or -1 with an exception (and
 * nothing held). */
int skin_path_and_ids(PyObject *points_obj, PyObject *ids_obj, PyArrayObject **pts, PyArrayObject **ids)
{
    *ids = NULL;
    *pts = path_points(points_obj);
    if (*pts == NULL)
        return -1;
    if (ids_obj == Py_None)
        return 0;
    *ids = (PyArrayObject *)PyArray_FROMANY(ids_obj, NPY_FLOAT64, 1, 1, NPY_ARRAY_CARRAY_RO | NPY_ARRAY_FORCECAST);
    if (*ids != NULL && PyArray_DIM(*ids, 0) == PyArray_DIM(*pts, 0))
        return 0;
    if (*ids != NULL)
        PyErr_Format(PyExc_ValueError, "need one stroke id per point: %zd points, %zd ids",
                     (Py_ssize_t)PyArray_DIM(*pts, 0), (Py_ssize_t)PyArray_DIM(*ids, 0));
    Py_CLEAR(*ids);
    Py_CLEAR(*pts);
    return -1;
}

/* resample(points, stroke, n) -> (n,) complex128: features.py's arc_length_resample_complex. */
static PyObject *py_resample(PyObject *Py_UNUSED(module), PyObject *args)
{
    PyObject *points_obj, *ids_obj;
    Py_ssize_t n;
    if (!PyArg_ParseTuple(args, "OOn:resample", &points_obj, &ids_obj, &n))
        return NULL;
    if (n < 1) {
        PyErr_Format(PyExc_ValueError, "need n >= 1 points, got %zd", n);
        return NULL;
    }
    PyArrayObject *pts, *ids;
    if (skin_path_and_ids(points_obj, ids_obj, &pts, &ids) < 0)
        return NULL;
    Py_ssize_t m = PyArray_DIM(pts, 0);
    npy_intp dims[1] = {n};
    PyObject *out = PyArray_SimpleNew(1, dims, NPY_COMPLEX128);
    double *cum = PyMem_Malloc((size_t)m * sizeof(double));
    if (out != NULL && cum != NULL)
        skin_resample_into(PyArray_DATA(pts), ids ? PyArray_DATA(ids) : NULL, m, n, cum,
                      PyArray_DATA((PyArrayObject *)out));
    else if (out != NULL) {
        Py_CLEAR(out);
        PyErr_NoMemory();
    }
    PyMem_Free(cum);
    Py_XDECREF(ids);
    Py_DECREF(pts);
    return out;
}

/* numpy's pairwise sum of n complex numbers (2 n doubles, interleaved) into rr, ri: what complex
 * .sum() gives bit for bit (numpy's loops_utils pairwise_sum, 8 accumulators in blocks of 128). */
static void pairwise_complex(const double *a, Py_ssize_t doubles, double *rr, double *ri)
{
    if (doubles < 8) {
        *rr = -0.0;
        *ri = -0.0;
        for (Py_ssize_t i = 0; i < doubles; i += 2) {
            *rr += a[i];
            *ri += a[i + 1];
        }
    } else if (doubles <= 128) {
        double r[8];
        Py_ssize_t i;
        for (int j = 0; j < 8; j++)
            r[j] = a[j];
        for (i = 8; i < doubles - (doubles % 8); i += 8)
            for (int j = 0; j < 8; j++)
                r[j] += a[i + j];
        *rr = (r[0] + r[2]) + (r[4] + r[6]);
        *ri = (r[1] + r[3]) + (r[5] + r[7]);
        for (; i < doubles; i += 2) {
            *rr += a[i];
            *ri += a[i + 1];
        }
    } else {
        Py_ssize_t half = doubles / 2;
        half -= half % 8;
        double r1, i1, r2, i2;
        pairwise_complex(a, half, &r1, &i1);
        pairwise_complex(a + half, doubles - half, &r2, &i2);
        *rr = r1 + r2;
        *ri = i1 + i2;
    }
}

/* cloud(points, stroke, n) -> (2 n,) float32: clouds.py's cloud_features (resampled along the ink, the
 * mean taken off as numpy's complex sum times 1 / n, divided by the larger side of the box). */
static PyObject *py_cloud(PyObject *module, PyObject *args)
{
    PyObject *resampled = py_resample(module, args);
    if (resampled == NULL)
        return NULL;
    Py_ssize_t n = PyArray_DIM((PyArrayObject *)resampled, 0);
    double *c = PyArray_DATA((PyArrayObject *)resampled), sr, si;
    pairwise_complex(c, 2 * n, &sr, &si);
    /* numpy's complex / n, Smith's method with a zero imaginary divisor: the parts cross-multiplied by 0
     * (so a NaN in one part makes both NaN, as numpy's), times 1 / n. */
    double inv = 1.0 / (double)n, mr = (sr + si * 0.0) * inv, mi = (si - sr * 0.0) * inv;
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    int nan_seen = 0;
    for (Py_ssize_t k = 0; k < n; k++) {
        c[2 * k] -= mr;
        c[2 * k + 1] -= mi;
        for (int a = 0; a < 2; a++) {
            double v = c[2 * k + a];
            nan_seen |= isnan(v);
            lo[a] = v < lo[a] ? v : lo[a];
            hi[a] = v > hi[a] ? v : hi[a];
        }
    }
    double width = hi[0] - lo[0], height = hi[1] - lo[1];
    double size = nan_seen ? NAN : (width > height ? width : height);   /* NaN if either is, as numpy's max */
    npy_intp dims[1] = {2 * n};
    PyObject *out = PyArray_SimpleNew(1, dims, NPY_FLOAT32);
    if (out != NULL) {
        float *f = PyArray_DATA((PyArrayObject *)out);
        for (Py_ssize_t k = 0; k < 2 * n; k++)
            f[k] = (float)(size > 1e-9 ? c[k] / size : c[k]);
    }
    Py_DECREF(resampled);
    return out;
}

/* numpy's pairwise sum of n doubles (what a contiguous .sum() gives bit for bit). */
static double pairwise_real(const double *a, Py_ssize_t n)
{
    if (n < 8) {
        double r = 0.0;
        for (Py_ssize_t i = 0; i < n; i++)
            r += a[i];
        return r;
    }
    if (n <= 128) {
        double r[8], res;
        Py_ssize_t i;
        for (int j = 0; j < 8; j++)
            r[j] = a[j];
        for (i = 8; i < n - (n % 8); i += 8)
            for (int j = 0; j < 8; j++)
                r[j] += a[i + j];
        res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
        for (; i < n; i++)
            res += a[i];
        return res;
    }
    Py_ssize_t half = n / 2;
    half -= half % 8;
    return pairwise_real(a, half) + pairwise_real(a + half, n - half);
}

/* ink(points, stroke, ink_points) -> (3 ink_points,) float32 or None: ndollar.py's ink_features, numpy's
 * arithmetic step by step (stroke lengths as hypot summed pairwise, shares floored, each stroke
 * resampled, the mean of the columns summed in order then divided, the larger side of the box). */
static PyObject *py_ink(PyObject *Py_UNUSED(module), PyObject *args)
{
    PyObject *points_obj, *ids_obj;
    Py_ssize_t ink;
    if (!PyArg_ParseTuple(args, "OOn:ink", &points_obj, &ids_obj, &ink))
        return NULL;
    if (ink < 1) {
        PyErr_Format(PyExc_ValueError, "need ink_points >= 1, got %zd", ink);
        return NULL;
    }
    PyArrayObject *pts, *ids;
    if (skin_path_and_ids(points_obj, ids_obj, &pts, &ids) < 0)
        return NULL;
    Py_ssize_t m = PyArray_DIM(pts, 0);
    const double *p = PyArray_DATA(pts), *id = ids ? PyArray_DATA(ids) : NULL;
    Py_ssize_t k = 1;
    for (Py_ssize_t i = 1; id != NULL && i < m; i++)
        k += id[i] != id[i - 1];
    PyObject *result = NULL;
    if (k > ink) {   /* more strokes than points to give them */
        result = Py_NewRef(Py_None);
        goto done;
    }
    /* one block: k stroke starts + 1, k lengths, m steps (and m cumulative lengths), ink x 2 points, ink ids */
    size_t need = (size_t)(k + 1) * sizeof(Py_ssize_t) + ((size_t)k + 2 * (size_t)m + 3 * (size_t)ink) * sizeof(double);
    char *block = PyMem_Malloc(need);
    if (block == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    Py_ssize_t *start = (Py_ssize_t *)block;
    double *lengths = (double *)(start + k + 1), *steps = lengths + k, *cum = steps + m, *out = cum + m;
    double *sid = out + 2 * ink;
    start[0] = 0;
    for (Py_ssize_t i = 1, s = 1; id != NULL && i < m; i++)
        if (id[i] != id[i - 1])
            start[s++] = i;
    start[k] = m;
    for (Py_ssize_t s = 0; s < k; s++) {
        Py_ssize_t a = start[s], len = start[s + 1] - a;
        for (Py_ssize_t i = 1; i < len; i++)
            steps[i - 1] = hypot(p[2 * (a + i)] - p[2 * (a + i - 1)], p[2 * (a + i) + 1] - p[2 * (a + i - 1) + 1]);
        lengths[s] = pairwise_real(steps, len - 1);
    }
    double total = pairwise_real(lengths, k);
    Py_ssize_t floor_points = 2 * k <= ink ? 2 : 1, spare = ink - floor_points * k, at = 0;
    for (Py_ssize_t s = 0; s < k; s++) {
        Py_ssize_t c = floor_points + (total > 0 ? (Py_ssize_t)floor((double)spare * lengths[s] / total) : 0);
        skin_resample_into(p + 2 * start[s], NULL, start[s + 1] - start[s], c, cum, out + 2 * at);
        for (Py_ssize_t j = 0; j < c; j++)
            sid[at + j] = (double)s;
        at += c;
    }
    for (Py_ssize_t j = at; j < ink; j++)
        sid[j] = -1.0;   /* padding */
    double mean[2] = {0.0, 0.0}, lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    int nan_seen = 0;
    for (Py_ssize_t j = 0; j < at; j++) {
        mean[0] += out[2 * j];
        mean[1] += out[2 * j + 1];
    }
    mean[0] /= (double)at;
    mean[1] /= (double)at;
    for (Py_ssize_t j = 0; j < at; j++) {
        for (int a = 0; a < 2; a++) {
            double v = out[2 * j + a] -= mean[a];
            nan_seen |= isnan(v);
            lo[a] = v < lo[a] ? v : lo[a];
            hi[a] = v > hi[a] ? v : hi[a];
        }
    }
    double w = hi[0] - lo[0], h = hi[1] - lo[1], size = nan_seen ? NAN : (w > h ? w : h);
    npy_intp dims[1] = {3 * ink};
    result = PyArray_SimpleNew(1, dims, NPY_FLOAT32);
    if (result != NULL) {
        float *f = PyArray_DATA((PyArrayObject *)result);
        for (Py_ssize_t j = 0; j < ink; j++) {
            Py_ssize_t from = j < at ? j : at - 1;   /* padding repeats the last point */
            for (int a = 0; a < 2; a++) {
                double v = out[2 * from + a];
                f[2 * j + a] = (float)(size > 1e-9 ? v / size : v);
            }
            f[2 * ink + j] = (float)sid[j];
        }
    }
    PyMem_Free(block);
done:
    Py_XDECREF(ids);
    Py_DECREF(pts);
    return result;
}

/* Mean of (n, 2) points into c[2]. */
static void centre_of(const double *p, Py_ssize_t n, double *c)
{
    c[0] = c[1] = 0.0;
    for (Py_ssize_t k = 0; k < n; k++) {
        c[0] += p[2 * k];
        c[1] += p[2 * k + 1];
    }
    c[0] /= (double)n;
    c[1] /= (double)n;
}

/* unistroke(path, n, one_d_ratio) -> ((2 n,) float64 unit vector, start angle or NaN): ndollar.py's
 * unistroke_vectors of one path (jumps between strokes count). */
static PyObject *py_unistroke(PyObject *Py_UNUSED(module), PyObject *args)
{
    PyObject *path_obj;
    Py_ssize_t n;
    double ratio;
    if (!PyArg_ParseTuple(args, "Ond:unistroke", &path_obj, &n, &ratio))
        return NULL;
    if (n < 8 || !(ratio >= 0.0 && ratio <= 1.0)) {
        PyErr_Format(PyExc_ValueError, "need n >= 8 and one_d_ratio in [0, 1]; got %zd, %R", n, PyTuple_GET_ITEM(args, 2));
        return NULL;
    }
    PyArrayObject *path = path_points(path_obj);
    if (path == NULL)
        return NULL;
    Py_ssize_t m = PyArray_DIM(path, 0);
    npy_intp dims[1] = {2 * n};
    PyObject *vec = PyArray_SimpleNew(1, dims, NPY_FLOAT64);
    double *cum = PyMem_Malloc((size_t)m * sizeof(double));
    if (vec == NULL || cum == NULL) {
        Py_XDECREF(vec);
        PyMem_Free(cum);
        Py_DECREF(path);
        return vec == NULL ? NULL : PyErr_NoMemory();
    }
    double *p = PyArray_DATA((PyArrayObject *)vec), c[2];
    skin_resample_into(PyArray_DATA(path), NULL, m, n, cum, p);
    PyMem_Free(cum);
    Py_DECREF(path);
    centre_of(p, n, c);
    for (Py_ssize_t k = 0; k < n; k++) {
        p[2 * k] -= c[0];
        p[2 * k + 1] -= c[1];
    }
    double indicative = atan2(-p[1], -p[0]);   /* from the first point to the centroid */
    double cs = cos(-indicative), sn = sin(-indicative);
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (Py_ssize_t k = 0; k < n; k++) {
        double x = p[2 * k], y = p[2 * k + 1];
        p[2 * k] = x * cs - y * sn;
        p[2 * k + 1] = x * sn + y * cs;
        for (int a = 0; a < 2; a++) {
            lo[a] = p[2 * k + a] < lo[a] ? p[2 * k + a] : lo[a];
            hi[a] = p[2 * k + a] > hi[a] ? p[2 * k + a] : hi[a];
        }
    }
    double w = hi[0] - lo[0], h = hi[1] - lo[1], big = w > h ? w : h, small = w < h ? w : h;
    int line = small <= ratio * big;
    /* A line scales uniformly; a 2-D shape to a square (ScaleDimTo); a dab (big 0) not at all. */
    double sx = 1.0 / fmax(line ? big : w, 1e-12), sy = 1.0 / fmax(line ? big : h, 1e-12);
    if (big <= 1e-12)
        sx = sy = 1.0;
    cs = cos(indicative);
    sn = sin(indicative);
    for (Py_ssize_t k = 0; k < n; k++) {
        double x = p[2 * k] * sx, y = p[2 * k + 1] * sy;
        p[2 * k] = x * cs - y * sn;   /* back to the skin's frame */
        p[2 * k + 1] = x * sn + y * cs;
    }
    centre_of(p, n, c);
    double norm = 0.0;
    for (Py_ssize_t k = 0; k < n; k++) {
        p[2 * k] -= c[0];
        p[2 * k + 1] -= c[1];
        norm += p[2 * k] * p[2 * k] + p[2 * k + 1] * p[2 * k + 1];
    }
    double sx0 = p[2 * (n / 8)] - p[0], sy0 = p[2 * (n / 8) + 1] - p[1];
    double angle = hypot(sx0, sy0) > 1e-9 ? atan2(sy0, sx0) : NAN;
    norm = sqrt(norm);
    for (Py_ssize_t k = 0; k < 2 * n; k++)
        p[k] = norm > 0 ? p[k] / norm : 0.0;
    PyObject *result = Py_BuildValue("Nd", vec, angle);
    return result;
}

/* ------------------------------------------------------------------------- the trace (proposed.py) */

/* numpy's minimum / maximum of two: NaN if either is. */
static inline double nan_min(double a, double b) { return isnan(a) ? a : isnan(b) ? b : (a <= b ? a : b); }
static inline double nan_max(double a, double b) { return isnan(a) ? a : isnan(b) ? b : (a >= b ? a : b); }

/* np.interp of index x between the full bins `full` (ascending, n_full >= 1) of res (n, 2): numpy's
 * arithmetic (the slope over the bracketing pair, times the offset from the lower, plus its value; from the
 * upper where that is NaN; the ends' values outside). */
static void interpolate_bin(double *res, const npy_intp *full, Py_ssize_t n_full, npy_intp x)
{
    if (n_full == 1 || x < full[0] || x > full[n_full - 1]) {
        npy_intp end = x < full[0] ? full[0] : full[n_full - 1];
        res[2 * x] = res[2 * end];
        res[2 * x + 1] = res[2 * end + 1];
        return;
    }
    Py_ssize_t lo = 0, hi = n_full - 1;   /* full[lo] <= x < full[hi] */
    while (hi - lo > 1) {
        Py_ssize_t mid = (lo + hi) / 2;
        if (full[mid] <= x)
            lo = mid;
        else
            hi = mid;
    }
    double x0 = (double)full[lo], x1 = (double)full[hi], xv = (double)x;
    for (int a = 0; a < 2; a++) {
        double y0 = res[2 * full[lo] + a], y1 = res[2 * full[hi] + a];
        double v;
        if (xv == x0)
            v = y0;
        else {
            double slope = (y1 - y0) / (x1 - x0);
            v = slope * (xv - x0) + y0;
            if (isnan(v)) {
                v = slope * (xv - x1) + y1;
                if (isnan(v) && y0 == y1)
                    v = y0;
            }
        }
        res[2 * x + a] = v;
    }
}

/* proposed.py's time_bin_resample of m >= 1 finite points p (m, 2) at times t (m,) into res (n, 2): each
 * point's bin ((t - t0) * n / duration, truncated, the last point into the last bin; by sample index where
 * the times are constant, go backwards or the duration is so small that n / duration overflows), the bins'
 * sums in point order (as np.bincount's), divided by their counts; empty bins interpolated. counts and full
 * hold n each. */
static void time_bins(const double *p, const double *t, Py_ssize_t m, Py_ssize_t n, double *res,
                      npy_intp *counts, npy_intp *full)
{
    if (m == 1) {
        for (Py_ssize_t k = 0; k < n; k++) {
            res[2 * k] = p[0];
            res[2 * k + 1] = p[1];
        }
        return;
    }
    double duration = t[m - 1] - t[0];
    double scale = duration > 0 ? (double)n / duration : INFINITY;
    int by_index = !isfinite(scale);
    for (Py_ssize_t i = 1; i < m && !by_index; i++)
        by_index = t[i] < t[i - 1];
    if (by_index)
        scale = (double)n / (double)(m - 1);
    memset(res, 0, 2 * (size_t)n * sizeof(double));
    memset(counts, 0, (size_t)n * sizeof(npy_intp));
    for (Py_ssize_t i = 0; i < m; i++) {
        double offset = by_index ? (double)i : t[i] - t[0];
        npy_intp k = (npy_intp)(offset * scale);
        if (k > n - 1)
            k = n - 1;   /* the last point falls on the upper edge: last bin */
        res[2 * k] += p[2 * i];
        res[2 * k + 1] += p[2 * i + 1];
        counts[k]++;
    }
    Py_ssize_t n_full = 0;
    for (Py_ssize_t k = 0; k < n; k++) {
        if (counts[k] == 0)
            continue;
        res[2 * k] /= (double)counts[k];
        res[2 * k + 1] /= (double)counts[k];
        full[n_full++] = k;
    }
    if (n_full < n)
        for (Py_ssize_t k = 0; k < n; k++)
            if (counts[k] == 0)
                interpolate_bin(res, full, n_full, k);
}

/* proposed.py's trace_features after the resampling: res (n, 2) centred on its bounding box and divided per
 * axis by the larger of its extent and aspect_floor times the larger extent, into out (2 n) float32; all
 * zeros where the larger extent is not above 1e-9 (or NaN). numpy's NaN rules (min, max, maximum). */
static void trace_scale(const double *res, Py_ssize_t n, double aspect_floor, float *out)
{
    double lo[2] = {res[0], res[1]}, hi[2] = {res[0], res[1]};
    for (Py_ssize_t k = 1; k < n; k++)
        for (int a = 0; a < 2; a++) {
            lo[a] = nan_min(lo[a], res[2 * k + a]);
            hi[a] = nan_max(hi[a], res[2 * k + a]);
        }
    double span[2] = {hi[0] - lo[0], hi[1] - lo[1]};
    double size = nan_max(span[0], span[1]);
    if (!(size > 1e-9)) {
        memset(out, 0, 2 * (size_t)n * sizeof(float));
        return;
    }
    double centre[2], scale[2];
    for (int a = 0; a < 2; a++) {
        centre[a] = 0.5 * (lo[a] + hi[a]);
        scale[a] = nan_max(span[a], aspect_floor * size);
    }
    for (Py_ssize_t k = 0; k < n; k++)
        for (int a = 0; a < 2; a++)
            out[2 * k + a] = (float)((res[2 * k + a] - centre[a]) / scale[a]);
}

/* trace(points, times, n, aspect_floor) -> (2 n,) float32: proposed.py's trace_features. Points and times
 * must be finite (the numpy reference's answers to NaN are accidents of its steps: refused here). */
static PyObject *py_trace(PyObject *Py_UNUSED(module), PyObject *args)
{
    PyObject *points_obj, *times_obj;
    Py_ssize_t n;
    double aspect_floor;
    if (!PyArg_ParseTuple(args, "OOnd:trace", &points_obj, &times_obj, &n, &aspect_floor))
        return NULL;
    if (n < 1) {
        PyErr_Format(PyExc_ValueError, "need n >= 1 time bins, got %zd", n);
        return NULL;
    }
    PyArrayObject *pts = path_points(points_obj);
    if (pts == NULL)
        return NULL;
    PyArrayObject *times = (PyArrayObject *)PyArray_FROMANY(times_obj, NPY_FLOAT64, 1, 1,
                                                            NPY_ARRAY_CARRAY_RO | NPY_ARRAY_FORCECAST);
    if (times == NULL) {
        Py_DECREF(pts);
        return NULL;
    }
    Py_ssize_t m = PyArray_DIM(pts, 0);
    const double *p = PyArray_DATA(pts), *t = PyArray_DATA(times);
    PyObject *out = NULL;
    double *res = NULL;
    npy_intp *counts = NULL;
    if (PyArray_DIM(times, 0) != m) {
        PyErr_Format(PyExc_ValueError, "need one time per point: %zd points, %zd times", m,
                     (Py_ssize_t)PyArray_DIM(times, 0));
        goto done;
    }
    int finite = 1;
    for (Py_ssize_t i = 0; i < m; i++)
        finite = finite && isfinite(p[2 * i]) && isfinite(p[2 * i + 1]) && isfinite(t[i]);
    if (!finite) {
        PyErr_SetString(PyExc_ValueError, "a trace needs finite points and times: got a NaN or infinite one");
        goto done;
    }
    npy_intp dims[1] = {2 * n};
    res = PyMem_Malloc(2 * (size_t)n * sizeof(double));
    counts = PyMem_Malloc(2 * (size_t)n * sizeof(npy_intp));   /* the counts, then the full bins */
    if (res == NULL || counts == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    out = PyArray_SimpleNew(1, dims, NPY_FLOAT32);
    if (out == NULL)
        goto done;
    time_bins(p, t, m, n, res, counts, counts + n);
    trace_scale(res, n, aspect_floor, PyArray_DATA((PyArrayObject *)out));
done:
    PyMem_Free(counts);
    PyMem_Free(res);
    Py_DECREF(times);
    Py_DECREF(pts);
    return out;
}

/* trace_minima(sq_norms, products, query_sq, n_points, class_starts) -> (n_classes,) float64: proposed.py's
 * distances (sqrt(max(|t|^2 - 2 t.q + |q|^2, 0) / n_points), float32 step by step as numpy computes them: the
 * python float |q|^2 and n_points as float32) and base.py's class minima of them (np.minimum.reduceat: NaN if
 * any is; a class whose run is empty takes its first template's, as reduceat). sq_norms and products (T,)
 * float32 (the templates' squared norms and the matrix-vector product numpy's BLAS computed), class_starts
 * (n_classes,) intp ascending within [0, T). */
static PyObject *py_trace_minima(PyObject *Py_UNUSED(module), PyObject *args)
{
    PyObject *norms_obj, *products_obj, *starts_obj;
    double query_sq;
    Py_ssize_t n_points;
    if (!PyArg_ParseTuple(args, "OOdnO:trace_minima", &norms_obj, &products_obj, &query_sq, &n_points, &starts_obj))
        return NULL;
    PyArrayObject *norms = NULL, *products = NULL, *starts = NULL;
    PyObject *out = NULL;
    norms = (PyArrayObject *)PyArray_FROMANY(norms_obj, NPY_FLOAT32, 1, 1, NPY_ARRAY_CARRAY_RO);
    products = norms ? (PyArrayObject *)PyArray_FROMANY(products_obj, NPY_FLOAT32, 1, 1, NPY_ARRAY_CARRAY_RO) : NULL;
    starts = products ? (PyArrayObject *)PyArray_FROMANY(starts_obj, NPY_INTP, 1, 1, NPY_ARRAY_CARRAY_RO) : NULL;
    if (starts == NULL)
        goto done;
    Py_ssize_t t_count = PyArray_DIM(norms, 0), n_classes = PyArray_DIM(starts, 0);
    if (PyArray_DIM(products, 0) != t_count || n_points < 1 || n_classes < 1) {
        PyErr_Format(PyExc_ValueError, "trace_minima: need as many products as norms (%zd, %zd), n_points >= 1 "
                     "(%zd) and a class", t_count, (Py_ssize_t)PyArray_DIM(products, 0), n_points);
        goto done;
    }
    const npy_intp *start = PyArray_DATA(starts);
    for (Py_ssize_t c = 0; c < n_classes; c++)
        if (start[c] < 0 || start[c] >= t_count) {
            PyErr_Format(PyExc_ValueError, "trace_minima: class %zd starts at %zd, outside %zd templates", c,
                         (Py_ssize_t)start[c], t_count);
            goto done;
        }
    npy_intp dims[1] = {n_classes};
    out = PyArray_SimpleNew(1, dims, NPY_FLOAT64);
    if (out == NULL)
        goto done;
    const float *sq = PyArray_DATA(norms), *tq = PyArray_DATA(products);
    const float qq = (float)query_sq, n = (float)n_points;
    double *o = PyArray_DATA((PyArrayObject *)out);
    for (Py_ssize_t c = 0; c < n_classes; c++) {
        Py_ssize_t end = c + 1 == n_classes ? t_count : start[c + 1];
        if (end <= start[c])
            end = start[c] + 1;   /* reduceat: a run that does not rise is its first element */
        float best = NAN;
        for (Py_ssize_t i = start[c]; i < end; i++) {
            float d2 = (sq[i] - 2.0f * tq[i]) + qq;
            d2 = isnan(d2) || d2 >= 0.0f ? d2 : 0.0f;   /* np.maximum(d2, 0.0): NaN stays */
            float d = sqrtf(d2 / n);
            if (i == start[c] || (!isnan(best) && (isnan(d) || d < best)))   /* np.minimum: a NaN wins, and stays */
                best = d;
        }
        o[c] = (double)best;
    }
done:
    Py_XDECREF(starts);
    Py_XDECREF(products);
    Py_XDECREF(norms);
    return out;
}

/* ------------------------------------------------------------------------- fused.py's sum */

/* relative_sum(first, second) -> (n,) float64: fused.py's relative_distances(first) + relative_distances(second)
 * of two (n,) float64 arrays: each over its smallest finite value (over DBL_MIN, numpy's finfo tiny, where that
 * is not above 0; as it is where none is finite), the same divisions and sum as numpy's, no warnings. */
static PyObject *py_relative_sum(PyObject *Py_UNUSED(module), PyObject *args)
{
    PyObject *objs[2];
    if (!PyArg_ParseTuple(args, "OO:relative_sum", &objs[0], &objs[1]))
        return NULL;
    PyArrayObject *arrs[2] = {NULL, NULL};
    PyObject *out = NULL;
    for (int a = 0; a < 2; a++) {
        arrs[a] = (PyArrayObject *)PyArray_FROMANY(objs[a], NPY_FLOAT64, 1, 1, NPY_ARRAY_CARRAY_RO | NPY_ARRAY_FORCECAST);
        if (arrs[a] == NULL)
            goto done;
    }
    Py_ssize_t n = PyArray_DIM(arrs[0], 0);
    if (PyArray_DIM(arrs[1], 0) != n) {
        PyErr_Format(PyExc_ValueError, "need two distances per class: %zd and %zd", n,
                     (Py_ssize_t)PyArray_DIM(arrs[1], 0));
        goto done;
    }
    const double *d[2] = {PyArray_DATA(arrs[0]), PyArray_DATA(arrs[1])};
    double divisor[2];
    int divide[2];
    for (int a = 0; a < 2; a++) {
        double nearest = INFINITY;
        divide[a] = 0;
        for (Py_ssize_t k = 0; k < n; k++)
            if (isfinite(d[a][k])) {
                divide[a] = 1;
                nearest = d[a][k] < nearest ? d[a][k] : nearest;
            }
        divisor[a] = nearest > 0 ? nearest : DBL_MIN;   /* an exact match: over the smallest normal float */
    }
    npy_intp dims[1] = {n};
    out = PyArray_SimpleNew(1, dims, NPY_FLOAT64);
    if (out == NULL)
        goto done;
    double *o = PyArray_DATA((PyArrayObject *)out);
    for (Py_ssize_t k = 0; k < n; k++) {
        double x = divide[0] ? d[0][k] / divisor[0] : d[0][k], y = divide[1] ? d[1][k] / divisor[1] : d[1][k];
        o[k] = x + y;
    }
done:
    Py_XDECREF(arrs[0]);
    Py_XDECREF(arrs[1]);
    return out;
}

PyMethodDef cloud_feature_methods[] = {
    {"resample", py_resample, METH_VARARGS,
     "resample(points, stroke, n) -> (n,) complex128 points equally spaced along the ink (features.py)."},
    {"cloud", py_cloud, METH_VARARGS,
     "cloud(points, stroke, n) -> (2 n,) float32 normalised cloud, x and y interleaved (clouds.py's cloud_features)."},
    {"ink", py_ink, METH_VARARGS,
     "ink(points, stroke, ink_points) -> (3 ink_points,) float32 or None: ndollar.py's ink_features."},
    {"unistroke", py_unistroke, METH_VARARGS,
     "unistroke(path, n, one_d_ratio) -> ((2 n,) float64 unit vector, start angle): ndollar.py's, of one path."},
    {"trace", py_trace, METH_VARARGS,
     "trace(points, times, n, aspect_floor) -> (2 n,) float32: proposed.py's trace_features (finite input only)."},
    {"trace_minima", py_trace_minima, METH_VARARGS,
     "trace_minima(sq_norms, products, query_sq, n_points, class_starts) -> (n_classes,) float64: the trace's class minima."},
    {"relative_sum", py_relative_sum, METH_VARARGS,
     "relative_sum(first, second) -> (n,) float64: fused.py's relative_distances(first) + relative_distances(second)."},
    {"oriented_cells", skin_oriented_cells, METH_VARARGS,
     "oriented_cells(points, stroke, n, grid, bins) -> (n,) intp: oriented.py's raster cells of a touch's cloud."},
    {"oriented_mean", skin_oriented_mean, METH_VARARGS,
     "oriented_mean(fields, cells) -> (T,) float32: fields[cells].mean(axis=0) (oriented.py's distances)."},
    {NULL, NULL, 0, NULL},
};


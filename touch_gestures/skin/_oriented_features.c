/* touch_gestures.skin._cloud_accel, the oriented cloud: the compiled twins of oriented.py's query side
 * (cloud_accel.py). oriented_cells: oriented_cloud then raster_cells of one touch, numpy's arithmetic step by
 * step (the resampling is features.py's, the mean an in-order axis-0 sum over n, the orientation code
 * (dx^2 - dy^2, 2 dx dy) / (dx^2 + dy^2)); oriented_mean: the float32 mean of the fields' rows a query's cells
 * name, rows added in order in float32 and divided once, as oriented.py's gather_mean (numpy's own mean adds a
 * single column pairwise). The same numbers as numpy's where libm's atan2
 * and numpy's agree (a bin can differ only for an orientation within an ulp of a bin's edge;
 * test/test_skin_oriented.py). */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

/* numpy's C API table: _cloud_accel.c's (it imports it once for every unit). */
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#define PY_ARRAY_UNIQUE_SYMBOL social_touch_cloud_accel_ARRAY_API
#define NO_IMPORT_ARRAY
#include <numpy/arrayobject.h>

#include <math.h>

#include "_cloud_features.h"

/* The stroke id of each of n points resampled along the ink: the id of the first knot whose running ink
 * (cum, m values) is at or past the point's (np.searchsorted(cum, target, 'left'), clipped), targets as
 * np.linspace(0, cum[m - 1], n). */
static void resampled_ids(const double *cum, const double *ids, Py_ssize_t m, Py_ssize_t n, double *out)
{
    double total = cum[m - 1];
    double step = n > 1 ? total / (double)(n - 1) : 0.0;
    Py_ssize_t j = 0;
    for (Py_ssize_t k = 0; k < n; k++) {
        double target = (n > 1 && k == n - 1) ? total : (double)k * step;
        while (j < m && cum[j] < target)
            j++;
        Py_ssize_t at = j < m ? j : m - 1;
        out[k] = ids != NULL ? ids[at] : 0.0;
    }
}

/* oriented.py's oriented_cloud of resampled points xy (2 n doubles, changed in place: centred, scaled) with
 * their stroke ids, then raster_cells into cells. 0, or -1 where the cloud is not finite (finite points whose
 * ink or spread overflows a double): no cell is made of a NaN. */
static int cells_of(double *xy, const double *sid, Py_ssize_t n, Py_ssize_t grid, Py_ssize_t bins, npy_intp *cells)
{
    double sx = 0.0, sy = 0.0;
    for (Py_ssize_t k = 0; k < n; k++) {
        sx += xy[2 * k];
        sy += xy[2 * k + 1];
    }
    double mx = sx / (double)n, my = sy / (double)n;
    double lox = INFINITY, hix = -INFINITY, loy = INFINITY, hiy = -INFINITY;
    for (Py_ssize_t k = 0; k < n; k++) {
        double x = xy[2 * k] - mx, y = xy[2 * k + 1] - my;
        xy[2 * k] = x;
        xy[2 * k + 1] = y;
        lox = x < lox ? x : lox;
        hix = x > hix ? x : hix;
        loy = y < loy ? y : loy;
        hiy = y > hiy ? y : hiy;
    }
    double width = hix - lox, height = hiy - loy, size = width >= height ? width : height;
    if (size > 1e-9)
        for (Py_ssize_t k = 0; k < 2 * n; k++)
            xy[k] /= size;
    for (Py_ssize_t k = 0; k < 2 * n; k++)
        if (!isfinite(xy[k]))
            return -1;
    double half_grid = (double)grid / 2.0, per_half_turn = (double)bins / (2.0 * M_PI);
    for (Py_ssize_t k = 0; k < n; k++) {
        Py_ssize_t before = (k > 0 && sid[k - 1] == sid[k]) ? k - 1 : k;
        Py_ssize_t after = (k + 1 < n && sid[k + 1] == sid[k]) ? k + 1 : k;
        double dx = xy[2 * after] - xy[2 * before], dy = xy[2 * after + 1] - xy[2 * before + 1];
        double square = dx * dx + dy * dy;
        Py_ssize_t bin = bins;   /* no orientation */
        if (square > 1e-18) {
            double c = (dx * dx - dy * dy) / square, s = 2.0 * dx * dy / square;
            if (c * c + s * s >= 0.25) {
                bin = (Py_ssize_t)floor(atan2(s, c) * per_half_turn + 0.5) % bins;
                if (bin < 0)
                    bin += bins;
            }
        }
        Py_ssize_t col = (Py_ssize_t)((xy[2 * k] + 1.0) * half_grid);
        Py_ssize_t row = (Py_ssize_t)((xy[2 * k + 1] + 1.0) * half_grid);
        col = col < 0 ? 0 : (col > grid - 1 ? grid - 1 : col);
        row = row < 0 ? 0 : (row > grid - 1 ? grid - 1 : row);
        cells[k] = (npy_intp)((row * grid + col) * (bins + 1) + bin);
    }
    return 0;
}

/* oriented_cells(points, stroke, n, grid, bins) -> (n,) intp: oriented.py's
 * raster_cells(oriented_cloud(points, stroke, n), grid, bins) of finite points (ValueError otherwise;
 * OverflowError where the cloud of finite points is not finite). */
PyObject *skin_oriented_cells(PyObject *Py_UNUSED(module), PyObject *args)
{
    PyObject *points_obj, *ids_obj;
    Py_ssize_t n, grid, bins;
    if (!PyArg_ParseTuple(args, "OOnnn:oriented_cells", &points_obj, &ids_obj, &n, &grid, &bins))
        return NULL;
    if (n < 2 || grid < 1 || bins < 1) {
        PyErr_Format(PyExc_ValueError, "need n >= 2, grid >= 1 and bins >= 1; got %zd, %zd, %zd", n, grid, bins);
        return NULL;
    }
    PyArrayObject *pts, *ids;
    if (skin_path_and_ids(points_obj, ids_obj, &pts, &ids) < 0)
        return NULL;
    Py_ssize_t m = PyArray_DIM(pts, 0);
    const double *p = PyArray_DATA(pts);
    for (Py_ssize_t i = 0; i < 2 * m; i++) {
        if (!isfinite(p[i])) {
            PyErr_SetString(PyExc_ValueError, "an oriented cloud needs finite points (a NaN or infinite one arrived)");
            Py_XDECREF(ids);
            Py_DECREF(pts);
            return NULL;
        }
    }
    npy_intp dims[1] = {n};
    PyObject *out = PyArray_SimpleNew(1, dims, NPY_INTP);
    double *work = PyMem_Malloc((size_t)(m + 3 * n) * sizeof(double));   /* cum (m), xy (2 n), ids (n) */
    if (out != NULL && work != NULL) {
        double *cum = work, *xy = work + m, *sid = work + m + 2 * n;
        const double *idp = ids ? PyArray_DATA(ids) : NULL;
        skin_resample_into(p, idp, m, n, cum, xy);
        resampled_ids(cum, idp, m, n, sid);
        if (cells_of(xy, sid, n, grid, bins, PyArray_DATA((PyArrayObject *)out)) < 0) {
            Py_CLEAR(out);
            PyErr_SetString(PyExc_OverflowError, "the touch's oriented cloud overflows a double (points too far "
                                                 "apart to measure its ink)");
        }
    }
    else if (out != NULL) {
        Py_CLEAR(out);
        PyErr_NoMemory();
    }
    PyMem_Free(work);
    Py_XDECREF(ids);
    Py_DECREF(pts);
    return out;
}

/* oriented_mean(fields, cells) -> (T,) float32: oriented.py's gather_mean(fields, cells) of (C, T) float32 C-contiguous
 * fields and (n,) intp cells, each below C. */
PyObject *skin_oriented_mean(PyObject *Py_UNUSED(module), PyObject *args)
{
    PyObject *fields_obj, *cells_obj;
    if (!PyArg_ParseTuple(args, "OO:oriented_mean", &fields_obj, &cells_obj))
        return NULL;
    if (!PyArray_Check(fields_obj) || PyArray_TYPE((PyArrayObject *)fields_obj) != NPY_FLOAT32
        || PyArray_NDIM((PyArrayObject *)fields_obj) != 2 || !PyArray_IS_C_CONTIGUOUS((PyArrayObject *)fields_obj)) {
        PyErr_SetString(PyExc_ValueError, "fields must be a (cells, templates) float32 C-contiguous array");
        return NULL;
    }
    if (!PyArray_Check(cells_obj) || PyArray_TYPE((PyArrayObject *)cells_obj) != NPY_INTP
        || PyArray_NDIM((PyArrayObject *)cells_obj) != 1 || !PyArray_IS_C_CONTIGUOUS((PyArrayObject *)cells_obj)
        || PyArray_DIM((PyArrayObject *)cells_obj, 0) < 1) {
        PyErr_SetString(PyExc_ValueError, "cells must be a non-empty (n,) intp C-contiguous array");
        return NULL;
    }
    PyArrayObject *fields = (PyArrayObject *)fields_obj, *cells = (PyArrayObject *)cells_obj;
    npy_intp rows = PyArray_DIM(fields, 0), templates = PyArray_DIM(fields, 1), n = PyArray_DIM(cells, 0);
    const npy_intp *cell = PyArray_DATA(cells);
    for (npy_intp i = 0; i < n; i++) {
        if (cell[i] < 0 || cell[i] >= rows) {
            PyErr_Format(PyExc_IndexError, "cell %zd is outside the raster's %zd cells", (Py_ssize_t)cell[i],
                         (Py_ssize_t)rows);
            return NULL;
        }
    }
    npy_intp dims[1] = {templates};
    PyObject *out = PyArray_ZEROS(1, dims, NPY_FLOAT32, 0);
    if (out == NULL)
        return NULL;
    float *acc = PyArray_DATA((PyArrayObject *)out);
    const float *base = PyArray_DATA(fields);
    const float *first = base + cell[0] * templates;
    for (npy_intp t = 0; t < templates; t++)
        acc[t] = first[t];
    for (npy_intp i = 1; i < n; i++) {   /* rows in order, as gather_mean's np.add.accumulate */
        const float *row = base + cell[i] * templates;
        for (npy_intp t = 0; t < templates; t++)
            acc[t] += row[t];
    }
    float count = (float)n;
    for (npy_intp t = 0; t < templates; t++)
        acc[t] /= count;
    return out;
}

/* touch_gestures.skin._cloud_accel: the compiled twin of CloudRecogniser's search (clouds.py, steps 2-3).
 *
 * The numpy path of clouds.py is the reference; this is the same arithmetic without numpy's per-call
 * cost (~30 calls of 1-3 us each per recognition). A Codebook copies what the codebook alone
 * determines, checked once at construction: the templates' distance fields (float32, raster cell x
 * template), their points (float64) and raster cells, their classes. Per query:
 *
 *  1. bounds: each query point reads every template's field at its cell (float32 sums, in the query's
 *     point order, as numpy's sum along axis 0), each template point reads the query's own field
 *     (float32, the minimum over the query's occupied cells of the distance between cell centres, as
 *     clouds.py's cell table), summed per template in ascending cell order with a point count per cell
 *     (scipy's CSR product); their sum times 0.5 / n as float64;
 *  2. the `exact` smallest bounds (the first in template order among equal ones) get the float64 point
 *     distances, their directed Chamfer means and the visit of clouds.py: a template is matched one to
 *     one only if its true Chamfer bound can change the nearest class or the runner-up; where every
 *     query point's nearest template point is a different one that pairing is optimal, else the
 *     optimal assignment is scipy's linear_sum_assignment, called back with the (n, n) costs.
 *
 * Sums are in another order than numpy's in places (numpy sums a contiguous row pairwise, this loop in
 * order): float64 sums of n distances below 3 differ by a few ulp (test/test_skin_cloud_accel.py).
 * Built with -ffp-contract=off (setup.py): a fused multiply-add would round differently from numpy.
 *
 * The features the search reads (resampling, the cloud, $N's ink and unistroke) are in _cloud_features.c.
 *
 * The GIL is held throughout: a recognition is microseconds of work, and the assignment is a Python
 * call. Per-call scratch memory is the call's own, so two threads may share a Codebook (the callback
 * may let another thread in).
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

/* numpy's C API table, shared with _cloud_features.c (this unit imports it: import_array below). */
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#define PY_ARRAY_UNIQUE_SYMBOL social_touch_cloud_accel_ARRAY_API
#include <numpy/arrayobject.h>

/* resample, cloud, ink, unistroke (_cloud_features.c), NULL-terminated: the module's functions. */
extern PyMethodDef cloud_feature_methods[];

#include <math.h>
#include <string.h>

typedef struct {
    PyObject_HEAD
    Py_ssize_t n_templates, n_points, grid, cells, n_classes, exact;
    float *fields;          /* (cells, T) distance of each cell centre to each template's nearest point */
    double *clouds;         /* (T, 2, n) template points: each template's xs, then its ys (loops vectorise) */
    npy_intp *labels;       /* (T,) class of each template */
    npy_intp *cell_starts;  /* (T + 1,) each template's run in cell_ids / cell_counts */
    npy_intp *cell_ids;     /* a template's occupied cells, ascending */
    float *cell_counts;     /* how many of its points fall in each */
    double *centres;        /* (grid,) cell centre coordinate along an axis */
    float *table;           /* (cells, cells) distances between cell centres, float32 (clouds.py's), or NULL */
} Codebook;

/* ------------------------------------------------------------------------------------ helpers */

/* A C-contiguous aligned array of `type` with `ndim` dimensions, or NULL with TypeError/ValueError. */
static PyArrayObject *checked(PyObject *obj, const char *name, int type, int ndim)
{
    if (!PyArray_Check(obj)) {
        PyErr_Format(PyExc_TypeError, "%s must be a numpy array", name);
        return NULL;
    }
    PyArrayObject *a = (PyArrayObject *)obj;
    if (PyArray_TYPE(a) != type || PyArray_NDIM(a) != ndim || !PyArray_IS_C_CONTIGUOUS(a) ||
        !PyArray_ISALIGNED(a) || PyArray_ISBYTESWAPPED(a)) {
        PyObject *want = (PyObject *)PyArray_DescrFromType(type);
        PyErr_Format(PyExc_ValueError, "%s must be a C-contiguous %d-d array of %R; got %d-d %R%s", name, ndim,
                     want, PyArray_NDIM(a), (PyObject *)PyArray_DESCR(a),
                     PyArray_IS_C_CONTIGUOUS(a) ? "" : " (not contiguous)");
        Py_XDECREF(want);
        return NULL;
    }
    return a;
}

/* The raster cell of a point (clouds.py's _cells: truncation, clipped to the raster). */
static inline npy_intp cell_of(double x, double y, Py_ssize_t grid)
{
    double scale = (double)grid / 2.0, v[2] = {(x + 1.0) * scale, (y + 1.0) * scale};
    npy_intp ij[2];
    for (int a = 0; a < 2; a++) {
        /* compared as doubles first: casting a value beyond the integers is undefined */
        ij[a] = !(v[a] >= 1.0) ? 0 : (v[a] >= (double)(grid - 1) ? grid - 1 : (npy_intp)v[a]);
    }
    return ij[0] + ij[1] * grid;
}

static void Codebook_dealloc(Codebook *self)
{
    PyMem_Free(self->fields);
    PyMem_Free(self->clouds);
    PyMem_Free(self->labels);
    PyMem_Free(self->cell_starts);
    PyMem_Free(self->cell_ids);
    PyMem_Free(self->cell_counts);
    PyMem_Free(self->centres);
    PyMem_Free(self->table);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

/* Codebook(fields, clouds, labels, n_classes, grid, exact, table=None): the arrays are copied (a caller
 * changing them later cannot make the kernel read out of bounds). */
static int Codebook_init(Codebook *self, PyObject *args, PyObject *kwds)
{
    static char *kwlist[] = {"fields", "clouds", "labels", "n_classes", "grid", "exact", "table", NULL};
    PyObject *fields_obj, *clouds_obj, *labels_obj, *table_obj = Py_None;
    Py_ssize_t n_classes, grid, exact;
    if (self->fields != NULL) {
        PyErr_SetString(PyExc_TypeError, "a Codebook is initialised once");
        return -1;
    }
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "OOOnnn|O", kwlist, &fields_obj, &clouds_obj, &labels_obj,
                                     &n_classes, &grid, &exact, &table_obj))
        return -1;
    PyArrayObject *fields = checked(fields_obj, "fields", NPY_FLOAT32, 2);
    PyArrayObject *clouds = fields ? checked(clouds_obj, "clouds", NPY_FLOAT64, 3) : NULL;
    PyArrayObject *labels = clouds ? checked(labels_obj, "labels", NPY_INTP, 1) : NULL;
    if (labels == NULL)
        return -1;
    npy_intp T = PyArray_DIM(clouds, 0), n = PyArray_DIM(clouds, 1);
    if (grid < 2 || grid > 4096 || exact < 0 || n_classes < 1 || T < 1 || n < 1 || PyArray_DIM(clouds, 2) != 2 ||
        PyArray_DIM(fields, 0) != grid * grid || PyArray_DIM(fields, 1) != T || PyArray_DIM(labels, 0) != T) {
        PyErr_Format(PyExc_ValueError, "need fields (grid * grid, T), clouds (T, n, 2), labels (T,), grid in "
                     "2..4096, exact >= 0 and n_classes >= 1; got fields (%zd, %zd), clouds (%zd, %zd, %zd), "
                     "labels (%zd,), grid %zd, exact %zd, n_classes %zd", (Py_ssize_t)PyArray_DIM(fields, 0),
                     (Py_ssize_t)PyArray_DIM(fields, 1), (Py_ssize_t)T, (Py_ssize_t)n,
                     (Py_ssize_t)PyArray_DIM(clouds, 2), (Py_ssize_t)PyArray_DIM(labels, 0), grid, exact, n_classes);
        return -1;
    }
    PyArrayObject *table = NULL;
    if (table_obj != Py_None) {
        table = checked(table_obj, "table", NPY_FLOAT32, 2);
        if (table == NULL)
            return -1;
        if (PyArray_DIM(table, 0) != grid * grid || PyArray_DIM(table, 1) != grid * grid) {
            PyErr_Format(PyExc_ValueError, "table must be (grid * grid, grid * grid) = (%zd, %zd)", grid * grid,
                         grid * grid);
            return -1;
        }
    }
    const npy_intp *lab = (const npy_intp *)PyArray_DATA(labels);
    const double *pts = (const double *)PyArray_DATA(clouds);
    for (npy_intp t = 0; t < T; t++) {
        if (lab[t] < 0 || lab[t] >= n_classes) {
            PyErr_Format(PyExc_ValueError, "labels[%zd] = %zd is not a class of %zd", (Py_ssize_t)t,
                         (Py_ssize_t)lab[t], n_classes);
            return -1;
        }
    }
    for (npy_intp i = 0; i < 2 * T * n; i++) {
        if (!isfinite(pts[i])) {
            PyErr_SetString(PyExc_ValueError, "clouds contain NaN or infinite values");
            return -1;
        }
    }
    size_t cells = (size_t)grid * (size_t)grid;
    self->fields = PyMem_Malloc(cells * (size_t)T * sizeof(float));
    self->clouds = PyMem_Malloc((size_t)(2 * T * n) * sizeof(double));
    self->labels = PyMem_Malloc((size_t)T * sizeof(npy_intp));
    self->cell_starts = PyMem_Malloc((size_t)(T + 1) * sizeof(npy_intp));
    self->cell_ids = PyMem_Malloc((size_t)(T * n) * sizeof(npy_intp));
    self->cell_counts = PyMem_Malloc((size_t)(T * n) * sizeof(float));
    self->centres = PyMem_Malloc((size_t)grid * sizeof(double));
    if (!self->fields || !self->clouds || !self->labels || !self->cell_starts || !self->cell_ids ||
        !self->cell_counts || !self->centres) {
        PyErr_NoMemory();
        return -1;   /* dealloc frees what was allocated */
    }
    if (table != NULL) {
        self->table = PyMem_Malloc(cells * cells * sizeof(float));
        if (self->table == NULL) {
            PyErr_NoMemory();
            return -1;
        }
        memcpy(self->table, PyArray_DATA(table), cells * cells * sizeof(float));
    }
    memcpy(self->fields, PyArray_DATA(fields), cells * (size_t)T * sizeof(float));
    for (npy_intp t = 0; t < T; t++) {
        for (npy_intp j = 0; j < n; j++) {
            self->clouds[2 * n * t + j] = pts[2 * (t * n + j)];
            self->clouds[2 * n * t + n + j] = pts[2 * (t * n + j) + 1];
        }
    }
    memcpy(self->labels, lab, (size_t)T * sizeof(npy_intp));
    double side = 2.0 / (double)grid;   /* clouds.py: (arange(g) + 0.5) * (2 / g) - 1 */
    for (Py_ssize_t i = 0; i < grid; i++)
        self->centres[i] = ((double)i + 0.5) * side - 1.0;
    /* Each template's cells, ascending with their point counts (insertion sort: n is small). */
    npy_intp at = 0, *sorted = PyMem_Malloc((size_t)n * sizeof(npy_intp));
    if (sorted == NULL) {
        PyErr_NoMemory();
        return -1;
    }
    for (npy_intp t = 0; t < T; t++) {
        self->cell_starts[t] = at;
        for (npy_intp j = 0; j < n; j++) {
            npy_intp c = cell_of(pts[2 * (t * n + j)], pts[2 * (t * n + j) + 1], grid), k = j;
            for (; k > 0 && sorted[k - 1] > c; k--)
                sorted[k] = sorted[k - 1];
            sorted[k] = c;
        }
        for (npy_intp j = 0; j < n; j++) {
            if (j > 0 && sorted[j] == sorted[j - 1]) {
                self->cell_counts[at - 1] += 1.0f;
            } else {
                self->cell_ids[at] = sorted[j];
                self->cell_counts[at++] = 1.0f;
            }
        }
    }
    self->cell_starts[T] = at;
    PyMem_Free(sorted);
    self->n_templates = T;
    self->n_points = n;
    self->grid = grid;
    self->cells = (Py_ssize_t)cells;
    self->n_classes = n_classes;
    self->exact = exact;
    return 0;
}

/* The query as (n, 2) float64 points, checked: shape, dtype, contiguity, finite values. */
static PyArrayObject *query_points(Codebook *self, PyObject *obj)
{
    PyArrayObject *q = checked(obj, "query", NPY_FLOAT64, 2);
    if (q == NULL)
        return NULL;
    if (PyArray_DIM(q, 0) != self->n_points || PyArray_DIM(q, 1) != 2) {
        PyErr_Format(PyExc_ValueError, "query must be (%zd, 2) points; got (%zd, %zd)", self->n_points,
                     (Py_ssize_t)PyArray_DIM(q, 0), (Py_ssize_t)PyArray_DIM(q, 1));
        return NULL;
    }
    const double *p = (const double *)PyArray_DATA(q);
    for (Py_ssize_t i = 0; i < 2 * self->n_points; i++) {
        if (!isfinite(p[i])) {
            PyErr_SetString(PyExc_ValueError, "query contains NaN or infinite values");
            return NULL;
        }
    }
    return q;
}

/* Step 1 into out (T,) float64; scratch holds T + cells floats, qcells n cells then 2 n doubles. */
static void raster_bounds(const Codebook *self, const double *q, double *out, float *scratch, npy_intp *qcells)
{
    const Py_ssize_t T = self->n_templates, n = self->n_points, g = self->grid;
    float *sums = scratch, *field = scratch + T;
    Py_ssize_t distinct = 0;
    for (Py_ssize_t t = 0; t < T; t++)
        sums[t] = 0.0f;
    for (Py_ssize_t j = 0; j < n; j++) {
        npy_intp c = cell_of(q[2 * j], q[2 * j + 1], g);
        const float *row = self->fields + (size_t)c * (size_t)T;
        for (Py_ssize_t t = 0; t < T; t++)
            sums[t] += row[t];
        Py_ssize_t k = 0;
        while (k < distinct && qcells[k] != c)
            k++;
        if (k == distinct)
            qcells[distinct++] = c;
    }
    /* The query's field: the minimum over its occupied cells of the distance between cell centres, as
     * float32 (clouds.py's table rows; without a table, the same float64 squares, their minimum, its root:
     * the root and the rounding keep the order, so the same numbers). */
    if (self->table != NULL) {
        memcpy(field, self->table + (size_t)qcells[0] * (size_t)self->cells, (size_t)self->cells * sizeof(float));
        for (Py_ssize_t k = 1; k < distinct; k++) {
            const float *row = self->table + (size_t)qcells[k] * (size_t)self->cells;
            for (Py_ssize_t c = 0; c < self->cells; c++)
                field[c] = row[c] < field[c] ? row[c] : field[c];
        }
    } else {
        double *qx = (double *)(qcells + n), *qy = qx + n;   /* the distinct cells' centres */
        for (Py_ssize_t k = 0; k < distinct; k++) {
            qx[k] = self->centres[qcells[k] % g];
            qy[k] = self->centres[qcells[k] / g];
        }
        for (Py_ssize_t row = 0; row < g; row++) {
            for (Py_ssize_t col = 0; col < g; col++) {
                double best = INFINITY;
                for (Py_ssize_t k = 0; k < distinct; k++) {
                    double dx = self->centres[col] - qx[k], dy = self->centres[row] - qy[k];
                    double d = dx * dx + dy * dy;
                    best = d < best ? d : best;
                }
                field[row * g + col] = (float)sqrt(best);
            }
        }
    }
    const double scale = 0.5 / (double)n;
    for (Py_ssize_t t = 0; t < T; t++) {
        float back = 0.0f;
        for (npy_intp i = self->cell_starts[t]; i < self->cell_starts[t + 1]; i++)
            back += self->cell_counts[i] * field[self->cell_ids[i]];
        out[t] = (double)(sums[t] + back) * scale;
    }
}

/* Mean cost of the optimal one-to-one matching of the (n, n) distances whose squares are `squares`, by
 * `solve` (scipy.optimize.linear_sum_assignment); -1 with an exception set on failure. */
static double assignment(PyObject *solve, const double *squares, Py_ssize_t n)
{
    npy_intp dims[2] = {n, n};
    PyObject *matrix = PyArray_SimpleNew(2, dims, NPY_FLOAT64);
    if (matrix == NULL)
        return -1.0;
    double *cost = (double *)PyArray_DATA((PyArrayObject *)matrix);
    for (Py_ssize_t i = 0; i < n * n; i++)
        cost[i] = sqrt(squares[i]);
    PyObject *pairs = PyObject_CallOneArg(solve, matrix);
    if (pairs == NULL) {
        Py_DECREF(matrix);
        return -1.0;
    }
    double total = -1.0;
    PyObject *rows = NULL, *cols = NULL;
    if (!PyTuple_Check(pairs) || PyTuple_GET_SIZE(pairs) != 2) {
        PyErr_SetString(PyExc_TypeError, "the assignment solver must return (rows, columns)");
        goto done;
    }
    rows = PyArray_FROMANY(PyTuple_GET_ITEM(pairs, 0), NPY_INTP, 1, 1, NPY_ARRAY_CARRAY_RO);
    cols = rows ? PyArray_FROMANY(PyTuple_GET_ITEM(pairs, 1), NPY_INTP, 1, 1, NPY_ARRAY_CARRAY_RO) : NULL;
    if (cols == NULL)
        goto done;
    npy_intp m = PyArray_DIM((PyArrayObject *)rows, 0);
    if (m != n || PyArray_DIM((PyArrayObject *)cols, 0) != n) {
        PyErr_Format(PyExc_ValueError, "the assignment solver paired %zd rows of %zd", (Py_ssize_t)m, n);
        goto done;
    }
    const npy_intp *r = PyArray_DATA((PyArrayObject *)rows), *c = PyArray_DATA((PyArrayObject *)cols);
    double sum = 0.0;
    for (npy_intp i = 0; i < m; i++) {
        if (r[i] < 0 || r[i] >= n || c[i] < 0 || c[i] >= n) {
            PyErr_SetString(PyExc_ValueError, "the assignment solver gave an index outside the matrix");
            goto done;
        }
        sum += cost[r[i] * n + c[i]];
    }
    total = sum / (double)m;
done:
    Py_XDECREF(rows);
    Py_XDECREF(cols);
    Py_DECREF(pairs);
    Py_DECREF(matrix);
    return total;
}

/* Step 2 on the bounds in out (T,), in place (clouds.py's _distances after _bounds); 0, or -1 on error. */
static int exact_search(const Codebook *self, const double *q, double *out, PyObject *solve)
{
    const Py_ssize_t T = self->n_templates, n = self->n_points, k = self->exact < T ? self->exact : T;
    if (k == 0)
        return 0;
    /* One block: (k, n, n) squared point distances; k each of means both ways, bounds, costs; n_classes
     * settled; n column minima; k closest, k visit order, (k, n) nearest; n seen. */
    size_t doubles = (size_t)(k * n * n) + 4 * (size_t)k + (size_t)self->n_classes + (size_t)n;
    size_t indices = 2 * (size_t)k + (size_t)(k * n);
    char *block = PyMem_Malloc(doubles * sizeof(double) + indices * sizeof(npy_intp) + (size_t)n);
    if (block == NULL) {
        PyErr_NoMemory();
        return -1;
    }
    double *pair = (double *)block, *to_template = pair + k * n * n, *bound = to_template + k;
    double *cost = bound + k, *from_template = cost + k, *settled = from_template + k;
    double *column = settled + self->n_classes;   /* n: a template point's nearest query point, squared */
    npy_intp *closest = (npy_intp *)(column + n), *order = closest + k, *nearest = order + k;
    char *seen = (char *)(nearest + k * n);
    int status = -1;

    /* The k smallest bounds, the first in template order among equal ones (insertion into a sorted k). */
    Py_ssize_t have = 0;
    for (Py_ssize_t t = 0; t < T; t++) {
        if (have == k && !(out[t] < out[closest[k - 1]]))
            continue;
        Py_ssize_t i = have < k ? have++ : k - 1;
        for (; i > 0 && out[t] < out[closest[i - 1]]; i--)
            closest[i] = closest[i - 1];
        closest[i] = t;
    }
    for (Py_ssize_t i = 0; i < k; i++) {
        /* Squared point distances: the nearest by them is the nearest by distance, and the root of the
         * smallest square is the smallest root (what cdist then min gives); the Hungarian gets the roots. */
        const double *tx = self->clouds + 2 * n * closest[i], *ty = tx + n;
        double *d = pair + i * n * n, forward = 0.0, backward = 0.0;
        for (Py_ssize_t a = 0; a < n; a++) {
            double qx = q[2 * a], qy = q[2 * a + 1], *row = d + a * n;
            for (Py_ssize_t b = 0; b < n; b++) {
                double dx = qx - tx[b], dy = qy - ty[b];
                row[b] = dx * dx + dy * dy;
            }
            for (Py_ssize_t b = 0; b < n; b++)
                column[b] = a == 0 || row[b] < column[b] ? row[b] : column[b];
            npy_intp best = 0;
            for (Py_ssize_t b = 1; b < n; b++)
                best = row[b] < row[best] ? b : best;
            nearest[i * n + a] = best;
            forward += sqrt(row[best]);
        }
        for (Py_ssize_t b = 0; b < n; b++)
            backward += sqrt(column[b]);
        to_template[i] = forward / (double)n;
        from_template[i] = backward / (double)n;
        bound[i] = cost[i] = to_template[i] > from_template[i] ? to_template[i] : from_template[i];
        Py_ssize_t j = i;   /* the visit's order: by bound, stable (Python's sorted) */
        for (; j > 0 && bound[order[j - 1]] > bound[i]; j--)
            order[j] = order[j - 1];
        order[j] = i;
    }
    for (Py_ssize_t c = 0; c < self->n_classes; c++)
        settled[c] = INFINITY;
    double first = INFINITY, second = INFINITY;
    for (Py_ssize_t v = 0; v < k; v++) {
        Py_ssize_t i = order[v];
        if (bound[i] >= second)
            break;                 /* neither the nearest class nor the runner-up can change */
        npy_intp c = self->labels[closest[i]];
        if (bound[i] >= settled[c])
            continue;              /* its cost is at least its bound: it cannot lower its class's distance */
        memset(seen, 0, (size_t)n);
        int distinct = 1;
        for (Py_ssize_t a = 0; a < n && distinct; a++) {
            distinct = !seen[nearest[i * n + a]];
            seen[nearest[i * n + a]] = 1;
        }
        double matched = distinct ? to_template[i] : assignment(solve, pair + i * n * n, n);
        if (matched < 0)
            goto done;
        cost[i] = matched;
        if (0.0 < matched && matched < settled[c]) {
            double was = settled[c];
            settled[c] = matched;
            if (was == first)
                first = matched;
            else if (matched < first) {
                second = first;
                first = matched;
            } else if (matched < second)
                second = matched;
        }
    }
    /* The others were ranked farther: none is taken as closer than the farthest of the closest. */
    double farthest = cost[0];
    for (Py_ssize_t i = 1; i < k; i++)
        farthest = cost[i] > farthest ? cost[i] : farthest;
    for (Py_ssize_t t = 0; t < T; t++)
        out[t] = out[t] > farthest ? out[t] : farthest;
    for (Py_ssize_t i = 0; i < k; i++)
        out[closest[i]] = cost[i];
    status = 0;
done:
    PyMem_Free(block);
    return status;
}

/* bounds(query) -> (T,) float64: step 1 alone (clouds.py's _bounds). */
static PyObject *Codebook_bounds(Codebook *self, PyObject *query)
{
    if (self->n_templates == 0) {   /* set last by a successful __init__ */
        PyErr_SetString(PyExc_ValueError, "the Codebook was not initialised");
        return NULL;
    }
    PyArrayObject *q = query_points(self, query);
    if (q == NULL)
        return NULL;
    npy_intp dims[1] = {self->n_templates};
    PyObject *out = PyArray_SimpleNew(1, dims, NPY_FLOAT64);
    float *scratch = PyMem_Malloc((size_t)(self->n_templates + self->cells) * sizeof(float));
    npy_intp *qcells = PyMem_Malloc((size_t)self->n_points * (sizeof(npy_intp) + 2 * sizeof(double)));
    if (out == NULL || scratch == NULL || qcells == NULL) {
        Py_XDECREF(out);
        PyMem_Free(scratch);
        PyMem_Free(qcells);
        return out == NULL ? NULL : PyErr_NoMemory();
    }
    raster_bounds(self, (const double *)PyArray_DATA(q), (double *)PyArray_DATA((PyArrayObject *)out), scratch,
                  qcells);
    PyMem_Free(scratch);
    PyMem_Free(qcells);
    return out;
}

/* distances(query, solve) -> (T,) float64: clouds.py's _distances. */
static PyObject *Codebook_distances(Codebook *self, PyObject *args)
{
    PyObject *query, *solve;
    if (!PyArg_ParseTuple(args, "OO:distances", &query, &solve))
        return NULL;
    if (!PyCallable_Check(solve)) {
        PyErr_SetString(PyExc_TypeError, "solve must be callable (scipy.optimize.linear_sum_assignment)");
        return NULL;
    }
    PyObject *out = Codebook_bounds(self, query);
    if (out == NULL)
        return NULL;
    if (exact_search(self, (const double *)PyArray_DATA((PyArrayObject *)query),
                     (double *)PyArray_DATA((PyArrayObject *)out), solve) < 0) {
        Py_DECREF(out);
        return NULL;
    }
    return out;
}

/* A Codebook never changes after __init__: a copy (copy.copy, copy.deepcopy of a recogniser) shares it. */
static PyObject *Codebook_copy(PyObject *self, PyObject *Py_UNUSED(ignored))
{
    return Py_NewRef(self);
}

static PyMethodDef Codebook_methods[] = {
    {"__copy__", (PyCFunction)Codebook_copy, METH_NOARGS, "The codebook itself (it never changes)."},
    {"__deepcopy__", (PyCFunction)Codebook_copy, METH_O, "The codebook itself (it never changes)."},
    {"bounds", (PyCFunction)Codebook_bounds, METH_O,
     "bounds(query) -> (T,) float64 raster Chamfer distances of the (n, 2) float64 query."},
    {"distances", (PyCFunction)Codebook_distances, METH_VARARGS,
     "distances(query, solve) -> (T,) float64 distances (clouds.py's _distances); solve(cost) -> (rows, cols)."},
    {NULL, NULL, 0, NULL},
};

static PyTypeObject CodebookType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "touch_gestures.skin._cloud_accel.Codebook",
    .tp_basicsize = sizeof(Codebook),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "Codebook(fields, clouds, labels, n_classes, grid, exact): a cloud codebook for the compiled search.",
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)Codebook_init,
    .tp_dealloc = (destructor)Codebook_dealloc,
    .tp_methods = Codebook_methods,
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_cloud_accel",
    "The compiled search of touch_gestures.skin.clouds (touch_gestures/skin/cloud_accel.py).", -1, cloud_feature_methods,
};

PyMODINIT_FUNC PyInit__cloud_accel(void)
{
    if (_import_array() < 0)
        return NULL;
    if (PyType_Ready(&CodebookType) < 0)
        return NULL;
    PyObject *m = PyModule_Create(&module);
    if (m == NULL)
        return NULL;
    Py_INCREF(&CodebookType);
    if (PyModule_AddObject(m, "Codebook", (PyObject *)&CodebookType) < 0) {
        Py_DECREF(&CodebookType);
        Py_DECREF(m);
        return NULL;
    }
    return m;
}

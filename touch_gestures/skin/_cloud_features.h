/* What the units of touch_gestures.skin._cloud_accel share: _cloud_features.c's path helpers, used by
 * _oriented_features.c, and _oriented_features.c's functions, in _cloud_features.c's method table. */
#ifndef SOCIAL_TOUCH_CLOUD_FEATURES_H
#define SOCIAL_TOUCH_CLOUD_FEATURES_H

#include <Python.h>

/* A path's (m, 2) float64 points and its (m,) stroke ids as float64 (NULL for None): new references, or -1
 * with an exception and nothing held. */
int skin_path_and_ids(PyObject *points_obj, PyObject *ids_obj, PyArrayObject **pts, PyArrayObject **ids);
/* features.py's arc_length_resample_complex of m points (ids NULL: one stroke) into out (2 n doubles); cum
 * (m doubles) is left holding the running ink length at each point. */
void skin_resample_into(const double *p, const double *ids, Py_ssize_t m, Py_ssize_t n, double *cum, double *out);

PyObject *skin_oriented_cells(PyObject *module, PyObject *args);
PyObject *skin_oriented_mean(PyObject *module, PyObject *args);

#endif
